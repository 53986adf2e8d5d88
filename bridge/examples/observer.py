"""A live observer of a running co-simulation: prints every follower's spacing error of
platoon 0 twice a second, read from the run's `observe/states` service (docs/observer-contract.md).

    platoon run configs/paper.toml --out runs/live &
    bridge/.venv/bin/python bridge/examples/observer.py runs/live

It finds the run through RUN_DIR/run.json (RUN_DIR.partial while the run is going), so it
never picks another run's services; it only reads, never publishes, never wakes anyone, and
polls on a timer: a slow, stalled, crashed or late observer cannot hold the run up (the
observer services drop what it does not read). It exits once the run has ended (its directory
moved into place: RUN_DIR/run.json of this run, no RUN_DIR.partial), when no step arrives for
`--idle` seconds (a run stalled or killed), or after `--max-seconds`.

`--stall` subscribes and then never reads (to test that a stalled observer changes nothing).
Exit codes: 0 done, 2 no run found, 3 no room left for another observer.
"""

import argparse
import ctypes
import json
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import iceoryx2 as iox  # noqa: E402

import platoon.wire as w  # noqa: E402


def find_run(run_dir: str, wait_s: float) -> dict:
    """run.json of the run writing RUN_DIR (or RUN_DIR.partial), waiting for it to appear."""
    deadline = time.monotonic() + wait_s
    while True:
        for d in (run_dir + ".partial", run_dir):
            path = os.path.join(d, "run.json")
            if os.path.exists(path):
                with open(path) as f:
                    return json.load(f)
        if time.monotonic() > deadline:
            print(f"observer: no run.json in {run_dir}(.partial): is an iceoryx2 run writing there?",
                  file=sys.stderr)
            sys.exit(2)
        time.sleep(0.1)


def run_ended(run_dir: str, run_id) -> bool:
    """The run has ended: its directory was moved into place (docs/observer-contract.md)."""
    if os.path.exists(run_dir + ".partial"):
        return False
    try:
        with open(os.path.join(run_dir, "run.json")) as f:
            return json.load(f).get("run_id") == run_id
    except (OSError, ValueError):
        return False


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", help="the run's --out directory")
    ap.add_argument("--every", type=float, default=0.5, help="seconds between lines")
    ap.add_argument("--idle", type=float, default=3.0, help="exit after this long without a step")
    ap.add_argument("--max-seconds", type=float, default=None)
    ap.add_argument("--stall", action="store_true", help="subscribe, then never read")
    args = ap.parse_args()

    run = find_run(args.run_dir, 30.0)
    iox.set_log_level_from_env_or(iox.LogLevel.Fatal)
    node = (
        iox.NodeBuilder.new()
        .name(iox.NodeName.new(f"platoon-observer-py-{os.getpid()}-{run['run_id']}"))
        .create(iox.ServiceType.Ipc)
    )
    # A crashed observer's slot is only free once its dead node is removed.
    node.try_cleanup_dead_nodes()
    # run.json is written as the run starts, a moment before its services exist: retry the
    # opening for a while; a full service fails at once.
    deadline = time.monotonic() + 30.0
    while True:
        try:
            service = (
                node.service_builder(iox.ServiceName.new(run["observe"]["states"]))
                .publish_subscribe(iox.Slice[w.VehicleState])
                .user_header(w.StepHeader)
                .open()
            )
            break
        except Exception as e:  # noqa: BLE001: iceoryx2 raises its own exception types
            if time.monotonic() > deadline:
                print(f"observer: run {run['run_id']} has no observer services ({e})", file=sys.stderr)
                return 2
            time.sleep(0.1)
    try:
        subscriber = service.subscriber_builder().create()
    except Exception as e:  # noqa: BLE001
        print(f"observer: cannot attach to run {run['run_id']} ({type(e).__name__}: {e}); "
              f"it has room for {run['observers']} observers (platoon run --observers N)",
              file=sys.stderr)
        return 3
    print(f"observer: attached to run {run['run_id']}", file=sys.stderr, flush=True)

    started = time.monotonic()
    last_seen = time.monotonic()
    n1, spacing = run["vehicles_per_platoon"], run["spacing_m"]
    steps = 0
    while True:
        time.sleep(args.every)
        now = time.monotonic()
        if args.max_seconds is not None and now - started > args.max_seconds:
            break
        if args.stall:
            continue
        latest = None
        while True:
            sample = subscriber.receive()
            if sample is None:
                break
            header = sample.user_header().contents
            count = header.count  # not the slice length (iceoryx2 #1533)
            items = sample.payload()
            if count >= n1:
                # Copy platoon 0's vehicles out of shared memory, nothing more.
                size = n1 * ctypes.sizeof(w.VehicleState)
                states = (w.VehicleState * n1).from_buffer_copy(ctypes.string_at(items.as_ptr(), size))
                latest = (header.step, header.time_s, [x.p for x in states])
            steps += 1
        if latest is None:
            if now - last_seen > args.idle or run_ended(args.run_dir, run["run_id"]):
                break
            continue
        last_seen = now
        step, t, p = latest
        errors = " ".join(f"{p[i] - p[0] + i * spacing:+8.3f}" for i in range(1, n1))
        print(f"t = {t:7.2f} s  spacing errors (m): {errors}", flush=True)
    print(f"observer: done after {steps} samples", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
