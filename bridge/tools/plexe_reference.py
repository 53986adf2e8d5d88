"""Reference trajectories of Plexe's platoon controllers, run by SUMO itself.

Plexe ships inside SUMO as the car-following model "CC". This script drives one scenario through
libsumo with one of its controllers and writes what SUMO did, so that our own implementations of
the same laws (crates/control/src/laws.rs) can be checked against it
(crates/control/tests/plexe_agreement.rs).

The scenario: a leader and 4 followers (4 m cars, 10 m front to front, so 6 m bumper to bumper)
at 15 m/s on lane 0 of the committed straight highway (sumo/highway), no lane changes, no other
traffic. The leader follows the velocity profile exactly (15 m/s; +2 m/s^2 on [10, 15) s;
25 m/s; -2 m/s^2 on [35, 40) s; 15 m/s after) through setSpeed every step (speed mode 0, which
overrides the CC model's speed, engine lag included); it is a CC vehicle whose cruise control
never limits, so the controller acceleration SUMO records for it, which the followers read, is
the profile's acceleration. The followers run the chosen controller (Plexe's `ccac`) with SUMO's
default parameters, a first-order-lag engine with tau 0.5 s (tauEngine), and receive their
predecessor's and the leader's data from SUMO every step (Plexe's auto-feeding, `ccaf`); the
consensus controller is not auto-fed in Plexe, so the script gives every follower every other
vehicle's data (`ccvd`) before each step, as an ideal channel would. Ballistic update.

Output CSV, one row per vehicle and step (t = 0 is the initial state):
  t        time, s
  vehicle  0 = leader, i = follower i
  p        front bumper position along the road (lane position), m
  v        speed, m/s
  a        acceleration (SUMO's: the speed change of the last step over dt), m/s^2
  u        the controller's commanded acceleration of the last step, as Plexe reports it
           (parameter ccsa; SUMO prints it with 6 significant digits), m/s^2
  gap      bumper-to-bumper distance to the vehicle ahead, m (NaN for the leader)
Every other number is written with all its digits (Python's repr).
"""

import argparse
import math
import os
import sys
import tempfile
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))  # the checkout (bridge/tools/ is two below it)
DEFAULT_NET = os.path.join(ROOT, "sumo", "highway", "highway.net.xml")

# Plexe's controller codes (parameter "ccac").
LAWS = {"acc": 1, "cacc": 2, "ploeg": 4, "consensus": 5, "flatbed": 6}


class ScenarioError(Exception):
    """Something about the scenario or SUMO failed; the message says what."""


def leader_speed(t):
    """The paper's leader velocity profile, m/s."""
    return 15.0 + 2.0 * min(max(t - 10.0, 0.0), 5.0) - 2.0 * min(max(t - 35.0, 0.0), 5.0)


def leader_distance(duration):
    """How far the leader travels in `duration` seconds, m (the profile's exact integral)."""
    n = 2000
    h = duration / n
    return sum(h * (leader_speed(i * h) + leader_speed((i + 1) * h)) / 2 for i in range(n))


def lane_info(net, edge, lane):
    """(number of lanes of the edge, length of the lane) from a .net.xml."""
    try:
        root = ET.parse(net).getroot()
    except (OSError, ET.ParseError) as e:
        raise ScenarioError(f"cannot read the network {net}: {e}") from e
    for e in root.iter("edge"):
        if e.get("id") == edge:
            lanes = e.findall("lane")
            for ln in lanes:
                if ln.get("index") == str(lane):
                    return len(lanes), float(ln.get("length"))
            raise ScenarioError(f"edge '{edge}' of {net} has no lane {lane}")
    raise ScenarioError(f"{net} has no edge '{edge}'")


