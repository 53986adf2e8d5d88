"""Plexe's join in the middle of a platoon, run by SUMO itself: the reference beside which
`platoon`'s join is measured (docs/maneuvers.md, tests/plexe_join.rs).

Plexe's maneuvers live in its Veins application, except one: the join of its Python API's
example (plexe-pyapi, examples/joindemo.py), which runs on SUMO alone through SUMO's CC
car-following model. This script replays that example's rules through libsumo, with its
numbers by default, and writes what SUMO did:

- A leader on Plexe's ACC at the cruising speed and N followers on the PATH CACC (ccac 2) at
  a gap of --distance m in lane 0; the joiner in lane 1, --joiner-behind m behind the last
  follower's front bumper, on its ACC at the same speed. No lane changes but the one below.
- Every 100 ms each vehicle of the platoon gets its leader's and its front vehicle's data
  (speed, acceleration, position, controller command), and the same as "fake" data with the
  distance between the two (GPS, not radar): an ideal channel, no messages lost, no protocol.
- At --ask-s the joiner takes follower --behind as its front vehicle, raises its cruise speed
  by 15 m/s and switches to Plexe's "faked CACC" (ccac 3), which follows the fake data at
  twice the gap, from the lane beside.
- Once it is within that distance + 1 m of its front vehicle, the member behind the slot
  follows the joiner on the faked CACC at twice the gap (the members behind take that member as
  their leader): it opens the gap.
- Once that member is more than 2 x (twice the gap) + 2 m behind the front vehicle, the joiner
  changes into lane 0 and both switch to the CACC at the platoon's gap; the members behind take
  the leader back.

Output CSV, one row per vehicle and step (t = 0 is the initial state):
  t        time, s
  vehicle  0 = leader, 1..N the followers in lane order, N + 1 the joiner
  lane     its lane index
  p        front bumper position along the road (lane position), m
  v        speed, m/s
  a        acceleration, m/s^2
  phase    the maneuver's phase at that step: waiting, approaching, opening, completed
"""

import argparse
import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import plexe_reference as ref  # noqa: E402  (its network checks, SUMO start, file writes)
from plexe_reference import set_par  # noqa: E402

ACC, CACC, FAKED_CACC = 1, 2, 3


def write_routes(path, args, lanes_count):
    vtype = (
        f'<vType id="plexe" carFollowModel="CC" length="{args.length!r}" minGap="0" '
        f'accel="2.5" decel="8" emergencyDecel="8" apparentDecel="8" maxSpeed="1000" '
        f'speedFactor="1" speedDev="0" sigma="0" tauEngine="{args.tau!r}" omegaN="0.2" xi="1" '
        f'c1="0.5" ccAccel="1.5" lanesCount="{lanes_count}"/>'
    )
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', "<routes>", f"    {vtype}",
             f'    <route id="road" edges="{args.edge}"/>']
    n = args.followers
    front = args.start + n * (args.distance + args.length)  # the leader's front bumper
    for i in range(n + 1):
        pos = front - i * (args.distance + args.length)
        lines.append(
            f'    <vehicle id="v{i}" type="plexe" route="road" depart="0" departLane="0" '
            f'departPos="{pos!r}" departSpeed="{args.speed!r}" insertionChecks="none"/>'
        )
    joiner = args.start - args.joiner_behind
    lines.append(
        f'    <vehicle id="v{n + 1}" type="plexe" route="road" depart="0" departLane="1" '
        f'departPos="{joiner!r}" departSpeed="{args.speed!r}" insertionChecks="none"/>'
    )
    lines.append("</routes>")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def data(sumo, vid):
    """What a vehicle would broadcast: (speed, acceleration, x, y, time, controller command),
    from Plexe's ccsa (speed:acceleration:u:x:y:time)."""
    f = sumo.vehicle.getParameter(vid, "carFollowModel.ccsa").split(":")
    speed, accel, u, x, y, t = (float(z) for z in f[:6])
    return speed, accel, x, y, t, u


