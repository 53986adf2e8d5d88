"""Old path of bridge/tools/bench_peers.py: runs it after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, run="tools/bench_peers.py")
