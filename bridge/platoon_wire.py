"""Old name of platoon.wire: the same module, after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, module="platoon.wire")
