"""The vehicle model of crates/model, in Python, for the SUMO plant (platoon.sumo.plant): the
engine lag of each follower under its tau schedule, the leader's reference acceleration, and
the scripted cut-ins of crates/sim (`sim::traffic`).

SUMO does the kinematics (ballistic update with the acceleration held over each step); this
module gives the acceleration to hold. Every expression is written exactly as in Rust
(`plant_step`, `TauSchedule::at`, `LeaderProfile::step_acceleration`, `Traffic::arrive` and
`Traffic::advance`) and with the same libm, so
the values are bit-identical; tests/sumo.rs checks them against the values Rust computes.
The schedules come from the plant spec that `platoon run` writes (plant.json), never from
parsing the scenario config a second time.
"""

import bisect
import math
import os

import numpy as np


class TauSchedule:
    """Piecewise tau(t) through knots, with step, linear or smooth interpolation."""

    def __init__(self, knots, interpolation):
        self.times = [float(t) for t, _ in knots]
        self.values = [float(y) for _, y in knots]
        self.interpolation = interpolation

    def at(self, t: float) -> float:
        i = bisect.bisect_right(self.times, t)  # Rust: partition_point(|tk| tk <= t)
        if i == 0:
            return self.values[0]
        if i == len(self.times):
            return self.values[i - 1]
        t0, y0 = self.times[i - 1], self.values[i - 1]
        t1, y1 = self.times[i], self.values[i]
        s = (t - t0) / (t1 - t0)
        if self.interpolation == "step":
            return y0
        if self.interpolation == "linear":
            return y0 + (y1 - y0) * s
        return y0 + (y1 - y0) * s * s * (3.0 - 2.0 * s)


class LeaderProfile:
    """Piecewise-linear leader velocity through waypoints; its slope is the reference."""

    def __init__(self, waypoints):
        self.times = [float(t) for t, _ in waypoints]
        self.speeds = [float(v) for _, v in waypoints]

    def acceleration_at(self, t: float) -> float:
        i = bisect.bisect_right(self.times, t)
        if 1 <= i < len(self.times):
            t0, v0 = self.times[i - 1], self.speeds[i - 1]
            t1, v1 = self.times[i], self.speeds[i]
            return (v1 - v0) / (t1 - t0)
        return 0.0

    def step_acceleration(self, k: int, dt: float) -> float:
        """The acceleration held over step k: the slope at the middle of the step."""
        return self.acceleration_at((float(k) + 0.5) * dt)


def lagged(a: float, u: float, tau: float, dt: float) -> float:
    """a[k+1] from a[k] and u[k]: the exact zero-order-hold solution of tau a' + a = u."""
    return u + (a - u) * math.exp(-dt / tau)


def limits_of(member):
    """A member's `(accel_max, decel_max, emergency_decel)` from plant.json (each None when
    absent; an absent emergency braking is decel_max)."""
    a, d, e = (member.get(k) for k in ("accel_max_mps2", "decel_max_mps2", "emergency_decel_mps2"))
    a, d = (None if a is None else float(a), None if d is None else float(d))
    return (a, d, d if e is None else float(e))


def limit(u: float, limits, guard: bool = False) -> float:
    """`Vehicle::limit`: u held below accel_max, then above -decel_max (-emergency_decel
    while the guard brakes)."""
    a, d, e = limits
    if guard:
        d = e
    if a is not None and a < u:
        u = a
    if d is not None and -d > u:
        u = -d
    return u


