"""Old name of platoon.controller (kept for scripts written before the package): the same module."""

import sys

import platoon.controller as _m

sys.modules[__name__] = _m