def distance(sumo, a, b, length):
    """The GPS distance from a's front bumper to b's rear one (Plexe's example's)."""
    (xa, ya), (xb, yb) = sumo.vehicle.getPosition(a), sumo.vehicle.getPosition(b)
    return math.hypot(xa - xb, ya - yb) - length


def communicate(sumo, links, length):
    """Every vehicle with a leader and a front vehicle gets their data, real and fake."""
    for vid, (leader, front) in links.items():
        s, a, x, y, t, u = data(sumo, leader)
        set_par(sumo, vid, "cclsa", f"{s!r}:{a!r}:{x!r}:{y!r}:{t!r}:{u!r}")
        set_par(sumo, vid, "cclfd", f"{s!r}:{a!r}:{u!r}")
        s, a, x, y, t, u = data(sumo, front)
        set_par(sumo, vid, "ccpsa", f"{s!r}:{a!r}:{x!r}:{y!r}:{t!r}:{u!r}")
        d = distance(sumo, front, vid, length)
        set_par(sumo, vid, "ccffd", f"{s!r}:{a!r}:{d!r}:{u!r}")


def simulate(sumo, args, out):
    sumo.simulationStep()  # inserts the vehicles at their initial state (not moved yet)
    n = args.followers
    ids = [f"v{i}" for i in range(n + 2)]
    missing = [v for v in ids if v not in sumo.vehicle.getIDList()]
    if missing:
        raise ref.ScenarioError(f"SUMO did not insert {', '.join(missing)}")
    joiner, front, opener = ids[n + 1], ids[args.behind], ids[args.behind + 1]
    join_gap = 2 * args.distance
    for i, vid in enumerate(ids):
        sumo.vehicle.setSpeedMode(vid, 0)
        sumo.vehicle.setLaneChangeMode(vid, 0)
        set_par(sumo, vid, "ccds", repr(args.speed))
        set_par(sumo, vid, "ccaht", "1.5")
        set_par(sumo, vid, "ccsp", repr(join_gap if vid == joiner else args.distance))
        set_par(sumo, vid, "ccac", str(CACC if 0 < i <= n else ACC))
    links = {ids[i]: [ids[0], ids[i - 1]] for i in range(1, n + 1)}
    steps = round(args.duration / args.dt)
    ask = round(args.ask_s / args.dt)

    def write(f):
        phase = "waiting"
        f.write("t,vehicle,lane,p,v,a,phase\n")
        for k in range(steps + 1):
            t = round(k * args.dt, 9)
            # Lane order: the joiner is numbered last whatever lane it is in.
            for i, vid in enumerate(ids):
                if vid not in sumo.vehicle.getIDList():
                    raise ref.ScenarioError(f"{vid} left the simulation at t = {t:.2f} s")
                f.write(
                    f"{t!r},{i},{sumo.vehicle.getLaneIndex(vid)},"
                    f"{sumo.vehicle.getLanePosition(vid)!r},{sumo.vehicle.getSpeed(vid)!r},"
                    f"{sumo.vehicle.getAcceleration(vid)!r},{phase}\n"
                )
            if k == steps:
                break
            if k % round(0.1 / args.dt) == 1:
                communicate(sumo, links, args.length)
            if k == ask:
                links[joiner] = [ids[0], front]
                set_par(sumo, joiner, "ccds", repr(args.speed + 15.0))
                set_par(sumo, joiner, "ccac", str(FAKED_CACC))
                phase = "approaching"
            if phase == "approaching" and distance(sumo, front, joiner, args.length) < join_gap + 1:
                for vid in ids[args.behind + 2 : n + 1]:
                    links[vid][0] = opener
                links[opener][1] = joiner
                set_par(sumo, opener, "ccac", str(FAKED_CACC))
                set_par(sumo, opener, "ccsp", repr(join_gap))
                phase = "opening"
            if phase == "opening" and distance(sumo, front, opener, args.length) > 2 * join_gap + 2:
                for vid in (joiner, opener):
                    set_par(sumo, vid, "ccac", str(CACC))
                    set_par(sumo, vid, "ccsp", repr(args.distance))
                links[opener][1] = joiner
                for vid in ids[args.behind + 2 : n + 1]:
                    links[vid][0] = ids[0]
                phase = "completed"
            if phase == "completed" and sumo.vehicle.getLaneIndex(joiner) != 0:
                # Asked again every step until it is in (as Plexe's fixed lane is).
                sumo.vehicle.changeLane(joiner, 0, 1.0)
            sumo.simulationStep()
            if sumo.simulation.getCollidingVehiclesNumber():
                raise ref.ScenarioError(
                    f"collision at t = {(k + 1) * args.dt:.2f} s: "
                    f"{', '.join(sumo.simulation.getCollidingVehiclesIDList())}"
                )

    ref.write_atomically(out, write)