def write_routes(path, args, lanes_count):
    common = (
        'carFollowModel="CC" length="{L!r}" minGap="0" accel="{A!r}" decel="{D!r}" '
        'emergencyDecel="{D!r}" apparentDecel="{D!r}" maxSpeed="100" speedFactor="1" '
        'speedDev="0" sigma="0" lanesCount="{n}"'
    ).format(L=args.length, A=args.max_accel, D=args.max_decel, n=lanes_count)
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<routes>",
        # The leader: setSpeed (speed mode 0) sets its speed, engine lag or not; the controller
        # acceleration SUMO records for it (and the followers read) is the lesser of its own
        # controller's command and the commanded speed change, so its cruise control must never
        # limit (ccAccel, default 1.5) for that to be the profile's acceleration.
        f'    <vType id="plexe_leader" {common} tauEngine="{args.tau!r}" ccAccel="1000"/>',
        f'    <vType id="plexe" {common} tauEngine="{args.tau!r}"/>',
        f'    <route id="road" edges="{args.edge}"/>',
    ]
    for i in range(args.followers + 1):
        pos = args.start + (args.followers - i) * args.spacing
        vtype = "plexe_leader" if i == 0 else "plexe"
        lines.append(
            f'    <vehicle id="v{i}" type="{vtype}" route="road" depart="0" '
            f'departLane="{args.lane}" departPos="{pos!r}" departSpeed="{args.speed!r}" '
            'insertionChecks="none"/>'
        )
    lines.append("</routes>")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def run(args, out):
    lanes_count, lane_length = lane_info(args.net, args.edge, args.lane)
    need = args.start + args.followers * args.spacing + leader_distance(args.duration) + 50.0
    if need > lane_length:
        raise ScenarioError(
            f"lane {args.edge}_{args.lane} of {args.net} is {lane_length:g} m long; the scenario "
            f"needs {need:.0f} m (--start, the platoon, the leader's travel and 50 m more)"
        )
    steps = round(args.duration / args.dt)
    if steps < 1 or abs(steps * args.dt - args.duration) > 1e-9 * max(1.0, args.duration):
        raise ScenarioError(f"--duration {args.duration} is not a positive multiple of --dt {args.dt}")
    n = args.followers + 1
    ids = [f"v{i}" for i in range(n)]
    with tempfile.TemporaryDirectory(prefix="plexe_reference.") as tmp:
        routes = os.path.join(tmp, "routes.rou.xml")
        write_routes(routes, args, lanes_count)
        in_sumo(args.net, routes, args.dt, lambda sumo: simulate(sumo, args, ids, steps, out))


def in_sumo(net, routes, dt, simulate, extra=()):
    """Starts libsumo on `net` and `routes` with a step of `dt` s (ballistic, collisions
    warned, no teleports, seed 0) and the `extra` options, runs `simulate(libsumo)` and closes
    it; what goes wrong is a ScenarioError."""
    try:
        import libsumo
    except ImportError as e:
        raise ScenarioError(
            f"cannot import libsumo ({e}); run bridge/setup-venv.sh and use bridge/.venv/bin/python"
        ) from e
    sumo_args = [
        "sumo",
        "--net-file", net,
        "--route-files", routes,
        "--step-length", repr(dt),
        "--step-method.ballistic", "true",
        *extra,
        "--collision.action", "warn",
        "--collision.mingap-factor", "0",
        "--time-to-teleport", "-1",
        "--no-step-log", "true",
        "--no-warnings", "true",
        "--seed", "0",
    ]
    try:
        libsumo.start(sumo_args)
    except Exception as e:  # libsumo raises its own TraCIException / FatalTraCIError
        raise ScenarioError(f"SUMO did not start: {e}") from e
    try:
        return simulate(libsumo)
    except libsumo.TraCIException as e:
        raise ScenarioError(f"SUMO refused a call: {e}") from e
    finally:
        libsumo.close()


def write_atomically(out, write):
    """Calls `write(f)` on OUT.partial and renames it to `out` once it returned: a failure
    (a ScenarioError, an OSError) leaves no file that looks complete."""
    partial = out + ".partial"
    try:
        f = open(partial, "w")
    except OSError as e:
        raise ScenarioError(f"cannot write {out}: {e}") from e
    try:
        with f:
            write(f)
        os.replace(partial, out)
    except OSError as e:
        raise ScenarioError(f"cannot write {out}: {e}") from e
    finally:
        if os.path.exists(partial):
            os.unlink(partial)


