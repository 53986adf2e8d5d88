"""Old name of platoon.sumo.model: the same module, after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, module="platoon.sumo.model")
