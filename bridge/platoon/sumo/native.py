"""The SUMO plant's per-vehicle loop of a step in C++ (cpp/sumo_step.cpp), called once
per step from the bridge's own Python process: set every acceleration, step SUMO, read every
lane position and speed (and the radars, and the background vehicles) back. The bridge stays the
Python process that starts and configures SUMO; only these libsumo calls leave Python, and no
arithmetic does (the values are copied, so both paths give the same bits: tests/sumo.rs).

PLATOON_SUMO_NATIVE chooses:
  unset  the C++ loop, built on first use; without a C++ compiler, the Python loop and a
         one-line warning in the plant's log (logs/plant.log)
  1      the C++ loop, or the run fails saying why (no compiler, a failed build)
  0      the Python loop (libsumo's Python API, one call per vehicle and quantity)

The helper is compiled with g++ (or $CXX) against the `libsumo` wheel's _libsumo.so, which
exports libsumo's C++ API (cpp/libsumo_api.h declares the few functions called), into
<the venv>/platoon-native/ (or ~/.cache/platoon/native when the venv is read-only;
PLATOON_SUMO_NATIVE_CACHE names another directory), named by a hash of its sources, the flags
and that _libsumo.so: compiled once (about a second), to a temporary name, then renamed, so
concurrent plants never load half a file.
"""

import ctypes
import glob
import hashlib
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = [os.path.join(HERE, "cpp", "libsumo_api.h"), os.path.join(HERE, "cpp", "sumo_step.cpp")]
FLAGS = ["-std=c++17", "-O2", "-fPIC", "-shared", "-ffp-contract=off", "-Wall"]


class NativeError(Exception):
    """The C++ loop could not be built or loaded, or libsumo raised inside it (the message is
    libsumo's, as the Python loop would have reported it)."""


def choice() -> str:
    """'auto', 'native' or 'python', from PLATOON_SUMO_NATIVE."""
    value = os.environ.get("PLATOON_SUMO_NATIVE", "").strip()
    if value == "":
        return "auto"
    if value in ("0", "1"):
        return "python" if value == "0" else "native"
    raise NativeError(f"PLATOON_SUMO_NATIVE={value!r}: use 1 (the C++ loop) or 0 (the Python loop)")


def _libsumo_so(libsumo) -> str:
    found = sorted(glob.glob(os.path.join(os.path.dirname(libsumo.__file__), "_libsumo*.so")))
    if not found:
        raise NativeError(f"no _libsumo*.so beside {libsumo.__file__}")
    return os.path.realpath(found[0])


def _cache_dirs():
    if os.environ.get("PLATOON_SUMO_NATIVE_CACHE"):
        yield os.environ["PLATOON_SUMO_NATIVE_CACHE"]
        return
    yield os.path.join(sys.prefix, "platoon-native")
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    yield os.path.join(cache, "platoon", "native")


def build(libsumo) -> str:
    """The path of the compiled helper for this libsumo, compiling it if it is not there."""
    so = _libsumo_so(libsumo)
    h = hashlib.sha256()
    for path in SOURCES:
        with open(path, "rb") as f:
            h.update(f.read())
    st = os.stat(so)
    h.update(repr((FLAGS, so, st.st_size, st.st_mtime_ns)).encode())
    name = f"sumo_step-{h.hexdigest()[:16]}.so"
    dirs = list(_cache_dirs())
    for d in dirs:
        if os.path.exists(os.path.join(d, name)):
            return os.path.join(d, name)
    cxx = os.environ.get("CXX") or shutil.which("g++") or shutil.which("c++")
    if not cxx or not shutil.which(cxx):
        raise NativeError(
            "no C++ compiler (g++) to build the SUMO bridge's C++ loop: install g++ "
            "(Debian/Ubuntu: apt-get install g++), or set PLATOON_SUMO_NATIVE=0 for the Python loop"
        )
    errors = []
    for d in dirs:
        target = os.path.join(d, name)
        try:
            os.makedirs(d, exist_ok=True)
        except OSError as e:
            errors.append(f"{d}: {e}")
            continue
        if not os.access(d, os.W_OK):
            errors.append(f"{d}: not writable")
            continue
        tmp = f"{target}.{os.getpid()}.tmp"
        # Linked against the wheel's _libsumo.so by its path: loading the helper finds it
        # already loaded by `import libsumo` and resolves libsumo's functions from it.
        cmd = [cxx, *FLAGS, "-o", tmp, SOURCES[1], so]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise NativeError(f"building the SUMO bridge's C++ loop failed ({' '.join(cmd)}):\n{r.stderr.strip()}")
        os.replace(tmp, target)
        return target
    raise NativeError("no writable directory for the SUMO bridge's C++ loop: " + "; ".join(errors))


_P = ctypes.c_void_p


def _load(path):
    lib = ctypes.CDLL(path)
    lib.platoon_fleet_new.restype = _P
    lib.platoon_fleet_new.argtypes = [_P, ctypes.c_int32, _P, ctypes.c_int32, ctypes.c_double, _P, ctypes.c_int32, _P]
    lib.platoon_fleet_free.argtypes = [_P]
    lib.platoon_fleet_error.restype = ctypes.c_char_p
    lib.platoon_fleet_error.argtypes = [_P]
    lib.platoon_fleet_subscribe.restype = ctypes.c_int32
    lib.platoon_fleet_subscribe.argtypes = [_P, ctypes.c_int32]
    lib.platoon_fleet_read.restype = ctypes.c_int32
    lib.platoon_fleet_read.argtypes = [_P]
    lib.platoon_fleet_step.restype = ctypes.c_int32
    lib.platoon_fleet_step.argtypes = [_P, ctypes.c_double]
    lib.platoon_fleet_traffic.restype = ctypes.c_int32
    lib.platoon_fleet_traffic.argtypes = [_P]
    return lib