def set_par(sumo, vid, key, value):
    sumo.vehicle.setParameter(vid, "carFollowModel." + key, value)


def controller_u(sumo, vid):
    """Plexe's controllerAcceleration (the third field of ccsa), or NaN."""
    try:
        fields = sumo.vehicle.getParameter(vid, "carFollowModel.ccsa").split(":")
        return float(fields[2])
    except (IndexError, ValueError):
        return math.nan


def simulate(sumo, args, ids, steps, out):
    sumo.simulationStep()  # inserts the vehicles at their initial state (not moved yet)
    missing = [v for v in ids if v not in sumo.vehicle.getIDList()]
    if missing:
        raise ScenarioError(f"SUMO did not insert {', '.join(missing)}")
    law = LAWS[args.law]
    n = len(ids)
    for i, vid in enumerate(ids):
        sumo.vehicle.setSpeedMode(vid, 0)
        sumo.vehicle.setLaneChangeMode(vid, 0)
        if i == 0:
            # Any controller but the driver: then SUMO records the leader's controller
            # acceleration, which the followers read; setSpeed decides its speed.
            set_par(sumo, vid, "ccac", "1")
            set_par(sumo, vid, "ccds", "100")
            continue
        set_par(sumo, vid, "ccds", repr(args.cc_desired_speed))
        set_par(sumo, vid, "ccac", str(law))
        if args.law in ("cacc", "ploeg", "flatbed"):
            set_par(sumo, vid, "ccaf", f"1:{ids[0]}:{ids[i - 1]}")
        if args.law == "consensus":
            set_par(sumo, vid, "ccvp", str(i))
            set_par(sumo, vid, "ccps", str(n))
        got = sumo.vehicle.getParameter(vid, "carFollowModel.ccac")
        if got.strip() != str(law):
            raise ScenarioError(f"{vid}: SUMO's active controller is '{got}', not {law} ({args.law})")
    t0 = sumo.simulation.getTime()

    def write(f):
        write_steps(sumo, args, ids, steps, f)
        elapsed = sumo.simulation.getTime() - t0
        if abs(elapsed - steps * args.dt) > 1e-6:
            raise ScenarioError(f"SUMO advanced {elapsed} s in {steps} steps of {args.dt} s")

    write_atomically(out, write)


def write_steps(sumo, args, ids, steps, f):
    """Writes the initial state, then steps SUMO `steps` times, writing every state."""
    f.write("t,vehicle,p,v,a,u,gap\n")
    for k in range(steps + 1):
        t = round(k * args.dt, 9)
        states = []
        for vid in ids:
            if vid not in sumo.vehicle.getIDList():
                raise ScenarioError(f"{vid} left the simulation at t = {t:.2f} s")
            states.append(
                (sumo.vehicle.getLanePosition(vid), sumo.vehicle.getSpeed(vid),
                 sumo.vehicle.getAcceleration(vid), controller_u(sumo, vid))
            )
        for i, (p, v, a, u) in enumerate(states):
            gap = states[i - 1][0] - args.length - p if i else math.nan
            f.write(f"{t!r},{i},{p!r},{v!r},{a!r},{u!r},{gap!r}\n")
        if k == steps:
            break
        if args.law == "consensus":
            feed_consensus(sumo, args, ids, states)
        sumo.vehicle.setSpeed(ids[0], leader_speed((k + 1) * args.dt))
        sumo.simulationStep()
        if sumo.simulation.getCollidingVehiclesNumber():
            raise ScenarioError(
                f"collision at t = {(k + 1) * args.dt:.2f} s: "
                f"{', '.join(sumo.simulation.getCollidingVehiclesIDList())}"
            )


