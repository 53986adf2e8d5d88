"""Campaign cells on a Dask cluster: the driver `platoon campaign --dask ADDRESS` starts as
`python -m platoon.dask` (platoon.dask.cells), and the batch task its workers run."""
