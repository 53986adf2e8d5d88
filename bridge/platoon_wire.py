"""Old name of platoon.wire (kept for scripts written before the package): the same module."""

import sys

import platoon.wire as _m

sys.modules[__name__] = _m