def feed_consensus(sumo, args, ids, states):
    """Every follower gets every other vehicle's current data (Plexe's ccvd: index, speed,
    acceleration, x, y, time, length, u, vx, vy, angle), read now, stamped with the current
    time."""
    now = sumo.simulation.getTime()
    data = []
    for j, vid in enumerate(ids):
        x, y = sumo.vehicle.getPosition(vid)
        v, a, u = states[j][1], states[j][2], states[j][3]
        heading = math.radians(sumo.vehicle.getAngle(vid))  # libsumo: clockwise from north
        vx, vy = v * math.sin(heading), v * math.cos(heading)
        angle = math.pi / 2 - heading  # Plexe's: radians, counterclockwise from east
        fields = [str(j)] + [
            repr(float(z))
            for z in (v, a, x, y, now, args.length, u if math.isfinite(u) else 0.0, vx, vy, angle)
        ]
        data.append(":".join(fields))
    for i, vid in enumerate(ids):
        if i == 0:
            continue
        for j in range(len(ids)):
            if j != i:
                set_par(sumo, vid, "ccvd", data[j])


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0] + "\n\n" + "\n\n".join(__doc__.split("\n\n")[1:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--law", required=True, choices=sorted(LAWS),
                    help="the followers' controller: acc (ccac 1), cacc (2, PATH/Rajamani), "
                    "ploeg (4), consensus (5, Santini et al.), flatbed (6)")
    ap.add_argument("--out", required=True, help="the CSV file to write")
    ap.add_argument("--duration", type=float, default=55.0, help="simulated time, s (default 55)")
    ap.add_argument("--dt", type=float, default=0.01, help="SUMO's step length, s (default 0.01)")
    ap.add_argument("--tau", type=float, default=0.5,
                    help="the followers' engine time constant (first-order lag), s (default 0.5)")
    ap.add_argument("--cc-desired-speed", type=float, default=30.0,
                    help="the followers' cruise-control set speed (ccds), m/s (default 30, above "
                    "the profile's 25): used by ACC's cruise-control branch only (with speed mode 0, "
                    "as here, SUMO does not also cap the car's speed at it)")
    ap.add_argument("--net", default=DEFAULT_NET, help="the road network (default sumo/highway)")
    ap.add_argument("--edge", default="highway", help="the edge to drive on (default highway)")
    ap.add_argument("--lane", type=int, default=0, help="the lane index (default 0)")
    ap.add_argument("--start", type=float, default=100.0,
                    help="the last follower's initial front position on the lane, m (default 100)")
    ap.add_argument("--followers", type=int, default=4, help="number of followers (default 4)")
    ap.add_argument("--length", type=float, default=4.0, help="vehicle length, m (default 4)")
    ap.add_argument("--spacing", type=float, default=10.0,
                    help="initial front-to-front distance, m (default 10)")
    ap.add_argument("--speed", type=float, default=15.0, help="initial speed, m/s (default 15)")
    ap.add_argument("--max-accel", type=float, default=100.0,
                    help="vType accel, m/s^2 (default 100: Plexe's engine clamp never acts)")
    ap.add_argument("--max-decel", type=float, default=100.0,
                    help="vType decel and emergencyDecel, m/s^2 (default 100: never acts)")
    args = ap.parse_args(argv)
    for name in ("duration", "dt", "tau", "length", "spacing", "speed", "max_accel", "max_decel"):
        if not math.isfinite(getattr(args, name)) or getattr(args, name) <= 0:
            ap.error(f"--{name.replace('_', '-')} must be a positive number")
    if not math.isfinite(args.start) or args.start < 0 or not math.isfinite(args.cc_desired_speed):
        ap.error("--start must be >= 0 and --cc-desired-speed finite")
    if args.spacing <= args.length:
        ap.error("--spacing (front to front) must exceed --length")
    if args.followers < 1 or (args.law == "consensus" and args.followers > 7):
        ap.error("--followers must be 1..7 for consensus (Plexe's 8 cars), at least 1 otherwise")
    try:
        run(args, args.out)
    except ScenarioError as e:
        print(f"plexe_reference.py: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
