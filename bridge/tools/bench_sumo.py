"""Benchmark (not a test): what one co-simulation step costs on the SUMO side, for 5, 100 and
1000 vehicles, through libsumo from Python, through the bridge's C++ loop (platoon.sumo.native:
the same libsumo calls in one call per step; with plain getters, which the bridge uses, and
with libsumo subscriptions read per vehicle or all at once) and through TraCI's socket.

Per step, as the bridge does it: set every vehicle's acceleration, step SUMO, read every
vehicle's lane position and speed. Open loop (a fixed acceleration pattern), on the 4-lane,
20 km highway, no FCD output. Reports medians (µs) of SUMO's own step and of the bridge's
get/set work, and the ratio TraCI / libsumo for the whole step. Needs eclipse-sumo and traci
(bridge/requirements-tools.txt) for the TraCI side; `sumo/build-networks.sh` installs the first.

    bridge/.venv/bin/pip install -r bridge/requirements-tools.txt traci==1.28.0
    bridge/.venv/bin/python bridge/tools/bench_sumo.py [--steps 500] [--sizes 5,100,1000]
        [--no-traci] [--no-native]

`--fcd PERIODS` (say `--fcd 0,0.1,0.01`) measures SUMO's own FCD writer instead: the bridge's
C++ loop with `--fcd-output` (acceleration on, as the bridge had it) every PERIOD s (0: none),
each period `--repeat` times, alternated, at each size; reports the whole step's median, p90
and mean (µs) and the p90 / median ratio, in wall time and in the thread's CPU time (which
other processes' load on a shared machine hardly moves).
"""

import argparse
import json
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
BRIDGE = os.path.dirname(HERE)  # where the platoon package is
NET = os.path.join(BRIDGE, "..", "sumo", "highway-long", "highway-long.net.xml")
sys.path.insert(0, BRIDGE)


def routes(path, n):
    with open(path, "w") as f:
        f.write('<routes>\n<vType id="t" length="4" minGap="0" accel="100" decel="100" '
                'emergencyDecel="100" maxSpeed="100"/>\n<route id="r" edges="highway"/>\n')
        for i in range(n):
            lane, slot = i % 4, i // 4
            f.write(f'<vehicle id="v{i}" type="t" route="r" depart="0" departLane="{lane}" '
                    f'departPos="{5000 - 12.0 * slot}" departSpeed="20" insertionChecks="none"/>\n')
        f.write("</routes>\n")


def run(api, n, steps, tmp, label, fcd=0.0):
    rou = os.path.join(tmp, f"r{n}.rou.xml")
    routes(rou, n)
    args = ["sumo", "-n", NET, "-r", rou, "--step-length", "0.01",
            "--step-method.ballistic", "true", "--no-step-log", "true", "--no-warnings", "true",
            "--collision.action", "warn", "--time-to-teleport", "-1"]
    if fcd > 0:
        args += ["--fcd-output", os.path.join(tmp, "fcd.xml"), "--fcd-output.acceleration", "true",
                 "--device.fcd.period", repr(fcd)]
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
        from platoon.sumo import native

        fleet = native.Fleet(api, ids)
        if label != "native":
            fleet.subscribe(1 if label == "native-subscribed" else 2)
        accel = [0.0] * n
    cpu_ns = []  # the whole step's CPU time (this thread's), which others' load hardly moves
    for k in range(steps):
        a = 0.5 if (k // 100) % 2 == 0 else -0.5
        t0 = time.perf_counter_ns()
        if fleet is not None:
            # One call: set, step, read (SUMO's step timed inside it).
            c0 = time.thread_time_ns()
            accel[:] = [a] * n
            step_ns, _ = fleet.step(accel, 0.01)
            fleet.states()
            t3 = time.perf_counter_ns()
            cpu_ns.append(time.thread_time_ns() - c0)
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
    total = sorted(a + b for a, b in zip(sumo_ns, bridge_ns))
    return {"sumo_step_us": med(sumo_ns), "bridge_us": med(bridge_ns),
            "total_us": med(total), "total_p90_us": total[int(0.9 * (len(total) - 1))] / 1e3,
            "total_mean_us": statistics.fmean(total) / 1e3,
            **({"cpu_us": med(cpu_ns), "cpu_p90_us": sorted(cpu_ns)[int(0.9 * (len(cpu_ns) - 1))] / 1e3,
                "cpu_mean_us": statistics.fmean(cpu_ns) / 1e3} if cpu_ns else {})}


def fcd_bench(sizes, steps, periods, repeat):
    """SUMO's FCD writer: the whole step (C++ loop, SUMO's step included) at each period."""
    import libsumo

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            for r in range(repeat):
                for fcd in periods:
                    res = run(libsumo, n, steps, tmp, "native", fcd)
                    out.setdefault(f"fcd {fcd}/{n}", []).append(res)
                    print(f"FCD every {fcd or '-':>5} s, {n:5} vehicles, run {r + 1}: median "
                          f"{res['total_us']:8.1f} µs, p90 {res['total_p90_us']:8.1f} µs "
                          f"({res['total_p90_us'] / res['total_us']:.2f}x), mean "
                          f"{res['total_mean_us']:8.1f} µs; CPU median {res['cpu_us']:8.1f}, p90 "
                          f"{res['cpu_p90_us']:8.1f} ({res['cpu_p90_us'] / res['cpu_us']:.2f}x), "
                          f"mean {res['cpu_mean_us']:8.1f}", flush=True)
    print(json.dumps(out, indent=2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--sizes", default="5,100,1000")
    ap.add_argument("--no-traci", action="store_true")
    ap.add_argument("--no-native", action="store_true")
    ap.add_argument("--fcd", metavar="PERIODS",
                    help="comma-separated FCD periods (s; 0: none): time SUMO's FCD writer")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each FCD period (alternated)")
    args = ap.parse_args()
    if args.steps < 1:
        sys.exit("--steps must be at least 1")
    if args.fcd:
        fcd_bench([int(x) for x in args.sizes.split(",")], args.steps,
                  [float(x) for x in args.fcd.split(",")], args.repeat)
        return
    import libsumo
    apis = [("libsumo", libsumo)]
    if not args.no_native:
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
