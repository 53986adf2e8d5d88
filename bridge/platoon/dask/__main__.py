"""`python -m platoon.dask SCHEDULER_ADDRESS PLATOON_EXE`: the Dask driver (platoon.dask.cells)."""

from platoon.dask.cells import exit_with, main

exit_with(main())
