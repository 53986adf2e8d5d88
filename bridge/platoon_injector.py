"""Old name of platoon.injector (kept for scripts written before the package): the same module."""

import sys

import platoon.injector as _m

sys.modules[__name__] = _m
