"""The SUMO plant: a platoon node that advances SUMO vehicles with the accelerations of the
platoon model, speaking the same iceoryx2 contract as the native plant (`platoon node plant`).

Started by `platoon run --plant sumo` as `python -m platoon.sumo`, with PLATOON_RUN_ID and
PLATOON_PLANT_SPEC (plant.json: time grid, initial states, leader profile, tau schedules, and the
SUMO options). Per step k: publish the background traffic's positions (`traffic`, with `[sumo]
background_vehicles`) and the states read from SUMO, wait for commands[k], hold each vehicle's
acceleration a[k] over the step (`setAcceleration`, ballistic update, speed mode 0), step SUMO,
check collisions, and update a[k+1] with the engine lag (platoon.sumo.model). Scripted cut-ins
(plant.json's `cut_ins`) are SUMO vehicles on the platoon's lane while they are on it
(`Intruders`). Writes sumo.json (SUMO version, per-step costs, collisions, teleports, the
cut-ins), with `[sumo] background_lane_changes` SUMO's lane-change output (lanechanges.xml) and,
with `[sumo] fcd = "sumo"` only, SUMO's FCD output into the run directory (by default platoon
writes fcd.xml from the trajectories after the run).

The per-vehicle libsumo calls of a step (set every acceleration, step, read every state back)
run in one call to a small C++ helper (platoon.sumo.native; PLATOON_SUMO_NATIVE=0 keeps them in
Python); the arithmetic stays here, so both give the same bits.

`python -m platoon.sumo --tight-loop STEPS` (with PLATOON_PLANT_SPEC) times the same SUMO and
model in a loop without the co-simulation around it, for `platoon bench step`.
"""

import json
import os
import random
import statistics
import sys
import traceback
import time

import numpy as np

from .. import plugin as _plugin
from .. import wire as w
from . import model, native as sumo_native


class SumoError(Exception):
    """SUMO refused something: the message names SUMO and the step."""


NAMES = {"per_platoon": 0, "platoons": 1}


def vehicle_id(g: int) -> str:
    """SUMO's name of wire vehicle g: leader, follower1, ... (p3.leader, p3.follower1, ... in a
    fleet)."""
    j, i = divmod(g, NAMES["per_platoon"])
    name = "leader" if i == 0 else f"follower{i}"
    return name if NAMES["platoons"] == 1 else f"p{j}.{name}"


def ahead_id(j: int, a: int) -> str:
    """SUMO's name of `[[sumo.ahead]]` vehicle a of platoon j: ahead0, ... (p3.ahead0 in a
    fleet)."""
    name = f"ahead{a}"
    return name if NAMES["platoons"] == 1 else f"p{j}.{name}"


def intruder_id(j: int, c: int) -> str:
    """SUMO's name of cut-in c's vehicle in platoon j: cutin0, ... (p3.cutin0, ... in a fleet)."""
    name = f"cutin{c}"
    return name if NAMES["platoons"] == 1 else f"p{j}.{name}"


def vtype(name, length):
    """A vehicle type that does what it is told (the platoon's and the cut-ins')."""
    return (
        f'    <vType id="{name}" length="{length!r}" minGap="0" '
        'accel="100" decel="100" emergencyDecel="100" apparentDecel="100" '
        'maxSpeed="100" speedFactor="1" speedDev="0" sigma="0" tau="1"/>'
    )


def leader_vtype(drive, length):
    """The leaders' vehicle type when SUMO's car-following model drives them (`leader.drive`):
    its model, desired speed, limits and headway, no dawdling (`sigma = 0`), no lane changes."""
    model = {"krauss": "Krauss", "idm": "IDM"}[drive["car_follow_model"]]
    return (
        f'    <vType id="leader" length="{length!r}" minGap="{float(drive["min_gap_m"])!r}" '
        f'carFollowModel="{model}" accel="{float(drive["accel_mps2"])!r}" '
        f'decel="{float(drive["decel_mps2"])!r}" emergencyDecel="9" '
        f'maxSpeed="{float(drive["speed_mps"])!r}" speedFactor="1" speedDev="0" sigma="0" '
        f'tau="{float(drive["headway_s"])!r}" lcStrategic="0" lcCooperative="0" lcSpeedGain="0" '
        'lcKeepRight="0"/>'
    )


def member_vtypes(spec):
    """With vehicle classes (plant.json's `vehicles`): a type per class, `platoon.<class>`,
    of its length (SUMO's radar gaps and collisions then count it). Its accel and decel stay
    SUMO's no-limit 100: the model (`platoon.sumo.model.Dynamics`) holds the input within the
    class's limits as the native plant does, and SUMO moves the vehicle by the acceleration
    it is set."""
    seen = {}
    for m in spec.get("vehicles") or []:
        seen.setdefault(m["class"], max(float(m["length_m"]), 0.01))
    return [vtype(f"platoon.{name}", length) for name, length in seen.items()]


def leader_length(spec):
    """The leaders' length: their class's, or the platoon's."""
    members = spec.get("vehicles")
    return float(members[0]["length_m"]) if members else spec["sumo"]["vehicle_length_m"]


def member_lengths(spec):
    """Every member's length, leader first: its class's with vehicle classes, else the
    platoon's."""
    members = spec.get("vehicles") or []
    return ([float(m["length_m"]) for m in members]
            or [float(spec["vehicle_length"])] * int(spec["vehicles_per_platoon"]))


def member_vtype(spec, g):
    """The SUMO type of wire vehicle g: its class's, or `platoon`."""
    members = spec.get("vehicles")
    return f'platoon.{members[g % spec["vehicles_per_platoon"]]["class"]}' if members else "platoon"


