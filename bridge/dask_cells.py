"""Old path of the Dask driver (platoon.dask.cells, run as `python -m platoon.dask`): run, it runs
that; imported, it is platoon.dask.cells; either after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, module="platoon.dask.cells", run="platoon.dask")
