"""Old path of bridge/tools/plexe_reference.py: runs it after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, run="tools/plexe_reference.py")
