"""Old name of platoon.sumo.native: the same module, after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, module="platoon.sumo.native")
