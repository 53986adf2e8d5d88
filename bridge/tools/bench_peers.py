"""Benchmark peers (not a test): the fleet of a `platoon` SUMO run, driven by SUMO itself, so
`platoon bench step` can show our co-simulation step as a ratio to each in one run.

Reads a run's plant.json (PLATOON_PLANT_SPEC or --plant-json: the network, every vehicle's
initial position, speed and lane, the platoons) and runs the same vehicles on the same road for
the same number of steps, in this process through libsumo, once per peer (the run's background
traffic left out):

  krauss      SUMO's own car-following model (Krauss, sigma 0) drives every vehicle, each at
              most at its initial speed: the cost of SUMO's step with no controller outside it.
  plexe_acc   Plexe's CC car-following model inside SUMO: every follower runs Plexe's ACC
              (ccac 1), every leader its cruise control at its initial speed.
  plexe_cacc  the same with Plexe's PATH CACC (ccac 2) on the followers, fed with the leader's
              and the predecessor's data by SUMO itself every step (auto-feeding, ccaf).
  floor       the floor of any external driver: speed mode 0 and, per vehicle and step, one
              setAcceleration and two getters (lane position, speed) from Python, no control.

Per step the wall time of what the peer does (the SUMO step, plus the floor's calls) is timed,
and SUMO's step alone; the report gives medians, p90 and means in µs, as JSON on stdout. Plexe's engine lag is the
run's (its first follower's tau), its other parameters SUMO's defaults.

    bridge/.venv/bin/python bridge/tools/bench_peers.py --plant-json runs/bench-step/sumo-1000/plant.json
        [--peers krauss,plexe_acc,plexe_cacc,floor] [--steps N]
"""

import argparse
import json
import os
import re
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.dirname(HERE)]  # beside it, plexe_reference; above it, platoon

import plexe_reference  # noqa: E402
from platoon.sumo import plant as sumo_plant  # noqa: E402

PEERS = ("krauss", "plexe_acc", "plexe_cacc", "floor")


class PeerError(Exception):
    """A peer could not run: the message says which and why."""


def routes(spec, peer, path):
    """The run's routes (platoon.sumo.plant.write_routes: same vehicles, lanes, positions and speeds)
    with the peer's vehicle type: SUMO's default model, or Plexe's CC with the run's lag."""
    sumo_plant.write_routes(path, spec)
    if peer.startswith("plexe"):
        tau = float(spec["taus"][0]["knots"][0][1]) if spec["taus"] else 0.5
        s = spec["sumo"]
        try:
            lanes, _ = plexe_reference.lane_info(s["net"], s["edge"], 0)
        except plexe_reference.ScenarioError as e:
            raise PeerError(f"{peer}: {e}") from e
        with open(path) as f:
            text = f.read()
        text, n = re.subn(
            r'<vType id="platoon" ',
            f'<vType id="platoon" carFollowModel="CC" tauEngine="{tau!r}" lanesCount="{lanes}" ',
            text,
            count=1,
        )
        if n != 1:
            raise PeerError(f"{peer}: no platoon vType in the routes platoon.sumo.plant writes")
        with open(path, "w") as f:
            f.write(text)


