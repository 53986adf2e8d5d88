"""Runs campaign cells on a Dask cluster: `platoon campaign --dask ADDRESS` starts this driver
as `python -m platoon.dask`, with the bridge first on its PYTHONPATH.

Protocol (JSON lines): stdin carries one cell job per line (what `platoon campaign-cell` reads),
closed when all are sent; stdout carries one reply per cell, a batch's replies as its task
completes. The cells go out in batches (about four per worker thread, so the threads stay busy
while the batches' sizes amortise a task's round trip).

A batch runs in the worker's own process when the worker's Python has the `platoon` package
(`pip install ./bridge`): its compiled core's `execute_cells` runs the cells, with the GIL
released. A worker without it (ImportError) runs each cell of the batch as a
`platoon campaign-cell` process instead, with the `platoon` binary at the path given here (a
shared file system, as clusters have) or at `$PLATOON_EXE` on the worker; so does every worker
when `PLATOON_DASK_IN_WORKER=0` is set where this script runs. Either way everything a cell
computes comes from the same Rust code as the local pool's, which is why a Dask campaign's
cells.csv equals a local one byte for byte. stderr (the campaign's dask.log) names, per batch,
the worker and which of the two ran it.

The task's functions travel by value (`cloudpickle.register_pickle_by_value`): a worker needs
Python and distributed, not this module, and imports `platoon` only to run cells in-process.

usage: python -m platoon.dask SCHEDULER_ADDRESS PLATOON_EXE
"""

import json
import math
import os
import sys
import time
import uuid

# Batches per worker thread: enough that a slow batch does not leave the others idle at the end.
BATCHES_PER_THREAD = 4


def run_cell(exe, job):
    """One cell as a `platoon campaign-cell` process on the worker."""
    import subprocess

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


def run_batch(exe, batch, in_worker):
    """One batch of cells on a worker (pickled by value, so workers need only Python,
    distributed and platoon). `batch` is the JSON list of the cell jobs.
    Returns (how, worker, detail, replies): how is "in-worker" (the package's core in this process,
    then `detail` is where the package is) or "subprocess" (with why in `detail`)."""
    try:
        from distributed import get_worker

        worker = get_worker().name
    except Exception:  # run outside a worker (a test calling it directly)
        worker = "?"
    why = "PLATOON_DASK_IN_WORKER=0"
    if in_worker:
        try:
            import platoon
            from platoon import _core
        except ImportError as e:
            why = f"no platoon._core on the worker ({e})"
        else:
            # Co-simulated cells start `platoon run`: the worker's own program if it names
            # one, else the package's `platoon` script (what _native() sets), else the binary
            # the campaign runs (a shared file system).
            if not os.environ.get("PLATOON_PROGRAM") and os.environ.get("PLATOON_EXE"):
                os.environ["PLATOON_PROGRAM"] = os.environ["PLATOON_EXE"]
            platoon._native()
            if not os.environ.get("PLATOON_PROGRAM"):
                os.environ["PLATOON_PROGRAM"] = exe
            where = os.path.dirname(platoon.__file__)
            try:
                replies = json.loads(_core.execute_cells(batch))
            except (KeyboardInterrupt, SystemExit):
                raise
            except BaseException as e:  # a panic in the core is a BaseException
                error = f"platoon._core.execute_cells on {worker}: {type(e).__name__}: {e}"
                replies = [{"index": job["index"], "error": error} for job in json.loads(batch)]
            return "in-worker", worker, where, replies
    jobs = json.loads(batch)
    return "subprocess", worker, why, [run_cell(exe, job) for job in jobs]


STARTED = time.monotonic()


def log(*args):
    """A line of dask.log, stamped with the seconds since the driver started."""
    print(f"dask_cells: {time.monotonic() - STARTED:.3f} s:", *args, file=sys.stderr, flush=True)


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    address, exe = sys.argv[1], sys.argv[2]
    lines = [line.strip() for line in sys.stdin if line.strip()]
    indices = [json.loads(line)["index"] for line in lines]
    in_worker = os.environ.get("PLATOON_DASK_IN_WORKER", "1") != "0"
    log(f"{len(lines)} cells read")
    import cloudpickle
    from distributed import Client, as_completed

    cloudpickle.register_pickle_by_value(sys.modules[__name__])

    try:
        client = Client(address, timeout="20s")
    except OSError as e:
        print(f"cannot reach the Dask scheduler at {address}: {e}", file=sys.stderr)
        return 1
    log(f"connected to {address}")
    with client:
        threads = max(1, sum(client.nthreads().values()))
        size = max(1, math.ceil(len(lines) / (BATCHES_PER_THREAD * threads)))
        starts = range(0, len(lines), size)
        way = (
            "in the workers where they have platoon._core"
            if in_worker
            else "a process per cell: PLATOON_DASK_IN_WORKER=0"
        )
        log(
            f"{len(lines)} cells in {len(starts)} batches of up to {size} on {threads} worker "
            f"threads ({way})"
        )
        token = uuid.uuid4().hex[:12]
        futures = {}
        for b, start in enumerate(starts):
            batch = "[" + ",".join(lines[start : start + size]) + "]"
            future = client.submit(
                run_batch, exe, batch, in_worker, key=f"platoon-cells-{token}-{b}"
            )
            futures[future] = indices[start : start + size]
        counts = {"in-worker": 0, "subprocess": 0, "failed": 0}
        for future in as_completed(futures):
            cells = futures[future]
            try:
                how, worker, detail, replies = future.result()
                if len(replies) != len(cells):
                    raise RuntimeError(f"{len(replies)} replies to {len(cells)} cells")
                counts[how] += len(cells)
                log(f"batch of {len(cells)} cells from {cells[0]}: {how} on {worker} ({detail})")
            except (KeyboardInterrupt, SystemExit):
                raise
            except BaseException as e:  # a worker that died or a task Dask gave up on
                counts["failed"] += len(cells)
                log(f"batch of {len(cells)} cells from {cells[0]} failed: {type(e).__name__}: {e}")
                replies = [
                    {"index": i, "error": f"Dask: {type(e).__name__}: {e}"} for i in cells
                ]
            sys.stdout.write("".join(json.dumps(r) + "\n" for r in replies))
            sys.stdout.flush()
        log(
            f"done: {counts['in-worker']} cells in-worker, {counts['subprocess']} by subprocess, "
            f"{counts['failed']} in failed batches"
        )
    return 0


def exit_with(code):
    """Ends the driver with `code` once its output is flushed. The client is closed: this skips
    the interpreter's teardown of distributed's threads and event loop (~0.15 s), which the
    campaign would wait for."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