def write_routes(path, spec):
    s = spec["sumo"]
    drive = s.get("leader")
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<routes>",
        vtype("platoon", s["vehicle_length_m"]),
        *(vtype(f"cutin{c}", float(cut["length_m"])) for c, cut in enumerate(spec.get("cut_ins", []))),
        *member_vtypes(spec),
        *([leader_vtype(drive, leader_length(spec))] if drive else []),
        *(
            f'    <vType id="ahead{a}" length="{float(x["length_m"])!r}" minGap="2.5" accel="1" '
            f'decel="4" maxSpeed="{max(float(x["speed_mps"]), 0.1)!r}" speedFactor="1" '
            'speedDev="0" sigma="0" guiShape="truck" lcStrategic="0" lcCooperative="0" '
            'lcSpeedGain="0" lcKeepRight="0"/>'
            for a, x in enumerate(s.get("ahead", []))
        ),
        f'    <route id="road" edges="{" ".join(s.get("route") or [s["edge"]])}"/>',
    ]
    n1 = int(spec["vehicles_per_platoon"])
    beside = set(s.get("beside", []))
    for g, (p, v, _) in enumerate(spec["initial"]):
        lane = spec["lanes"][g // n1]
        if g % n1 in beside:  # a joiner from beside starts in the lane beside the platoon's
            lane = s["side_lanes"][g // n1]
        kind = "leader" if drive and g % spec["vehicles_per_platoon"] == 0 else member_vtype(spec, g)
        lines.append(
            f'    <vehicle id="{vehicle_id(g)}" type="{kind}" route="road" depart="0" '
            f'departLane="{lane}" departPos="{p + s["offset_m"]!r}" departSpeed="{v!r}" '
            'insertionChecks="none"/>'
        )
    # The vehicles ahead of each platoon's leader, at their gaps and speeds.
    n1 = int(spec["vehicles_per_platoon"])
    for j, lane in enumerate(spec["lanes"]):
        front = float(spec["initial"][j * n1][0]) + float(s["offset_m"])
        for a, x in enumerate(s.get("ahead", [])):
            pos = front + float(x["gap_m"]) + float(x["length_m"])
            lines.append(
                f'    <vehicle id="{ahead_id(j, a)}" type="ahead{a}" route="road" depart="0" '
                f'departLane="{lane}" departPos="{pos!r}" departSpeed="{float(x["speed_mps"])!r}" '
                'insertionChecks="none"/>'
            )
    # Background traffic: SUMO's own model (Krauss), on the free lanes, spread evenly along the
    # road with seeded jitter and speeds (Python's Mersenne Twister: the same seed gives the same
    # traffic). Without `background_lane_changes` it keeps its lane (every lc* weight 0).
    nb = int(s.get("background_vehicles", 0))
    if nb:
        rng = random.Random(int(s["background_seed"]))
        free = s["background_lanes"]
        lc = s.get("background_lane_changes")
        trucks = float(s.get("background_truck_share", 0.0))
        lines[3:3] = background_vtypes(lc, trucks)
        if not s.get("background_on_platoon_lanes"):
            per_lane = -(-nb // len(free))
            for b in range(nb):
                lane, length = free[b % len(free)]
                slot = (length - 100.0) / per_lane
                pos = 50.0 + (b // len(free)) * slot + rng.uniform(0.0, 0.3 * slot)
                lines.append(background_vehicle(b, lane, pos, rng, trucks))
        else:
            segments = background_segments(spec)
            free = [(lane, length) for lane, length in free if segments[lane]]
            if not free:
                raise SumoError("no room for background traffic beside the platoons on the road")
            per_lane = -(-nb // len(free))
            for b in range(nb):
                lane, _ = free[b % len(free)]
                on_lane = segments[lane]
                slot = sum(hi - lo for lo, hi in on_lane) / per_lane
                x = (b // len(free)) * slot + rng.uniform(0.0, 0.3 * slot)
                for lo, hi in on_lane:
                    if x <= hi - lo:
                        break
                    x -= hi - lo
                lines.append(background_vehicle(b, lane, lo + x, rng, trucks))
    lines += flow_lines(s)
    lines.append("</routes>")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def flow_lines(s):
    """`[[sumo.flows]]`: vehicles of SUMO's Krauss and LC2013 models (`flow<i>.<n>`) entering on
    their `from` edge at an even rate, routed by SUMO to their `to` edge; cars, or trucks with
    `truck_share` (a vTypeDistribution drawn from SUMO's seed). LC2013's weights are
    `background_lane_changes`' when given, else SUMO's."""
    flows = s.get("flows") or []
    if not flows:
        return []
    lc = s.get("background_lane_changes")
    changes = "" if lc is None else (
        f' lcCooperative="{float(lc["cooperative"])!r}" lcSpeedGain="{float(lc["speed_gain"])!r}" '
        f'lcKeepRight="{float(lc["keep_right"])!r}" lcAssertive="{float(lc["assertive"])!r}"'
    )
    car = f'id="flow_car" length="4.5" minGap="2.5" maxSpeed="36"{changes}'
    truck = f'id="flow_truck" length="12" minGap="2.5" maxSpeed="25" accel="1" decel="4" guiShape="truck"{changes}'
    lines = [f"    <vType {car}/>", f"    <vType {truck}/>"]
    for i, f in enumerate(flows):
        share = float(f.get("truck_share", 0.0))
        kind = "flow_car" if share == 0.0 else "flow_truck" if share == 1.0 else f"flow{i}_mix"
        if kind == f"flow{i}_mix":
            lines.append(
                f'    <vTypeDistribution id="{kind}" vTypes="flow_car flow_truck" '
                f'probabilities="{1.0 - share!r} {share!r}"/>'
            )
        end = f.get("end_s")
        end = float(s["duration_s"]) if end is None else float(end)
        speed = f.get("speed_mps")
        lines.append(
            f'    <flow id="flow{i}" type="{kind}" from="{f["from"]}" to="{f["to"]}" '
            f'begin="{float(f.get("begin_s", 0.0))!r}" end="{end!r}" '
            f'vehsPerHour="{float(f["vehicles_per_hour"])!r}" departLane="best" '
            f'departSpeed="{"max" if speed is None else repr(float(speed))}"/>'
        )
    return lines


# How far a background vehicle starts from a platoon on its lane, ahead of its leader and
# behind its last vehicle (m).
PLATOON_CLEARANCE_M = 50.0


def background_vtypes(lc, trucks):
    """The background vehicles' types: cars (`background`) and, with a truck share, trucks
    (`background_truck`, 12 m, at most 25 m/s). Without lane changes (`lc` None) every LC2013
    weight is 0; with them, LC2013 with the config's weights (`background_lane_changes`)."""
    if lc is None:
        changes = 'lcStrategic="0" lcCooperative="0" lcSpeedGain="0" lcKeepRight="0"'
    else:
        changes = (
            f'lcCooperative="{float(lc["cooperative"])!r}" lcSpeedGain="{float(lc["speed_gain"])!r}" '
            f'lcKeepRight="{float(lc["keep_right"])!r}" lcAssertive="{float(lc["assertive"])!r}"'
        )
    types = [f'    <vType id="background" length="4.5" minGap="2.5" maxSpeed="36" {changes}/>']
    if trucks > 0.0:
        types.append(
            '    <vType id="background_truck" length="12" minGap="2.5" maxSpeed="25" '
            f'accel="1" decel="4" guiShape="truck" {changes}/>'
        )
    return types


def background_vehicle(b, lane, pos, rng, trucks):
    """Background vehicle b's route line: a truck with probability `trucks` (drawn only when
    there are trucks, so a run without keeps its draws), entering at 18-24 m/s, else a car at
    20-30 m/s."""
    truck = trucks > 0.0 and rng.random() < trucks
    speed = rng.uniform(18.0, 24.0) if truck else rng.uniform(20.0, 30.0)
    return (
        f'    <vehicle id="bg{b}" type="{"background_truck" if truck else "background"}" '
        f'route="road" depart="0" departLane="{lane}" departPos="{pos!r}" departSpeed="{speed!r}"/>'
    )


def background_segments(spec):
    """Per lane of `background_lanes`, the stretches (lo, hi) of lane position where background
    vehicles may start: 50 m from either end of the lane, and on a platoon's lane not within
    PLATOON_CLEARANCE_M of the platoon (from its last vehicle's rear to its leader's front)."""
    s = spec["sumo"]
    n1, length, offset = int(spec["vehicles_per_platoon"]), float(s["vehicle_length_m"]), float(s["offset_m"])
    busy = {}
    for j, lane in enumerate(spec["lanes"]):
        p = [float(x[0]) + offset for x in spec["initial"][j * n1:(j + 1) * n1]]
        busy.setdefault(int(lane), []).append(
            (min(p) - length - PLATOON_CLEARANCE_M, max(p) + PLATOON_CLEARANCE_M)
        )
    segments = {}
    for lane, lane_length in s["background_lanes"]:
        lo, end, stretch = 50.0, float(lane_length) - 50.0, []
        for a, b in sorted(busy.get(int(lane), [])):
            if a > lo:
                stretch.append((lo, min(a, end)))
            lo = max(lo, b)
        if end > lo:
            stretch.append((lo, end))
        segments[lane] = [(a, b) for a, b in stretch if b > a]
    return segments


def open_native(spec, sumo):
    """The C++ loop over this run's vehicles (platoon.sumo.native.Fleet), or None for the Python
    loop."""
    n = len(spec["initial"])
    n1 = int(spec["vehicles_per_platoon"])
    radar = spec.get("radar_range_m")
    s = spec["sumo"]
    if s.get("road") or s.get("leader"):
        # The C++ loop reads lane positions and sets every vehicle's acceleration; a route of
        # several edges (road positions from lane ids) and a leader SUMO drives are stepped here.
        print("platoon.sumo: the Python loop (sumo.route of several edges, or leader.drive = sumo)",
              file=sys.stderr, flush=True)
        return None
    return sumo_native.open_fleet(
        sumo,
        [vehicle_id(i) for i in range(n)],
        [i for i in range(n) if i % n1] if radar is not None else [],
        radar,
        [f"bg{b}" for b in range(int(spec["sumo"].get("background_vehicles", 0)))],
        say=lambda m: print(f"platoon.sumo: {m}", file=sys.stderr, flush=True),
    )


def start_sumo(spec):
    import libsumo  # imported here: it sets SUMO_HOME for its own data files

    s = spec["sumo"]
    write_routes(s["routes"], spec)
    args = [
        "sumo",
        "--net-file", s["net"],
        "--route-files", s["routes"],
        "--step-length", repr(spec["dt"]),
        "--step-method.ballistic", "true",
        "--collision.action", s["collision_action"],
        "--collision.mingap-factor", "0",
        "--collision.check-junctions", "true",
        "--time-to-teleport", "-1",
        "--no-step-log", "true",
        "--no-warnings", "true",
        "--seed", "0",
    ]
    if s.get("lanechanges"):
        args += ["--lanechange-output", s["lanechanges"]]
    if s["fcd_period_s"] > 0:
        args += [
            "--fcd-output", s["fcd"],
            "--fcd-output.acceleration", "true",
            "--device.fcd.period", repr(s["fcd_period_s"]),
        ]
    libsumo.start(args)
    libsumo.simulationStep()  # inserts the vehicles; their state is still the initial one
    n = len(spec["initial"])
    n1 = int(spec["vehicles_per_platoon"])
    driven = bool(s.get("leader"))
    for i in range(n):
        vid = vehicle_id(i)
        if not (driven and i % n1 == 0):  # a leader SUMO drives keeps SUMO's safe speeds
            libsumo.vehicle.setSpeedMode(vid, 0)
        libsumo.vehicle.setLaneChangeMode(vid, 0)
    for j in range(len(spec["lanes"])):
        for a in range(len(s.get("ahead", []))):
            libsumo.vehicle.setLaneChangeMode(ahead_id(j, a), 0)
    return libsumo


# The flags of a state about the vehicle ahead: AHEAD, INTRUDER and who it is.
AHEAD_FLAGS = w.VehicleState.AHEAD | w.VehicleState.INTRUDER | (0xFFFFFF << w.VehicleState.TARGET_SHIFT)

# The numpy views of the wire types (the same fields and offsets as the ctypes mirrors).
COMMAND = np.ctypeslib.as_array((w.Command * 1)()).dtype
# A command's modes `left` (8: a member that left) and `beside` (9: a joiner waiting beside)
# (Command.flags, MODE_SHIFT): the vehicle drives in the lane beside the platoon's.
SIDE_MODES = (8, 9)


class Road:
    """Positions along a route of several edges (`[sumo] route`): a vehicle's lane position
    plus where its lane starts along the platoons' lane (plant.json's `road`, from the
    network's lengths and connections). Remembers the lanes the platoons drove on."""

    def __init__(self, spec, sumo):
        self.start = {str(lane): float(x) for lane, x in spec["sumo"]["road"]}
        self.sumo = sumo
        self.platoon_lanes = set()

    def position(self, vid):
        """Platoon vehicle vid's road position (lane coordinates: before the offset)."""
        lane = self.sumo.vehicle.getLaneID(vid)
        start = self.start.get(lane)
        if start is None:
            raise SumoError(f"{vid} is on lane {lane!r}, off the platoon's route (sumo.route)")
        self.platoon_lanes.add(lane)
        return start + self.sumo.vehicle.getLanePosition(vid)

    def traffic_position(self, vid):
        """Another vehicle's road position, NaN off the route's lanes (on a ramp, say)."""
        start = self.start.get(self.sumo.vehicle.getLaneID(vid))
        return float("nan") if start is None else start + self.sumo.vehicle.getLanePosition(vid)


class Flows:
    """`[[sumo.flows]]`' vehicles (`flow<i>.<n>`) for sumo.json: when each entered the network,
    every lane it drove on (and from which step), when it left; whether it ever drove on a lane
    of the platoons' (merged into their lane) is decided at the end."""

    def __init__(self, spec, sumo):
        self.sumo = sumo
        self.enabled = bool(spec["sumo"].get("flows"))
        self.alive = set()
        self.log = {}
        # Those inserted by the step that inserted the platoon (start_sumo's).
        self.observe(0, sumo.vehicle.getIDList())

    def observe(self, k, departed=None):
        if not self.enabled:
            return
        sim, vehicle = self.sumo.simulation, self.sumo.vehicle
        for vid in sim.getDepartedIDList() if departed is None else departed:
            if vid.startswith("flow"):
                self.alive.add(vid)
                self.log[vid] = {"depart_step": k, "lanes": {}, "arrive_step": None}
        for vid in sim.getArrivedIDList():
            if vid in self.alive:
                self.alive.discard(vid)
                self.log[vid]["arrive_step"] = k
        for vid in self.alive:
            lanes = self.log[vid]["lanes"]
            lane = vehicle.getLaneID(vid)
            if lane not in lanes:
                lanes[lane] = k

    def report(self, platoon_lanes):
        merged = {}
        for vid, x in self.log.items():
            steps = [k for lane, k in x["lanes"].items() if lane in platoon_lanes]
            x["on_platoon_lane_step"] = min(steps) if steps else None
            if steps:
                merged[vid] = min(steps)
        return {
            "departed": len(self.log),
            "arrived": sum(x["arrive_step"] is not None for x in self.log.values()),
            "on_platoon_lane": len(merged),
            "platoon_lanes": sorted(platoon_lanes),
            "vehicles": self.log,
        }


class Kinematics:
    """Every vehicle's position and speed, from SUMO and from the model (the Rust formulas of
    `plant_step`; with numpy for large fleets, as whole-array operations that round as the
    loop does), and how far apart they are."""

    def __init__(self, spec, sumo, mode, native=None, intruders=None):
        self.sumo = sumo
        self.native = native  # native.Fleet: SUMO's states come from its arrays
        self.intruders = intruders  # Intruders: the cut-ins, which enter and leave in `read`
        self.mode = mode  # "sumo": the controllers see SUMO's states; "model": the model's
        self.offset = float(spec["sumo"]["offset_m"])
        self.dt = float(spec["dt"])
        n = len(spec["initial"])
        self.vector = model.vectorised(n)
        self.p = [float(x[0]) for x in spec["initial"]]
        self.v = [float(x[1]) for x in spec["initial"]]
        if self.vector:
            self.p, self.v = np.array(self.p), np.array(self.v)
        self.max_dp = 0.0
        self.max_dv = 0.0
        self.worst = None
        self.ids = [vehicle_id(i) for i in range(n)]
        self.n1 = int(spec["vehicles_per_platoon"])
        # Positions along a route of several edges; the leaders SUMO's car-following model
        # drives (their states are SUMO's, whatever the model says).
        self.road = Road(spec, sumo) if spec["sumo"].get("road") else None
        self.driven = list(range(0, n, self.n1)) if spec["sumo"].get("leader") else []
        self.pushed = [i for i in range(n) if i not in set(self.driven)]
        self.platoons = len(spec["lanes"])
        # The radar's view (when a fallback or the guard reads it): SUMO's leader on the lane.
        self.radar_range = spec.get("radar_range_m")
        self.followers = [i for i in range(n) if i % self.n1]
        # Who an intruder is, in the state's flags (VehicleState.TARGET_SHIFT): the cut-ins,
        # then the background vehicles.
        cut_ins = len(spec.get("cut_ins", []))
        self.codes = {intruder_id(j, c): 1 + c for j in range(self.platoons) for c in range(cut_ins)}
        for b in range(int(spec["sumo"].get("background_vehicles", 0))):
            self.codes[f"bg{b}"] = 1 + cut_ins + b
        # Each platoon vehicle's platoon: a member ahead on the lane is no intruder, whether
        # it is the predecessor or, after members between left, one further up.
        self.platoon_of = {vid: g // self.n1 for g, vid in enumerate(self.ids)}
        # Lane changes (leaves, joins from beside): the lane beside each platoon's, and who is
        # in it (the joiners from beside at first).
        self.side_lanes = [int(x) for x in spec["sumo"].get("side_lanes", [])]
        starts_beside = set(spec["sumo"].get("beside", []))
        self.beside = {g for g in range(n) if g % self.n1 in starts_beside}
        self.platoon_lanes = [int(x) for x in spec["lanes"]]
        # When a lane change is safe (the native plant's rule), every member's length, and
        # the lane-change waits (for sumo.json).
        self.rule = model.LaneChangeRule(spec["lane_change"]) if spec.get("lane_change") else None
        if self.rule is not None:
            self.lengths = member_lengths(spec)
        self.waiting = {}
        # The states sample, filled in place (through a numpy view for large fleets).
        self.out = (w.VehicleState * n)()
        self.view = np.ctypeslib.as_array(self.out)
        self.view["vehicle"] = np.arange(n, dtype=np.uint32)

    def commands(self, cmds):
        """The followers' commands u in slot order (platoon j's follower i at j * N + i - 1),
        and whether the guard overrode each (Command.GUARD), in the same order."""
        n1 = self.n1
        if self.vector:
            got = np.frombuffer(cmds, dtype=COMMAND)
            j, i = np.divmod(got["vehicle"].astype(np.intp), n1)
            bad = (i == 0) | (j >= self.platoons)
            if bad.any():
                raise SumoError(f"commands for vehicles that are not followers: {got['vehicle'][bad][:5].tolist()}")
            odd = ~np.isfinite(got["u"])
            if odd.any():
                raise SumoError(f"non-finite commands for vehicles {got['vehicle'][odd][:5].tolist()}")
            u = np.zeros(len(cmds), dtype=np.float64)
            u[j * (n1 - 1) + i - 1] = got["u"]
            guard = np.zeros(len(cmds), dtype=bool)
            guard[j * (n1 - 1) + i - 1] = (got["flags"] & np.uint32(w.Command.GUARD)) != 0
            return u, guard
        u = [0.0] * len(cmds)
        guard = [False] * len(cmds)
        for c in cmds:
            j, i = divmod(c.vehicle, n1)
            if i == 0 or j >= self.platoons:
                raise SumoError(f"a command for vehicle {c.vehicle}, which is not a follower")
            if not np.isfinite(c.u):
                raise SumoError(f"a non-finite command ({c.u}) for vehicle {c.vehicle}")
            u[j * (n1 - 1) + i - 1] = c.u
            guard[j * (n1 - 1) + i - 1] = (c.flags & w.Command.GUARD) != 0
        return u, guard

    def change_lanes(self, cmds, k, report):
        """Each follower to the lane its command's mode asks for (Command.flags, MODE_SHIFT):
        the lane beside the platoon's for `left` (8) and `beside` (9), else the platoon's, when
        the gap there is safe (`model.LaneChangeRule`, the native plant's rule, in the same
        order: by wire number, each seeing the lanes as those before it left them); otherwise
        it stays and asks again at the next step. SUMO changes lanes in the coming step
        (lane-change mode 0: at once); each change goes into the report, with how long the
        vehicle waited for a safe gap."""
        if not self.side_lanes:
            return
        got = np.frombuffer(cmds, dtype=COMMAND)
        modes = (got["flags"] >> w.Command.MODE_SHIFT) & w.Command.MODE_MASK
        side = np.isin(modes, SIDE_MODES)
        for g, beside in sorted(zip(got["vehicle"].tolist(), side.tolist())):
            if beside == (g in self.beside):
                self.waiting.pop(g, None)
                continue
            since = self.waiting.setdefault(g, k)
            if self.rule is not None and not self.lane_change_safe(g, beside):
                continue
            del self.waiting[g]
            j = g // self.n1
            lane = self.side_lanes[j] if beside else self.platoon_lanes[j]
            (self.beside.add if beside else self.beside.discard)(g)
            # Held in that lane until told otherwise.
            self.sumo.vehicle.changeLane(self.ids[g], lane, 1e9)
            report.append({"step": k, "t": k * self.dt, "vehicle": self.ids[g], "lane": lane,
                           "waited_s": (k - since) * self.dt})

    def lane_change_safe(self, g, beside):
        """Whether wire vehicle g may move into the lane beside its platoon's (`beside`) or
        back into the platoon's, at the states published at this step: among its platoon's
        members on that lane and the cars of its cut-ins there (both as the native plant has
        them: the model's values), and any other SUMO vehicle that is the nearest ahead or
        behind it on that lane (background traffic, other platoons), as SUMO has it."""
        n1 = self.n1
        j, i = divmod(g, n1)
        lo = j * n1
        vehicle = lambda h: [float(self.p[h]), float(self.v[h]), self.lengths[h - lo]]
        others = [vehicle(h) for h in range(lo, lo + n1)
                  if h != g and (h in self.beside) == beside]
        known = {self.ids[h] for h in range(lo, lo + n1)}
        if self.intruders:
            cuts = self.intruders.platoons[j]
            for c, x in enumerate(cuts.cars):
                known.add(intruder_id(j, c))
                if x is not None and x[2] == beside:
                    others.append([x[0], x[1], float(cuts.cut_ins[c]["length_m"])])
        me = vehicle(g)
        others.extend(self.strangers(g, beside, me, known))
        return self.rule.safe_among(me, others)

    def strangers(self, g, beside, me, known):
        """The nearest SUMO vehicles ahead and behind wire vehicle g on the lane it wants,
        other than `known` ones, as [front bumper, speed, length] in the platoon's road
        coordinates (SUMO's neighbour gaps: a leader's is bumper to bumper less g's minGap,
        0 for members; a follower's less the follower's own minGap)."""
        j = g // self.n1
        target = self.side_lanes[j] if beside else self.platoon_lanes[j]
        here = self.platoon_lanes[j] if beside else self.side_lanes[j]
        vehicle, vid = self.sumo.vehicle, self.ids[g]
        # getNeighbors' mode: bit 0 right (else left), bit 1 leaders (else followers).
        right = 0 if target > here else 1
        leaders, followers = vehicle.getNeighbors(vid, right | 2), vehicle.getNeighbors(vid, right)
        out = []
        for other, dist in leaders:
            if other not in known:
                length = vehicle.getLength(other)
                out.append([me[0] + dist + length, vehicle.getSpeed(other), length])
        for other, dist in followers:
            if other not in known:
                gap = dist + vehicle.getMinGap(other)
                out.append([me[0] - me[2] - gap, vehicle.getSpeed(other), vehicle.getLength(other)])
        return out

    def step(self, accel, k):
        """The model's p, v after step k with the accelerations held over it."""
        dt = self.dt
        if self.vector:
            self.p = self.p + self.v * dt + 0.5 * accel * dt * dt
            self.v = self.v + accel * dt
            return
        for i, a in enumerate(accel):
            p, v = self.p[i], self.v[i]
            self.p[i] = p + v * dt + 0.5 * a * dt * dt
            self.v[i] = v + a * dt

    def read(self, k, accel):
        """The states to publish at step k (a VehicleState array), after comparing SUMO with
        the model. One libsumo call per vehicle and quantity (subscriptions cost more per
        step here, from Python and from C++: BENCHMARKS.md), made by the C++ loop when there
        is one, which leaves SUMO's values in its arrays."""
        get_pos, get_speed = self.sumo.vehicle.getLanePosition, self.sumo.vehicle.getSpeed
        if self.road is not None:
            get_pos = self.road.position
        ids = self.ids
        driven = self.driven
        if self.native is not None:
            lane, speed = self.native.states()
            if not self.vector:
                # The loop below, reading those values by index instead of asking libsumo.
                ids = range(len(self.ids))
                get_pos, get_speed = lane.tolist().__getitem__, speed.tolist().__getitem__
        if not self.vector:
            out = self.out
            for i, vid in enumerate(ids):
                p = get_pos(vid) - self.offset
                v = get_speed(vid)
                if driven and i % self.n1 == 0:
                    self.p[i], self.v[i] = p, v  # SUMO's model moves it: nothing to compare
                self.compare(k, i, abs(p - self.p[i]), abs(v - self.v[i]))
                if self.mode == "sumo":
                    self.p[i], self.v[i] = p, v  # the next comparison is over one step
                s = out[i]
                s.p, s.v, s.a = self.p[i], self.v[i], accel[i]
            self.arrive_and_sense(k)
            return out
        if self.native is not None:
            p, v = lane - self.offset, speed.copy()
        else:
            p = np.array([get_pos(vid) for vid in self.ids]) - self.offset
            v = np.array([get_speed(vid) for vid in self.ids])
        if driven:
            self.p[driven], self.v[driven] = p[driven], v[driven]
        dp, dv = np.abs(p - self.p), np.abs(v - self.v)
        max_dp, max_dv = float(dp.max()), float(dv.max())
        if max_dp > self.max_dp or max_dv > self.max_dv:
            i = int(dp.argmax() if max_dp > self.max_dp else dv.argmax())
            self.worst = {"step": k, "vehicle": i, "dp_m": float(dp[i]), "dv_mps": float(dv[i])}
            self.max_dp, self.max_dv = max(self.max_dp, max_dp), max(self.max_dv, max_dv)
        if self.mode == "sumo":
            self.p, self.v = p, v
        self.view["p"], self.view["v"], self.view["a"] = self.p, self.v, accel
        self.arrive_and_sense(k)
        return self.out

    def members(self, j):
        """The SUMO ids of platoon j's members."""
        return set(self.ids[j * self.n1:(j + 1) * self.n1])

    def arrive_and_sense(self, k):
        """The cut-ins of step k enter (mid-gap, from the states published) and leave, then
        the radars read the lane, and each state says its vehicle's lane (BESIDE)."""
        if (self.intruders and self.intruders.arrive(k, self.p, self.v, self.beside, self.members)
                and self.native is not None):
            self.native.reread()
        self.sense()
        if self.side_lanes:
            flags = self.view["flags"] & ~np.uint32(w.VehicleState.BESIDE)
            for g in self.beside:
                flags[g] |= np.uint32(w.VehicleState.BESIDE)
            self.view["flags"] = flags

    def sense(self):
        """What each follower's radar sees, as SUMO has it: the nearest vehicle ahead on its
        lane, whoever it is (a background vehicle or a cut-in included): the bumper-to-bumper
        gap (`getLeader`; minGap is 0), the closing speed, and whether it is not the platoon's
        predecessor (INTRUDER). The controllers keep only what is within the radar's range."""
        if self.radar_range is None:
            return
        if self.native is not None:
            self.sense_native()
            return
        get_leader, get_speed = self.sumo.vehicle.getLeader, self.sumo.vehicle.getSpeed
        out, ahead_flags = self.out, AHEAD_FLAGS
        for i in self.followers:
            vid = self.ids[i]
            ahead = get_leader(vid, self.radar_range)
            s = out[i]
            s.flags &= ~ahead_flags
            if ahead:
                s.flags |= w.VehicleState.AHEAD
                if not self.member_ahead(ahead[0], i):
                    s.flags |= w.VehicleState.INTRUDER | self.target(ahead[0])
                s.gap = ahead[1]
                s.closing = get_speed(vid) - get_speed(ahead[0])
            else:
                s.gap = s.closing = 0.0

    def sense_native(self):
        """`sense` from what the C++ loop read (`ahead`: 0 none, 1 the predecessor, 2 another
        vehicle): the same values, the same subtraction."""
        nat = self.native
        ahead_flags = AHEAD_FLAGS
        if not self.vector:
            out, speed = self.out, nat.speed.tolist()
            gap, ahead_speed = nat.gap.tolist(), nat.ahead_speed.tolist()
            for j, i in enumerate(self.followers):
                s = out[i]
                s.flags &= ~ahead_flags
                if nat.ahead[j]:
                    s.flags |= w.VehicleState.AHEAD
                    if nat.ahead[j] == 2:
                        s.flags |= self.intruder_flags(i)
                    s.gap = gap[j]
                    s.closing = speed[i] - ahead_speed[j]
                else:
                    s.gap = s.closing = 0.0
            return
        f, seen = nat.followers, nat.ahead
        ahead = seen.astype(bool)
        view = self.view
        flags = view["flags"][f] & ~np.uint32(ahead_flags)
        flags |= np.where(ahead, np.uint32(w.VehicleState.AHEAD), np.uint32(0))
        for j in np.flatnonzero(seen == 2):  # few: the followers with a vehicle cut in ahead
            flags[j] |= np.uint32(self.intruder_flags(int(f[j])))
        view["flags"][f] = flags
        view["gap"][f] = np.where(ahead, nat.gap, 0.0)
        view["closing"][f] = np.where(ahead, nat.speed[f] - nat.ahead_speed, 0.0)

    def target(self, vid):
        """The flags naming vehicle `vid` ahead (VehicleState.TARGET_SHIFT; 0: not named)."""
        return self.codes.get(vid, 0) << w.VehicleState.TARGET_SHIFT

    def member_ahead(self, vid, i):
        """Whether vehicle `vid`, ahead of follower i on its lane, is a member of its platoon."""
        return self.platoon_of.get(vid) == i // self.n1

    def intruder_flags(self, i):
        """INTRUDER and `target` of follower i's leader on the lane when it is not of its
        platoon (0 when it is: a member further up, after those between left): the C++ loop
        says only that it is not the predecessor, so its id is asked of SUMO (the same call,
        on the same state)."""
        ahead = self.sumo.vehicle.getLeader(self.ids[i], self.radar_range)[0]
        if self.member_ahead(ahead, i):
            return 0
        return w.VehicleState.INTRUDER | self.target(ahead)

    def compare(self, k, i, dp, dv):
        if dp > self.max_dp or dv > self.max_dv:
            self.worst = {"step": k, "vehicle": i, "dp_m": dp, "dv_mps": dv}
            self.max_dp, self.max_dv = max(self.max_dp, dp), max(self.max_dv, dv)


class Intruders:
    """The scripted cut-ins (plant.json's `cut_ins`, into every platoon), each a SUMO vehicle
    (`cutin<c>`, of type `cutin<c>` with its length) from the step it appears, with the
    kinematics and lane changes of `sim::traffic` (platoon.sumo.model.CutIns). At the step the
    native plant's appears, it is put beside the gap, as computed from the states published at
    that step, on the lane beside the platoon's (`side_lanes`), or on the platoon's lane when it
    cuts in at once: `vehicle.add` then `moveTo` puts a vehicle that has not departed on the
    lane at once (at its departSpeed), so the radars' `getLeader` of that same step sees it. It
    changes lanes by `moveTo` at its position (also at once) when the model says the gap is
    safe, SUMO's own vehicles on that lane counted (`strangers`). Over each step it holds its
    scripted acceleration (`setAcceleration`; speed mode 0, no lane changes of its own). Not a
    platoon vehicle: no state, no command; its collisions are SUMO's like any other."""

    def __init__(self, spec, sumo):
        self.sumo = sumo
        cut_ins = spec.get("cut_ins", [])
        self.n1 = int(spec["vehicles_per_platoon"])
        self.dt = float(spec["dt"])
        # Every member's length, leader first (its class's with vehicle classes).
        self.lengths = member_lengths(spec)
        self.offset = float(spec["sumo"]["offset_m"])
        edge = spec["sumo"]["edge"]
        self.lanes = [f"{edge}_{lane}" for lane in spec["lanes"]]
        self.side_lanes = [f"{edge}_{lane}" for lane in spec["sumo"].get("side_lanes", [])]
        rule = model.LaneChangeRule(spec["lane_change"]) if cut_ins else None
        self.platoons = [model.CutIns(cut_ins, rule) for _ in spec["lanes"]] if cut_ins else []
        # What happened, for sumo.json: per vehicle, when and where it appeared, when it
        # entered the platoon's lane and left it, and how far SUMO's position and speed got
        # from the kinematics.
        self.log = {}
        self.max_dp = self.max_dv = 0.0

    def __bool__(self):
        return bool(self.platoons)

    def arrive(self, k, p, v, beside=frozenset(), known=None) -> bool:
        """Step k's appearances and lane changes, given the states published at k (p, v: every
        platoon's, wire order), the members on the lane beside (`beside`, wire numbers) and
        `known(j)`, the SUMO ids of platoon j's members. Whether any car appeared or changed
        lanes."""
        t = k * self.dt
        if not self.due(t):
            return False
        n1, changed = self.n1, False
        vehicle = self.sumo.vehicle
        for j, cuts in enumerate(self.platoons):
            lo = j * n1
            off, ids = self.around(j, cuts, beside, known)

            def strangers(to_beside, j=j, ids=ids):
                return self.strangers(self.side_lanes[j] if to_beside else self.lanes[j], ids)

            appeared, entered, left = cuts.arrive(t, p[lo:lo + n1], v[lo:lo + n1], self.lengths,
                                                  off, strangers)
            for c in appeared:
                vid = intruder_id(j, c)
                x, speed, on_side = cuts.cars[c]
                lane_id = self.side_lanes[j] if on_side else self.lanes[j]
                vehicle.add(vid, "road", typeID=f"cutin{c}", depart="now",
                            departLane=lane_id.rsplit("_", 1)[1], departPos="0",
                            departSpeed=repr(speed))
                vehicle.moveTo(vid, lane_id, x + self.offset)
                vehicle.setSpeedMode(vid, 0)
                vehicle.setLaneChangeMode(vid, 0)
                self.log[vid] = {"appeared_step": k, "p_m": x, "v_mps": speed,
                                 "entered_step": None, "left_step": None}
            for c in entered:
                vid = intruder_id(j, c)
                if c not in appeared:
                    vehicle.moveTo(vid, self.lanes[j], cuts.cars[c][0] + self.offset)
                self.log[vid]["entered_step"] = k
            for c in left:
                vid = intruder_id(j, c)
                vehicle.moveTo(vid, self.side_lanes[j], cuts.cars[c][0] + self.offset)
                self.log[vid]["left_step"] = k
            changed = changed or bool(appeared or entered or left)
        if changed:
            self.compare()
        return changed

    def strangers(self, lane_id, known):
        """SUMO's vehicles on lane `lane_id` other than `known` ones (background traffic, other
        platoons), as [front bumper, speed, length] in the platoon's road coordinates."""
        vehicle = self.sumo.vehicle
        return [[vehicle.getLanePosition(o) - self.offset, vehicle.getSpeed(o), vehicle.getLength(o)]
                for o in self.sumo.lane.getLastStepVehicleIDs(lane_id) if o not in known]

    def due(self, t) -> bool:
        """Whether any car appears or wants the other lane at time t, in any platoon."""
        return any(cuts.due(t) for cuts in self.platoons)

    def hold(self, k, p, v, beside=frozenset(), known=None):
        """Before SUMO's step k -> k + 1: each car's acceleration over it, as the kinematics
        move it (and SUMO then does), given the states published at k (as `arrive`)."""
        if all(x is None for x in self.platoons[0].cars):  # they appear at the same time in all
            return
        self.compare()
        vehicle, dt, n1 = self.sumo.vehicle, self.dt, self.n1
        t = k * dt
        for j, cuts in enumerate(self.platoons):
            lo = j * n1
            off, ids = self.around(j, cuts, beside, known)

            def leader(c, j=j, ids=ids):
                return self.leader(intruder_id(j, c), ids)

            held = cuts.advance(t, dt, p[lo:lo + n1], v[lo:lo + n1], self.lengths, off, leader)
            for c, a in enumerate(held):
                if a is not None:
                    vehicle.setAcceleration(intruder_id(j, c), a, dt)

    def around(self, j, cuts, beside, known):
        """Platoon j's members on the lane beside (by index), and the SUMO ids the model knows
        (its members' and its cars')."""
        lo = j * self.n1
        off = {g - lo for g in beside if lo <= g < lo + self.n1}
        ids = {intruder_id(j, c) for c in range(len(cuts.cut_ins))}
        if known is not None:
            ids |= known(j)
        return off, ids

    def leader(self, vid, known):
        """The vehicle SUMO has nearest ahead of car `vid` on its lane, as [[front bumper,
        speed, length]] in the platoon's road coordinates, unless it is a `known` one (then
        the model has it, nearer than any other): one `getLeader` call a step, where reading
        the whole lane would cost one call per vehicle on it."""
        vehicle = self.sumo.vehicle
        got = vehicle.getLeader(vid, 1000.0)
        if not got or not got[0] or got[0] in known:
            return []
        o = got[0]
        return [[vehicle.getLanePosition(o) - self.offset, vehicle.getSpeed(o), vehicle.getLength(o)]]

    def compare(self):
        """SUMO's cars against the kinematics (their lane positions minus the offset)."""
        vehicle = self.sumo.vehicle
        for j, cuts in enumerate(self.platoons):
            for c, x in enumerate(cuts.cars):
                if x is not None:
                    vid = intruder_id(j, c)
                    dp = abs(vehicle.getLanePosition(vid) - self.offset - x[0])
                    dv = abs(vehicle.getSpeed(vid) - x[1])
                    self.max_dp, self.max_dv = max(self.max_dp, dp), max(self.max_dv, dv)

    def report(self):
        """sumo.json's `cut_ins`."""
        return {
            "vehicles": self.log,
            "max_deviation_m": self.max_dp,
            "max_deviation_mps": self.max_dv,
        }


class Traffic:
    """SUMO's background vehicles (`bg<b>`) as the `traffic` sample of a step: each one's lane
    position minus the run's offset (the platoon's road coordinates, as the states), flagged
    ON_ROAD, or NaN before it is inserted and after it leaves the road. Who is on the road is
    kept from SUMO's departed and arrived lists (two calls per step), and each position is one
    `getLanePosition` call: per-vehicle calls cost less than subscriptions in libsumo
    (docs/performance.md, "What was tried")."""

    def __init__(self, spec, sumo, native=None, road=None):
        self.sumo = sumo
        self.native = native  # native.Fleet: the positions come from the C++ loop
        self.road = road  # Road: positions along a route of several edges
        self.offset = float(spec["sumo"]["offset_m"])
        n = int(spec["sumo"].get("background_vehicles", 0))
        self.ids = [f"bg{b}" for b in range(n)]
        self.index = {vid: b for b, vid in enumerate(self.ids)}
        self.on_road = [False] * n
        self.depart(sumo.vehicle.getIDList())
        self.out = (w.TrafficVehicle * n)()
        self.view = np.ctypeslib.as_array(self.out) if n else None
        if n:
            self.view["index"] = np.arange(n, dtype=np.uint32)
        self.nan = float("nan")

    def __len__(self):
        return len(self.ids)

    def depart(self, vids):
        for vid in vids:
            b = self.index.get(vid)
            if b is not None:
                self.on_road[b] = True

    def read(self):
        """The traffic sample of the current SUMO step."""
        sim = self.sumo.simulation
        self.depart(sim.getDepartedIDList())
        for vid in sim.getArrivedIDList():
            b = self.index.get(vid)
            if b is not None:
                self.on_road[b] = False
        get_pos, offset, nan = self.sumo.vehicle.getLanePosition, self.offset, self.nan
        if self.road is not None:
            get_pos = self.road.traffic_position
        if self.native is not None:
            lane = self.native.traffic(self.on_road)  # clears on_road for the removed ones
            p = np.where(self.on_road, lane - offset, nan)
        else:
            p = [nan] * len(self.ids)
            for b, vid in enumerate(self.ids):
                if self.on_road[b]:
                    try:
                        p[b] = get_pos(vid) - offset
                    except self.sumo.TraCIException:  # removed some other way (a collision)
                        self.on_road[b] = False
        self.view["p"] = p
        if self.road is None:
            self.view["flags"] = self.on_road
        else:
            # Off the route's lanes (on a ramp): not on the platoons' road, NaN as the contract says.
            self.view["flags"] = np.logical_and(self.on_road, np.isfinite(p))
        return self.out


def run(spec) -> int:
    n = len(spec["initial"])
    steps = int(spec["steps"])
    dt = float(spec["dt"])
    node = w.Endpoint("plant")
    states_out = node.outlet("states", w.VehicleState, n, grow=False)
    # The background traffic, published before the states of each step (the injector reads it
    # once the tx batch that follows the states wakes it). The orchestrator creates the service
    # exactly when there is background traffic.
    nb = int(spec["sumo"].get("background_vehicles", 0))
    traffic_out = node.outlet("traffic", w.TrafficVehicle, nb, grow=False) if nb else None
    commands_in = node.inlet("commands", w.Command)
    control = node.control_inlet()
    status = node.status_outlet()

    k = 0
    report = {
        "sumo_version": None,
        "steps": 0,
        "collisions": [],
        # Vehicles SUMO teleported (none should: --time-to-teleport -1 turns jam teleports off).
        "teleports": [],
        # SUMO's FCD writer ([sumo] fcd = "sumo"); platoon's own (the default) fills this in
        # after the run.
        "fcd": {"file": "fcd.xml", "writer": "sumo", "period_s": spec["sumo"]["fcd_period_s"]}
        if spec["sumo"]["fcd_period_s"] > 0 else None,
    }
    sumo_ns, bridge_ns, sumo_cpu, bridge_cpu = [], [], [], []

    def fail(message):
        print(f"platoon.sumo: {message}", file=sys.stderr)
        # Called while an exception is handled: its whole traceback goes to logs/plant.log.
        traceback.print_exc(file=sys.stderr)
        sys.stderr.flush()
        # FAILED, then the orchestrator's ABORT before exiting (the report lives in our status
        # publisher).
        _plugin.fail(node, control, status, "plant", k, message)

    try:
        sumo = start_sumo(spec)
        report["sumo_version"] = sumo.getVersion()[1]
        native = open_native(spec, sumo)
        report["loop"] = "python" if native is None else "native"
        dyn = model.Dynamics(spec)
        intruders = Intruders(spec, sumo)
        kin = Kinematics(spec, sumo, spec["sumo"]["states"], native, intruders)
        traffic = Traffic(spec, sumo, native, kin.road)
        flows = Flows(spec, sumo)
        tolerance = float(spec["sumo"]["tolerance_m"])
    except Exception as e:  # libsumo raises its own exception types
        fail(f"SUMO could not start: {e}")
        return 1

    w.send_status(status, w.ControlMsg.READY, "plant")
    started = False
    while not started:
        node.wait()
        msg = control.receive()
        while msg is not None:
            kind = msg.payload().contents.kind
            if kind == w.ControlMsg.START:
                started = True
            elif kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT):
                sumo.close()
                return 0
            msg = control.receive()

    try:
        if traffic_out is not None:
            traffic_out.send(0, 0.0, traffic.read())
        states_out.send(0, 0.0, kin.read(0, dyn.accel))
        while True:
            if _plugin.stop_received(control):
                sumo.close()
                return 0
            cmds = commands_in.take(k)
            if cmds is None:
                node.wait()
                continue
            t0 = time.perf_counter_ns()
            c0 = time.thread_time_ns()
            if len(cmds) != len(spec["taus"]):
                raise SumoError(f"{len(cmds)} commands for {len(spec['taus'])} followers")
            u, guard = kin.commands(cmds)
            kin.change_lanes(cmds, k, report.setdefault("lane_changes", []) if kin.side_lanes else None)
            if intruders:
                intruders.hold(k, kin.p, kin.v, kin.beside, kin.members)
            if native is not None:
                # Set, step and read in one call; SUMO's step timed inside it.
                t1 = time.perf_counter_ns()
                c1 = time.thread_time_ns()
                step_ns, step_cpu = native.step(dyn.accel, dt)
                t2 = time.perf_counter_ns()
                c2 = time.thread_time_ns()
                # SUMO's step is its own part of the call; the rest of it is the bridge's work.
                t1, c1 = t2 - step_ns, c2 - step_cpu
            else:
                set_accel = sumo.vehicle.setAcceleration
                accel = dyn.accel.tolist() if dyn.vector else dyn.accel
                if kin.driven:
                    for i in kin.pushed:
                        set_accel(kin.ids[i], accel[i], dt)
                else:
                    for vid, a in zip(kin.ids, accel):
                        set_accel(vid, a, dt)
                t1 = time.perf_counter_ns()
                c1 = time.thread_time_ns()
                sumo.simulationStep()
                t2 = time.perf_counter_ns()
                c2 = time.thread_time_ns()
            flows.observe(k + 1)
            for c in sumo.simulation.getCollisions():
                report["collisions"].append(
                    {
                        "step": k + 1,
                        "t": (k + 1) * dt,
                        "collider": c.collider,
                        "victim": c.victim,
                        "type": c.type,
                        "lane": c.lane,
                        # Along the route when it has several edges (SUMO gives the lane's).
                        "position_m": (c.pos if kin.road is None
                                       else kin.road.start.get(c.lane, float("nan")) + c.pos)
                        - kin.offset,
                    }
                )
            for vid in sumo.simulation.getStartingTeleportIDList():
                report["teleports"].append({"step": k + 1, "t": (k + 1) * dt, "vehicle": vid})
            kin.step(dyn.accel, k)
            dyn.advance(k, u, guard)
            for g in kin.driven:
                # What SUMO's model held over the step (ballistic: the speed's change / dt).
                dyn.accel[g] = sumo.vehicle.getAcceleration(kin.ids[g])
            k += 1
            if k > steps:
                report["steps"] = k
                break
            states = kin.read(k, dyn.accel)
            if max(kin.max_dp, kin.max_dv) > tolerance:
                raise SumoError(
                    f"SUMO deviates from the vehicle model by {kin.worst['dp_m']:.3g} m, "
                    f"{kin.worst['dv_mps']:.3g} m/s (vehicle {kin.worst['vehicle']}; "
                    f"tolerance sumo.tolerance_m = {tolerance:g})"
                )
            if traffic_out is not None:
                traffic_out.send(k, k * dt, traffic.read())
            states_out.send(k, k * dt, states)
            t3 = time.perf_counter_ns()
            c3 = time.thread_time_ns()
            sumo_ns.append(t2 - t1)
            bridge_ns.append((t1 - t0) + (t3 - t2))
            # CPU time: wall time also counts being preempted by the process we just woke.
            sumo_cpu.append(c2 - c1)
            bridge_cpu.append((c1 - c0) + (c3 - c2))
    except Exception as e:
        fail(f"SUMO at step {k}: {e}")
        return 1

    def stats(ns):
        if not ns:
            return None
        ns = sorted(ns)
        return {
            "p50_us": ns[len(ns) // 2] / 1e3,
            "p99_us": ns[min(len(ns) - 1, int(len(ns) * 0.99))] / 1e3,
            "mean_us": statistics.fmean(ns) / 1e3,
        }

    report["states"] = kin.mode
    report["max_deviation_m"] = kin.max_dp
    report["max_deviation_mps"] = kin.max_dv
    report["worst_deviation"] = kin.worst
    if intruders:
        report["cut_ins"] = intruders.report()
    if flows.enabled:
        report["flows"] = flows.report(kin.road.platoon_lanes if kin.road else
                                       {f'{spec["sumo"]["edge"]}_{lane}' for lane in spec["lanes"]})
    if kin.driven:
        report["leader"] = spec["sumo"]["leader"]
    report["sumo_step"] = stats(sumo_ns)
    report["bridge_step"] = stats(bridge_ns)
    report["sumo_step_cpu"] = stats(sumo_cpu)
    report["bridge_step_cpu"] = stats(bridge_cpu)
    tmp = spec["sumo"]["report"] + ".partial"
    with open(tmp, "w") as f:
        json.dump(report, f, indent=2)
        f.write("\n")
    os.replace(tmp, spec["sumo"]["report"])
    sumo.close()
    w.send_status(status, w.ControlMsg.DONE, "plant", k - 1)
    while not _plugin.stop_received(control):
        node.wait()
    return 0


def tight_loop(spec, steps: int) -> dict:
    """The bridge's per-step work without the co-simulation around it: the same SUMO (options,
    network, routes), the same model, set-step-read in a loop with no process hops and no
    waiting (the followers' commands held at 0; no cut-ins). Medians in µs, for `platoon bench step`."""
    import tempfile

    # Its own routes file, and no FCD output: nothing of the run's directory is touched.
    tmp = tempfile.TemporaryDirectory()
    spec = dict(spec, sumo=dict(spec["sumo"], routes=os.path.join(tmp.name, "routes.rou.xml"),
                                fcd_period_s=0, lanechanges=None))
    sumo = start_sumo(spec)
    native = open_native(spec, sumo)
    dyn = model.Dynamics(spec)
    kin = Kinematics(spec, sumo, spec["sumo"]["states"], native)
    traffic = Traffic(spec, sumo, native)
    u = np.zeros(len(spec["taus"])) if dyn.vector else [0.0] * len(spec["taus"])
    dt = float(spec["dt"])
    sumo_ns, bridge_ns = [], []
    for k in range(steps):
        t0 = time.perf_counter_ns()
        if native is not None:
            step_ns, _ = native.step(dyn.accel, dt)
            t2 = time.perf_counter_ns()
            t1 = t2 - step_ns
        else:
            accel = dyn.accel.tolist() if dyn.vector else dyn.accel
            for vid, a in zip(kin.ids, accel):
                sumo.vehicle.setAcceleration(vid, a, dt)
            t1 = time.perf_counter_ns()
            sumo.simulationStep()
            t2 = time.perf_counter_ns()
        kin.step(dyn.accel, k)
        dyn.advance(k, u)
        kin.read(k + 1, dyn.accel)
        if len(traffic):
            traffic.read()
        t3 = time.perf_counter_ns()
        sumo_ns.append(t2 - t1)
        bridge_ns.append((t1 - t0) + (t3 - t2))
    sumo.close()
    tmp.cleanup()
    return {
        "steps": steps,
        "loop": "python" if native is None else "native",
        "sumo_step_p50_us": statistics.median(sumo_ns) / 1e3,
        "bridge_step_p50_us": statistics.median(bridge_ns) / 1e3,
    }


def main() -> int:
    path = os.environ.get("PLATOON_PLANT_SPEC")
    if not path:
        print("platoon.sumo: PLATOON_PLANT_SPEC is not set; start me with `platoon run --plant sumo`",
              file=sys.stderr)
        return 2
    with open(path) as f:
        spec = json.load(f)
    NAMES["per_platoon"] = int(spec["vehicles_per_platoon"])
    NAMES["platoons"] = len(spec["lanes"])
    if len(sys.argv) == 3 and sys.argv[1] == "--tight-loop":
        print(json.dumps(tight_loop(spec, int(sys.argv[2]))))
        return 0
    return run(spec)


if __name__ == "__main__":
    sys.exit(main())
