"""The `platoon` command installed with the package: the same program as the Rust binary."""

import os
import signal
import sys


def main():
    from . import _core, _program

    _program()
    # The command handles SIGINT itself where it can stop cleanly (run, campaign); elsewhere
    # Ctrl-C ends it, as it ends the binary, rather than waking Python after the fact.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    code = _core.cli(["platoon", *sys.argv[1:]])
    sys.stdout.flush()
    sys.stderr.flush()
    sys.exit(code)
