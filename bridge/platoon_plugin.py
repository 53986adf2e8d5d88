"""Old name of platoon.plugin (kept for scripts written before the package): the same module."""

import sys

import platoon.plugin as _m

sys.modules[__name__] = _m
