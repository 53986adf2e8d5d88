#!/bin/sh
# Regenerates every sumo/<name>/<name>.net.xml from its plain node and edge files with netconvert
# (from the PyPI eclipse-sumo package, installed into bridge/.venv on first use). The generated
# networks are committed, so runs and tests never need this.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
"$root/bridge/setup-venv.sh"
py="$root/bridge/.venv/bin/python"
if ! "$py" -P -c "import sumo" 2>/dev/null; then
    echo "installing eclipse-sumo (netconvert) into bridge/.venv ..." >&2
    "$root/bridge/.venv/bin/pip" install --quiet -r "$root/bridge/requirements-tools.txt"
fi
netconvert="$("$py" -P -c 'import sumo, os; print(os.path.join(sumo.SUMO_HOME, "bin", "netconvert"))')"
for dir in "$root"/sumo/*/; do
    name=$(basename "$dir")
    [ -f "$dir/$name.nod.xml" ] || continue
    SUMO_HOME="$("$py" -P -c 'import sumo; print(sumo.SUMO_HOME)')" "$netconvert" \
        --node-files "$dir/$name.nod.xml" --edge-files "$dir/$name.edg.xml" \
        --output-file "$dir/$name.net.xml" --no-turnarounds true --output.street-names false \
        --no-warnings true >/dev/null
    echo "built sumo/$name/$name.net.xml" >&2
done