class Dynamics:
    """Every vehicle's acceleration state from a plant spec (plant.json)."""

    def __init__(self, spec):
        self.dt = float(spec["dt"])
        self.leader = LeaderProfile(spec["leader"]["waypoints"])
        # Followers share schedules (a fleet repeats its platoon's): evaluate each distinct
        # schedule once per step. exp(-dt / tau) of the same tau is the same number, so this
        # changes no bit of the result.
        distinct, self.schedule_of = {}, []
        for t in spec["taus"]:
            key = repr((t["knots"], t["interpolation"]))
            if key not in distinct:
                distinct[key] = len(distinct)
            self.schedule_of.append(distinct[key])
        by_index = {i: k for k, i in distinct.items()}
        self.schedules = []
        for i in range(len(distinct)):
            t = next(t for t in spec["taus"] if repr((t["knots"], t["interpolation"])) == by_index[i])
            self.schedules.append(TauSchedule(t["knots"], t["interpolation"]))
        self.per_platoon = int(spec["vehicles_per_platoon"])
        n1 = self.per_platoon
        accel = [float(x[2]) for x in spec["initial"]]
        slots = [(g, (g // n1) * (n1 - 1) + g % n1 - 1) for g in range(len(accel)) if g % n1]
        # With vehicle classes (plant.json's `vehicles`, platoon 0's members, leader first):
        # each follower's input held within its class's limits, `Vehicle::limit` in Rust
        # (first the acceleration, then the deceleration); None: no class, no limit.
        members = spec.get("vehicles") or []
        self.limits = None
        if members:
            self.limits = [limits_of(members[g % n1]) for g, _ in slots]
        self.vector = vectorised(len(accel))
        if self.vector:
            # Arrays: a step is a few whole-array operations instead of a loop per vehicle.
            # Element-wise, numpy evaluates `u + (a - u) * e` as Python does (no fused
            # multiply-add), so the values are the same bits (tested against the loop).
            self.accel = np.array(accel, dtype=np.float64)
            self.follower_vehicles = np.array([g for g, _ in slots], dtype=np.intp)
            self.follower_slots = np.array([f for _, f in slots], dtype=np.intp)
            self.follower_schedule = np.array(self.schedule_of, dtype=np.intp)[self.follower_slots]
            self.leaders = np.arange(0, len(accel), n1, dtype=np.intp)
            if self.limits is not None:
                # By slot; an absent limit is infinite, which np.minimum/np.maximum pass through.
                by_slot = [None] * len(slots)
                for (_, f), lim in zip(slots, self.limits):
                    by_slot[f] = lim
                self.accel_max = np.array([math.inf if a is None else a for a, _, _ in by_slot])
                self.decel_min = np.array([-math.inf if d is None else -d for _, d, _ in by_slot])
                self.emergency_min = np.array([-math.inf if e is None else -e for _, _, e in by_slot])
        else:
            self.accel = accel
            self.slots = slots
            self.leaders = range(0, len(accel), n1)

    def advance(self, k: int, u, guard=None) -> None:
        """From step k to k + 1 with the followers' commands u (platoon j's follower i at
        j * N + i - 1; an array when `vector`); guard: whether the guard overrode each command
        (the same order and type; None: none did), which brakes within the emergency limit."""
        t = k * self.dt
        dt = self.dt
        decay = [math.exp(-dt / s.at(t)) for s in self.schedules]
        a_leader = self.leader.step_acceleration(k + 1, dt)
        if self.vector:
            g = self.follower_vehicles
            if self.limits is not None:
                lo = self.decel_min if guard is None else np.where(guard, self.emergency_min, self.decel_min)
                u = np.maximum(np.minimum(u, self.accel_max), lo)
            uf = u[self.follower_slots]
            self.accel[g] = uf + (self.accel[g] - uf) * np.array(decay)[self.follower_schedule]
            self.accel[self.leaders] = a_leader
            return
        accel, which = self.accel, self.schedule_of
        if self.limits is not None:
            for (g, f), lim in zip(self.slots, self.limits):
                uf = limit(u[f], lim, guard is not None and bool(guard[f]))
                accel[g] = uf + (accel[g] - uf) * decay[which[f]]
        else:
            for g, f in self.slots:
                uf = u[f]
                accel[g] = uf + (accel[g] - uf) * decay[which[f]]
        for g in self.leaders:
            accel[g] = a_leader


class CutIns:
    """One platoon's scripted cut-ins (`sim::traffic::Traffic`, from plant.json's `cut_ins`):
    each one's car `[p, v, beside]` (front bumper, speed, on the lane beside the platoon's)
    from the time it appears, else None. It appears beside the gap at `at_s`, changes into
    the platoon's lane when the gap there is safe (`rule`; at once when `aggressive`), and
    from `leave_s` back to the lane beside, where it drives on."""

    def __init__(self, cut_ins, rule):
        self.cut_ins = [dict(c) for c in cut_ins]
        n = len(self.cut_ins)
        self.cars = [None] * n
        self.appeared = [None] * n
        self.entered = [None] * n
        self.left = [None] * n
        self.rule = rule

    def arrive(self, t: float, p, v, lengths, off=(), strangers=None):
        """`Traffic::arrive` at time t, given the platoon's positions p, speeds v and lengths
        (leader first) at that step and `off`, the members (by index) on the lane beside: those
        due appear beside the platoon (`gap_m` ahead of their follower, or mid-gap), those that
        want the other lane move into it where the gap is safe, also from the vehicles
        `strangers(to_beside)` names on that lane (SUMO's own). Returns the indices of the
        cut-ins that appeared, of those that entered the platoon's lane and of those that left
        it."""
        appeared, entered, left = [], [], []
        for c, cut in enumerate(self.cut_ins):
            if self.cars[c] is None and t >= cut["at_s"]:
                i = cut["ahead_of"]
                gap = cut.get("gap_m")
                if gap is not None:
                    x = float(p[i]) + gap + cut["length_m"]
                else:
                    # Equal gaps: ahead - L - x = x - length - behind.
                    x = 0.5 * (float(p[i - 1]) - lengths[i - 1] + float(p[i]) + cut["length_m"])
                speed = float(v[i]) + cut["speed_diff_mps"]
                self.cars[c] = [x, max(speed, 0.0), True]
                self.appeared[c] = t
                appeared.append(c)
            car = self.cars[c]
            if car is None:
                continue
            leave = cut["leave_s"]
            # It asks for the platoon's lane until its time there is up, then for the lane
            # beside (a car that never got in stays there; one that left never comes back).
            beside = (leave is not None and t >= leave) or self.left[c] is not None
            if beside == car[2]:
                continue
            if not cut.get("aggressive", False) and not self.safe(c, beside, p, v, lengths, off, strangers):
                continue
            car[2] = beside
            if beside:
                self.left[c] = t
                left.append(c)
            else:
                self.entered[c] = t
                entered.append(c)
        return appeared, entered, left

    def safe(self, c, beside, p, v, lengths, off, strangers) -> bool:
        """Whether cut-in c's car may move onto the lane beside (`beside`) or the platoon's."""
        car = self.cars[c]
        me = [car[0], car[1], float(self.cut_ins[c]["length_m"])]
        return self.rule.safe_among(me, self.lane(c, beside, p, v, lengths, off, strangers))

    def lane(self, c, beside, p, v, lengths, off, strangers):
        """`Traffic::lane`: the vehicles on the lane beside (`beside`) or the platoon's as
        [front bumper, speed, length], cut-in c's car left out: the members there, the other
        cars there, then `strangers`' vehicles (SUMO's own)."""
        others = [[float(p[i]), float(v[i]), lengths[i]] for i in range(len(p)) if (i in off) == beside]
        others.extend([x[0], x[1], float(self.cut_ins[d]["length_m"])]
                      for d, x in enumerate(self.cars) if x is not None and d != c and x[2] == beside)
        if strangers is not None:
            others.extend(strangers(beside))
        return others

    def due(self, t: float) -> bool:
        """Whether `arrive` at time t has anything to decide: a cut-in to appear, or a car
        that wants the other lane."""
        for c, cut in enumerate(self.cut_ins):
            car = self.cars[c]
            if car is None:
                if t >= cut["at_s"]:
                    return True
                continue
            leave = cut["leave_s"]
            if ((leave is not None and t >= leave) or self.left[c] is not None) != car[2]:
                return True
        return False

    def advance(self, t: float, dt: float, p=(), v=(), lengths=(), off=(), leader=None):
        """`Traffic::advance`: moves every car from t to t + dt, given the platoon at t (as
        `arrive`): once it cut in it brakes for `brake_s` from the moment it entered, otherwise
        it holds its speed; closing in on the vehicle ahead on its lane nearer than the rule's
        safe gap, it brakes at the rule's `safe_decel_mps2`; `leader(c)`, if given, lists the
        vehicle of SUMO's own nearest ahead of car c on its lane (none when the nearest is a
        member or a car). Returns the acceleration each one holds over the step (None before it
        appears)."""
        held = [self.acceleration(c, t, dt, p, v, lengths, off, leader)
                for c in range(len(self.cars))]
        for x, a in zip(self.cars, held):
            if x is not None:
                x[0] += x[1] * dt + 0.5 * a * dt * dt
                x[1] += a * dt
        return held

    def acceleration(self, c, t, dt, p, v, lengths, off, leader):
        """`Traffic::acceleration`: what cut-in c's car holds from t over dt."""
        x = self.cars[c]
        if x is None:
            return None
        cut = self.cut_ins[c]
        e, s = self.entered[c], self.appeared[c]
        # The same float as Rust's: from at_s when it cut in as it appeared.
        braking = e is not None and t < cut["at_s"] + cut["brake_s"] + (e - s)
        a = -cut["decel_mps2"] if braking else 0.0
        # The nearest vehicle ahead on its lane: members first, then the other cars, then
        # SUMO's own.
        others = self.lane(c, x[2], p, v, lengths, off, None)
        if leader is not None:
            others.extend(leader(c))
        ahead = None
        for o in others:
            if o[0] > x[0] and (ahead is None or o[0] < ahead[0]):
                ahead = o
        if (ahead is not None and x[1] > ahead[1]
                and not self.rule.gap_is_safe(ahead[0] - ahead[2] - x[0], x[1] - ahead[1])):
            a = min(a, -self.rule.safe_decel_mps2)
        # It stops rather than reverses.
        if x[1] + a * dt < 0.0:
            a = -x[1] / dt
        return a


class LaneChangeRule:
    """When a lane change is safe (`sim::lanes::LaneChangeRule`, plant.json's `lane_change`):
    the gap between a vehicle and the one ahead of it on the lane it moves into, closing at
    c, at least `min_gap_m + max(c, 0) reaction_s + max(c, 0)^2 / (2 safe_decel_mps2)`, for
    the changer behind its new leader and for its new follower behind it. The same expressions
    as Rust, so both plants change lanes at the same steps (tests/sumo.rs)."""

    def __init__(self, rule):
        self.min_gap_m = float(rule["min_gap_m"])
        self.reaction_s = float(rule["reaction_s"])
        self.safe_decel_mps2 = float(rule["safe_decel_mps2"])

    def gap_is_safe(self, gap: float, closing: float) -> bool:
        c = max(closing, 0.0)
        return gap >= self.min_gap_m + c * self.reaction_s + c * c / (2.0 * self.safe_decel_mps2)

    def safe(self, me, ahead, behind) -> bool:
        """Whether `me` may move between `ahead` and `behind` (each [front bumper, speed,
        length], or None: nobody there)."""
        front = ahead is None or self.gap_is_safe(ahead[0] - ahead[2] - me[0], me[1] - ahead[1])
        back = behind is None or self.gap_is_safe(me[0] - me[2] - behind[0], behind[1] - me[1])
        return front and back

    def safe_among(self, me, others) -> bool:
        """Whether `me` may move onto a lane where `others` drive: between the nearest ahead
        (its front bumper further on than `me`'s, or level) and the nearest behind."""
        ahead = behind = None
        for o in others:
            if o[0] >= me[0]:
                if ahead is None or o[0] < ahead[0]:
                    ahead = o
            elif behind is None or o[0] > behind[0]:
                behind = o
        return self.safe(me, ahead, behind)


# Fleets of at least this many vehicles are stepped with numpy; smaller ones with plain loops,
# which cost less than numpy's per-call overhead there (a 5-vehicle step: ~20 µs against ~45).
VECTOR_MIN_VEHICLES = 64


def vectorised(vehicles: int) -> bool:
    """Whether a fleet of `vehicles` is stepped with numpy (PLATOON_BRIDGE_VECTOR_MIN
    overrides the threshold: the tests run both ways and compare the bits)."""
    threshold = os.environ.get("PLATOON_BRIDGE_VECTOR_MIN")
    return vehicles >= (int(threshold) if threshold else VECTOR_MIN_VEHICLES)
