#!/bin/sh
# Creates bridge/.venv with the pinned packages of bridge/requirements.txt, once; later calls
# only check it. Used by .ci/run and by anyone running a Python injector or the SUMO bridge.
# The SUMO plant's C++ loop is not built here: the plant compiles it on first use, into this
# venv (platoon/sumo/native.py; needs g++, else the plant warns and steps SUMO from Python).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
stamp="$venv/.requirements"
# The venv's Python imports the SDK (platoon.injector, platoon.wire) from a script anywhere:
# a .pth file in its site-packages names this directory (rewritten if the checkout moved).
bridge_on_path() {
    for site in "$venv"/lib/python*/site-packages; do
        [ -d "$site" ] || continue
        pth="$site/platoon-bridge.pth"
        if [ "$(cat "$pth" 2>/dev/null)" != "$here" ]; then
            printf '%s\n' "$here" >"$pth.$$" && mv -f "$pth.$$" "$pth"
        fi
    done
}
if [ -f "$stamp" ] && cmp -s "$stamp" "$here/requirements.txt"; then
    bridge_on_path
    exit 0
fi
python=${PYTHON:-python3}
if ! command -v "$python" >/dev/null 2>&1; then
    echo "error: $python not found; install Python 3.10+ (or set PYTHON=/path/to/python3)" >&2
    exit 1
fi
echo "setting up the bridge's Python environment in $venv (one time) ..." >&2
"$python" -m venv "$venv" || {
    echo "error: '$python -m venv' failed; on Debian/Ubuntu install python3-venv" >&2
    exit 1
}
"$venv/bin/pip" install --quiet --disable-pip-version-check -r "$here/requirements.txt" || {
    echo "error: pip could not install bridge/requirements.txt (is PyPI reachable?)" >&2
    exit 1
}
bridge_on_path
cp "$here/requirements.txt" "$stamp"
echo "bridge environment ready" >&2
