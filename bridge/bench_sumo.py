"""Benchmark (not a test): what one co-simulation step costs on the SUMO side, for 5, 100 and
1000 vehicles, through libsumo from Python, through the bridge's C++ loop (sumo_native.py: the
same libsumo calls in one call per step; with plain getters, which the bridge uses, and with
libsumo subscriptions read per vehicle or all at once) and through TraCI's socket.

Per step, as the bridge does it: set every vehicle's acceleration, step SUMO, read every
vehicle's lane position and speed. Open loop (a fixed acceleration pattern), on the 4-lane,
20 km highway, no FCD output. Reports medians (µs) of SUMO's own step and of the bridge's
get/set work, and the ratio TraCI / libsumo for the whole step. Needs eclipse-sumo and traci
(bridge/requirements-tools.txt) for the TraCI side; `sumo/build-networks.sh` installs the first.

    bridge/.venv/bin/pip install -r bridge/requirements-tools.txt traci==1.28.0
    bridge/.venv/bin/python bridge/bench_sumo.py [--steps 500] [--sizes 5,100,1000]
        [--no-traci] [--no-native]
"""

import argparse
import json
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
NET = os.path.join(HERE, "..", "sumo", "highway-long", "highway-long.net.xml")


def routes(path, n):
    with open(path, "w") as f:
        f.write('<routes>\n<vType id="t" length="4" minGap="0" accel="100" decel="100" '
                'emergencyDecel="100" maxSpeed="100"/>\n<route id="r" edges="highway"/>\n')
        for i in range(n):
            lane, slot = i % 4, i // 4
            f.write(f'<vehicle id="v{i}" type="t" route="r" depart="0" departLane="{lane}" '
                    f'departPos="{5000 - 12.0 * slot}" departSpeed="20" insertionChecks="none"/>\n')
        f.write("</routes>\n")


def run(api, n, steps, tmp, label):
    rou = os.path.join(tmp, f"r{n}.rou.xml")
    routes(rou, n)
    args = ["sumo", "-n", NET, "-r", rou, "--step-length", "0.01",
            "--step-method.ballistic", "true", "--no-step-log", "true", "--no-warnings", "true",
            "--collision.action", "warn", "--time-to-teleport", "-1"]
    if label == "traci":
        import sumo
        args[0] = os.path.join(sumo.SUMO_HOME, "bin", "sumo")
    api.start(args)
    api.simulationStep()
    ids = [f"v{i}" for i in range(n)]
    for v in ids:
        api.vehicle.setSpeedMode(v, 0)
        api.vehicle.setLaneChangeMode(v, 0)
    sumo_ns, bridge_ns = [], []
    fleet = None
    if label.startswith("native"):
        import sumo_native

        fleet = sumo_native.Fleet(api, ids)
        if label != "native":
            fleet.subscribe(1 if label == "native-subscribed" else 2)
        accel = [0.0] * n
    for k in range(steps):
        a = 0.5 if (k // 100) % 2 == 0 else -0.5
        t0 = time.perf_counter_ns()
        if fleet is not None:
            # One call: set, step, read (SUMO's step timed inside it).
            accel[:] = [a] * n
            step_ns, _ = fleet.step(accel, 0.01)
            fleet.states()
            t3 = time.perf_counter_ns()
            sumo_ns.append(step_ns)
            bridge_ns.append(t3 - t0 - step_ns)
            continue
        for v in ids:
            api.vehicle.setAcceleration(v, a, 0.01)
        t1 = time.perf_counter_ns()
        api.simulationStep()
        t2 = time.perf_counter_ns()
        for v in ids:
            api.vehicle.getLanePosition(v)
            api.vehicle.getSpeed(v)
        t3 = time.perf_counter_ns()
        sumo_ns.append(t2 - t1)
        bridge_ns.append((t1 - t0) + (t3 - t2))
    api.close()
    med = lambda x: statistics.median(x) / 1e3  # noqa: E731
    return {"sumo_step_us": med(sumo_ns), "bridge_us": med(bridge_ns),
            "total_us": med([a + b for a, b in zip(sumo_ns, bridge_ns)])}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--sizes", default="5,100,1000")
    ap.add_argument("--no-traci", action="store_true")
    ap.add_argument("--no-native", action="store_true")
    args = ap.parse_args()
    if args.steps < 1:
        sys.exit("--steps must be at least 1")
    import libsumo
    apis = [("libsumo", libsumo)]
    if not args.no_native:
        sys.path.insert(0, HERE)
        apis += [("native", libsumo), ("native-subscribed", libsumo),
                 ("native-subscribed-all", libsumo)]
    if not args.no_traci:
        try:
            import sumo  # noqa: F401  (the sumo binary for TraCI)
            import traci
            apis.append(("traci", traci))
        except ImportError as e:
            print(f"TraCI baseline skipped: {e} (pip install -r bridge/requirements-tools.txt "
                  "traci==1.28.0)", file=sys.stderr)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in [int(x) for x in args.sizes.split(",")]:
            for label, api in apis:
                r = run(api, n, args.steps, tmp, label)
                out[f"{label}/{n}"] = r
                print(f"{label:21} {n:5} vehicles: SUMO step {r['sumo_step_us']:9.1f} µs, "
                      f"get/set {r['bridge_us']:9.1f} µs, total {r['total_us']:9.1f} µs",
                      flush=True)
            if f"traci/{n}" in out:
                ratio = out[f"traci/{n}"]["total_us"] / out[f"libsumo/{n}"]["total_us"]
                print(f"                      {n:5} vehicles: TraCI / libsumo = {ratio:.1f}x")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
