"""Old path of the SUMO plant (platoon.sumo.plant, run as `python -m platoon.sumo`): run, it runs
that; imported, it is platoon.sumo.plant; either after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, module="platoon.sumo.plant", run="platoon.sumo")