def _strings(names):
    raw = [n.encode() for n in names]
    return raw, (ctypes.c_char_p * max(1, len(raw)))(*raw)


class Fleet:
    """The platoon vehicles `ids` (wire order), the followers with a radar (`followers`, indices
    into ids, read when `radar_range` is not None) and the background vehicles, driven through
    the C++ loop. After `step` (or `states`) the arrays hold what SUMO has: `lane` and `speed` per
    vehicle, `ahead` (0: nothing, 1: the predecessor, 2: another vehicle), `gap` and
    `ahead_speed` per radar follower."""

    def __init__(self, libsumo, ids, followers=(), radar_range=None, background=()):
        self.lib = _load(build(libsumo))
        n, m, nb = len(ids), len(followers), len(background)
        self._keep = [_strings(ids), _strings(background)]
        self.followers = np.array(followers, dtype=np.int32)
        # The buffers the helper reads and fills, given to it once (kept alive by self).
        self.accel = np.zeros(n)
        self.lane, self.speed = np.zeros(n), np.zeros(n)
        self.ahead = np.zeros(m, dtype=np.uint8)
        self.gap, self.ahead_speed = np.zeros(m), np.zeros(m)
        self.ns = (ctypes.c_int64 * 2)()
        self.on_road = np.zeros(nb, dtype=np.uint8)
        self.bg_lane = np.zeros(nb)
        arrays = [self.accel, self.lane, self.speed, self.ahead, self.gap, self.ahead_speed,
                  self.ns, self.on_road, self.bg_lane]
        self._arrays = (_P * len(arrays))(*[ctypes.addressof(a) if isinstance(a, ctypes.Array)
                                             else a.ctypes.data for a in arrays])
        self.handle = self.lib.platoon_fleet_new(
            self._keep[0][1], n, self.followers.ctypes.data, m,
            -1.0 if radar_range is None else float(radar_range), self._keep[1][1], nb,
            self._arrays,
        )
        self._step, self._read = self.lib.platoon_fleet_step, self.lib.platoon_fleet_read
        # The helper must drive the SUMO this process started (the _libsumo.so `import libsumo`
        # loaded, not a second copy): it reads the vehicles once, changing nothing.
        if n and self._read(self.handle):
            error = self._error()
            self.close()
            raise NativeError(f"the C++ loop does not see the bridge's SUMO: {error}")
        self.filled = False  # the arrays hold the state after the last step, not yet read
        self.pending = None  # a read that failed after the step: raised when the states are read

    def close(self):
        if self.handle:
            self.lib.platoon_fleet_free(self.handle)
            self.handle = None

    def _error(self):
        return self.lib.platoon_fleet_error(self.handle).decode(errors="replace")

    def subscribe(self, how):
        """Read through libsumo subscriptions (1: per vehicle, 2: all at once): measured by
        bench_sumo.py, never used by the plant."""
        if self.lib.platoon_fleet_subscribe(self.handle, how):
            raise NativeError(self._error())

    def step(self, accel, duration):
        """setAcceleration(id, accel[i], duration) for every vehicle, SUMO's step, and the read.
        Raises what SUMO raised while setting or stepping; a failed read is held until `states`,
        where the Python loop reads. Returns SUMO's step alone: (wall ns, thread CPU ns)."""
        self.accel[:] = accel
        rc = self._step(self.handle, duration)
        if rc == 1:
            raise NativeError(self._error())
        self.pending = self._error() if rc == 2 else None
        self.filled = True
        return self.ns[0], self.ns[1]

    def states(self):
        """(lane, speed) arrays of the current SUMO step (read now unless a step just did)."""
        if not self.filled:
            if self._read(self.handle):
                raise NativeError(self._error())
        self.filled = False
        if self.pending is not None:
            raise NativeError(self.pending)
        return self.lane, self.speed

    def reread(self):
        """Reads the current SUMO step again (after the bridge changed the lane: a cut-in
        entered or left), for `states` and the radars."""
        if self._read(self.handle):
            raise NativeError(self._error())

    def traffic(self, on_road):
        """The background vehicles' lane positions (array; meaningful where on_road), and
        on_road with those SUMO no longer knows cleared (in place, a list of bools)."""
        self.on_road[:] = on_road
        if self.lib.platoon_fleet_traffic(self.handle):
            raise NativeError(self._error())
        on_road[:] = self.on_road.astype(bool).tolist()
        return self.bg_lane


def open_fleet(libsumo, ids, followers=(), radar_range=None, background=(), say=None):
    """A `Fleet` when PLATOON_SUMO_NATIVE chooses the C++ loop, else None (the Python loop).
    Unset, a helper that cannot be built is a warning through `say` and the Python loop."""
    how = choice()
    if how == "python":
        return None
    try:
        return Fleet(libsumo, ids, followers, radar_range, background)
    except (NativeError, OSError) as e:
        if how == "native":
            raise NativeError(f"PLATOON_SUMO_NATIVE=1: {e}") from None
        if say is not None:
            say(f"warning: stepping SUMO from Python (slower): {str(e).splitlines()[0]}")
        return None
