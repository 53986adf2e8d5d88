"""Runs campaign cells on a Dask cluster: `platoon campaign --dask ADDRESS` starts this script.

Protocol (JSON lines): stdin carries one cell job per line (what `platoon campaign-cell` reads),
closed when all are sent; stdout carries one reply per cell as it completes. Each task runs
`platoon campaign-cell` on a worker with the job on its stdin, so workers need the same
`platoon` binary: at the path given here (a shared file system, as clusters have) or at
`$PLATOON_EXE` on the worker. Everything the cell computes comes from that binary, which is why
a Dask campaign's cells.csv equals a local one byte for byte.

usage: dask_cells.py SCHEDULER_ADDRESS PLATOON_EXE
"""

import json
import os
import subprocess
import sys


def run_cell(exe, job):
    """One cell on a worker (pickled by value, so workers need only Python and platoon)."""
    exe = os.environ.get("PLATOON_EXE", exe)
    try:
        p = subprocess.run(
            [exe, "campaign-cell"],
            input=json.dumps(job),
            capture_output=True,
            text=True,
        )
    except OSError as e:
        return {"index": job["index"], "error": f"cannot start {exe} on the worker: {e}"}
    if p.returncode != 0:
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        last = lines[-1] if lines else "no message"
        return {
            "index": job["index"],
            "error": f"platoon campaign-cell exited with {p.returncode}: {last}",
        }
    return json.loads(p.stdout)


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    address, exe = sys.argv[1], sys.argv[2]
    jobs = [json.loads(line) for line in sys.stdin if line.strip()]
    from distributed import Client, as_completed

    try:
        client = Client(address, timeout="20s")
    except OSError as e:
        print(f"cannot reach the Dask scheduler at {address}: {e}", file=sys.stderr)
        return 1
    with client:
        futures = {
            client.submit(run_cell, exe, job, key=f"platoon-cell-{job['index']}-{os.getpid()}"): job
            for job in jobs
        }
        for future in as_completed(futures):
            job = futures[future]
            try:
                reply = future.result()
            except Exception as e:  # a worker that died or a task Dask gave up on
                reply = {"index": job["index"], "error": f"Dask: {type(e).__name__}: {e}"}
            print(json.dumps(reply), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