def run_peer(spec, peer, steps):
    import libsumo

    # The platoons only: a run's background traffic is not part of what the peers drive.
    spec = dict(spec, sumo=dict(spec["sumo"], background_vehicles=0))
    n = len(spec["initial"])
    n1 = int(spec["vehicles_per_platoon"])
    ids = [sumo_plant.vehicle_id(g) for g in range(n)]
    dt = float(spec["dt"])
    with tempfile.TemporaryDirectory(prefix="bench_peers.") as tmp:
        rou = os.path.join(tmp, "routes.rou.xml")
        routes(spec, peer, rou)
        s = spec["sumo"]
        try:
            libsumo.start([
                "sumo", "--net-file", s["net"], "--route-files", rou,
                "--step-length", repr(dt), "--step-method.ballistic", "true",
                "--collision.action", "warn", "--collision.mingap-factor", "0",
                "--time-to-teleport", "-1", "--no-step-log", "true", "--no-warnings", "true",
                "--seed", "0",
            ])
        except libsumo.TraCIException as e:
            raise PeerError(f"{peer}: SUMO did not start: {e}") from e
        try:
            libsumo.simulationStep()  # inserts every vehicle
            on_road = len(libsumo.vehicle.getIDList())
            if on_road != n:
                raise PeerError(f"{peer}: SUMO inserted {on_road} of the run's {n} vehicles")
            par = libsumo.vehicle.setParameter
            for g, vid in enumerate(ids):
                libsumo.vehicle.setLaneChangeMode(vid, 0)
                if peer == "krauss":
                    # The run's speeds, not the lane's limit (the vType allows 100 m/s).
                    libsumo.vehicle.setMaxSpeed(vid, float(spec["initial"][g][1]))
                if peer == "floor":
                    libsumo.vehicle.setSpeedMode(vid, 0)
                elif peer.startswith("plexe"):
                    speed = repr(float(spec["initial"][g][1]))
                    if g % n1 == 0:
                        par(vid, "carFollowModel.ccds", speed)
                        par(vid, "carFollowModel.ccac", "1")
                        continue
                    par(vid, "carFollowModel.ccds", speed)
                    if peer == "plexe_acc":
                        par(vid, "carFollowModel.ccac", "1")
                    else:
                        par(vid, "carFollowModel.ccac", "2")
                        par(vid, "carFollowModel.ccaf", f"1:{ids[g - g % n1]}:{ids[g - 1]}")
                    want = "1" if peer == "plexe_acc" else "2"
                    got = libsumo.vehicle.getParameter(vid, "carFollowModel.ccac").strip()
                    if got != want:
                        raise PeerError(f"{peer}: {vid} runs Plexe controller {got!r}, not {want}")
            step_ns, sumo_ns = [], []
            set_acc = libsumo.vehicle.setAcceleration
            get_pos, get_speed = libsumo.vehicle.getLanePosition, libsumo.vehicle.getSpeed
            checksum = 0.0
            for k in range(steps):
                t0 = time.perf_counter_ns()
                if peer == "floor":
                    a = 0.5 if (k // 100) % 2 == 0 else -0.5
                    for vid in ids:
                        set_acc(vid, a, dt)
                    t1 = time.perf_counter_ns()
                    libsumo.simulationStep()
                    t2 = time.perf_counter_ns()
                    for vid in ids:
                        checksum += get_pos(vid) + get_speed(vid)
                else:
                    t1 = time.perf_counter_ns()
                    libsumo.simulationStep()
                    t2 = time.perf_counter_ns()
                step_ns.append(time.perf_counter_ns() - t0)
                sumo_ns.append(t2 - t1)
            if len(libsumo.vehicle.getIDList()) != n:
                raise PeerError(f"{peer}: vehicles left the road during the run")
        except libsumo.TraCIException as e:
            raise PeerError(f"{peer}: SUMO refused a call: {e}") from e
        finally:
            libsumo.close()
    step_ns.sort()
    return {
        "steps": steps,
        "vehicles": n,
        "p50_us": statistics.median(step_ns) / 1e3,
        "p90_us": step_ns[min(len(step_ns) - 1, int(0.9 * len(step_ns)))] / 1e3,
        "mean_us": statistics.fmean(step_ns) / 1e3,
        # SUMO's simulationStep alone (all of the step but the floor's calls).
        "sumo_step_p50_us": statistics.median(sumo_ns) / 1e3,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="\n\n".join(__doc__.split("\n\n")[1:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--plant-json", default=os.environ.get("PLATOON_PLANT_SPEC"),
                    help="a SUMO run's plant.json (default: $PLATOON_PLANT_SPEC)")
    ap.add_argument("--peers", default=",".join(PEERS),
                    help=f"comma-separated, of {', '.join(PEERS)} (default: all)")
    ap.add_argument("--steps", type=int, default=None,
                    help="steps per peer (default: the run's)")
    args = ap.parse_args(argv)
    if not args.plant_json:
        ap.error("give --plant-json (a SUMO run's plant.json) or set PLATOON_PLANT_SPEC")
    peers = [p for p in args.peers.split(",") if p]
    unknown = [p for p in peers if p not in PEERS]
    if unknown or not peers:
        ap.error(f"--peers: unknown {', '.join(unknown) or '(none given)'}; use {', '.join(PEERS)}")
    try:
        with open(args.plant_json) as f:
            spec = json.load(f)
    except (OSError, ValueError) as e:
        print(f"bench_peers.py: error: cannot read {args.plant_json}: {e}", file=sys.stderr)
        return 1
    try:
        sumo_plant.NAMES["per_platoon"] = int(spec["vehicles_per_platoon"])
        sumo_plant.NAMES["platoons"] = len(spec["lanes"])
        steps = args.steps if args.steps is not None else int(spec["steps"])
    except (KeyError, TypeError, ValueError) as e:
        print(f"bench_peers.py: error: {args.plant_json} is not a plant.json ({e!r} missing "
              "or malformed)", file=sys.stderr)
        return 1
    if steps < 1:
        ap.error("--steps must be at least 1")
    report = {}
    try:
        for p in peers:
            report[p] = run_peer(spec, p, steps)
    except PeerError as e:
        print(f"bench_peers.py: error: {e}", file=sys.stderr)
        return 1
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