def run(args, out):
    lanes_count, lane_length = ref.lane_info(args.net, args.edge, 1)
    need = args.start + args.followers * (args.distance + args.length) + args.duration * (
        args.speed) + 50.0
    if need > lane_length:
        raise ref.ScenarioError(
            f"lane {args.edge}_1 of {args.net} is {lane_length:g} m long; the scenario needs "
            f"{need:.0f} m (--start, the platoon, the leader's travel and 50 m more)"
        )
    with tempfile.TemporaryDirectory(prefix="plexe_join.") as tmp:
        routes = os.path.join(tmp, "routes.rou.xml")
        write_routes(routes, args, lanes_count)
        ref.in_sumo(args.net, routes, args.dt, lambda sumo: simulate(sumo, args, out),
                    extra=("--lanechange.duration", "3"))


def main(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0] + "\n\n" + "\n\n".join(__doc__.split("\n\n")[1:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--out", required=True, help="the CSV file to write")
    ap.add_argument("--duration", type=float, default=60.0, help="simulated time, s (default 60)")
    ap.add_argument("--dt", type=float, default=0.01, help="SUMO's step length, s (default 0.01)")
    ap.add_argument("--followers", type=int, default=7,
                    help="followers in the platoon (default 7: the example's 8 cars)")
    ap.add_argument("--behind", type=int, default=2,
                    help="the follower the joiner joins behind (default 2)")
    ap.add_argument("--ask-s", type=float, default=1.0,
                    help="when the joiner starts its approach, s (default 1)")
    ap.add_argument("--speed", type=float, default=120 / 3.6,
                    help="the cruising speed, m/s (default 120 km/h)")
    ap.add_argument("--distance", type=float, default=5.0,
                    help="the platoon's gap, bumper to bumper, m (default 5)")
    ap.add_argument("--length", type=float, default=4.0, help="vehicle length, m (default 4)")
    ap.add_argument("--tau", type=float, default=0.5,
                    help="the engine's time constant (first-order lag), s (default 0.5)")
    ap.add_argument("--start", type=float, default=60.0,
                    help="the last follower's initial front position on lane 0, m (default 60)")
    ap.add_argument("--joiner-behind", type=float, default=50.0,
                    help="how far the joiner starts behind the last follower's front bumper, "
                    "in lane 1, m (default 50: the example's 10 m position)")
    ap.add_argument("--net", default=ref.DEFAULT_NET, help="the road network (default sumo/highway)")
    ap.add_argument("--edge", default="highway", help="the edge to drive on (default highway)")
    args = ap.parse_args(argv)
    for name in ("duration", "dt", "ask_s", "speed", "distance", "length", "tau"):
        if not math.isfinite(getattr(args, name)) or getattr(args, name) <= 0:
            ap.error(f"--{name.replace('_', '-')} must be a positive number")
    if not 1 <= args.behind < args.followers:
        ap.error("--behind must name a follower with a follower behind it (1..followers-1)")
    if args.start - args.joiner_behind < 0:
        ap.error("--joiner-behind puts the joiner before the start of the road")
    try:
        run(args, args.out)
    except ref.ScenarioError as e:
        print(f"plexe_join.py: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
