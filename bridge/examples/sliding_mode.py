"""A law the project does not have, on the Python controller SDK: a sliding-mode CACC. It is an
example of what a controller plug-in can do, not a validated law: nothing here proves it
string stable, and its gains are tuned by hand on configs/paper.toml only.

Each follower i measures its own speed and acceleration and, with its radar, the gap to the
vehicle ahead and the closing speed (VehicleState.gap, .closing); over V2V it hears its
predecessor's acceleration (every vehicle broadcasts its state at every step). With the spacing
error e = gap - d (d = spacing_m - vehicle_length_m + time_headway_s v) and e' = -closing, it
drives the sliding variable

    S = e' + lam e          to zero with          S' = -k S - eta sat(S / phi),

taking its own acceleration as the input (the power-train lag is left to the boundary layer
phi), which gives

    u = a_pred + (lam + k) e' + k lam e + eta sat(S / phi)

clipped to [-8, 4] m/s^2. While it has no packet of its predecessor from the last 0.1 s (a DoS,
a lossy link) it drops the feed-forward a_pred and says so: `affected`, mode `acc`.

    platoon run configs/paper.toml --controller "bridge/.venv/bin/python bridge/examples/sliding_mode.py"

Options: --lam, --k, --eta, --phi (defaults 1.0, 1.0, 0.5, 0.5).
"""

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.controller as pc  # noqa: E402

U_MIN, U_MAX = -8.0, 4.0
FRESH_S = 0.1  # a predecessor's packet older than this is not used


class SlidingMode(pc.Controller):
    def __init__(self, run, platoon, lam, k, eta, phi):
        p = run.config["platoon"]
        self.n = run.vehicles_per_platoon - 1
        self.gap0 = p["spacing_m"] - p.get("vehicle_length_m", 0.0)
        self.headway = (
            p.get("time_headway_s", 0.0) if p.get("spacing_policy") == "time_headway" else 0.0
        )
        self.lam, self.k, self.eta, self.phi = lam, k, eta, phi
        self.fresh_steps = max(1, round(FRESH_S / run.dt))
        self.seq = [0] * (self.n + 1)
        self.last_u = [0.0] * (self.n + 1)
        self.pred = [None] * (self.n + 1)  # (step, acceleration) last heard from i - 1
        self.refused = [0] * 6

    def transmit(self, step, tx):
        # Everyone broadcasts its state at every step; the leader's u is its acceleration.
        for i, s in enumerate(step.states):
            self.seq[i] += 1
            u = s.a if i == 0 else self.last_u[i]
            tx.append(pc.Packet(i, self.seq[i], step.k, (s.p, s.v, s.a), u))

    def receive(self, step, commands):
        k = step.k
        for d in step.deliveries:
            pk = d.packet
            if not all(math.isfinite(x) for x in pk.state):
                self.refused[0] += 1
            elif pk.step > k:
                self.refused[2] += 1
            elif 1 <= d.receiver <= self.n and pk.sender == d.receiver - 1:
                last = self.pred[d.receiver]
                if last is None or pk.step > last[0]:
                    self.pred[d.receiver] = (pk.step, pk.state[2])
        for i in range(1, self.n + 1):
            me = step.states[i]
            last = self.pred[i]
            fresh = last is not None and k - last[0] <= self.fresh_steps
            a_pred = last[1] if fresh else 0.0
            if me.flags & pc.AHEAD:
                e = me.gap - (self.gap0 + self.headway * me.v)
                de = -me.closing - self.headway * me.a
                s = de + self.lam * e
                sat = max(-1.0, min(1.0, s / self.phi))
                u = a_pred + (self.lam + self.k) * de + self.k * self.lam * e + self.eta * sat
            else:
                u = 0.0  # nothing ahead in sight: coast
            u = max(U_MIN, min(U_MAX, u))
            self.last_u[i] = u
            commands.append(
                pc.Command(u, affected=not fresh, mode=pc.COOP if fresh else pc.ACC)
            )

    def rejected(self):
        return tuple(self.refused)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lam", type=float, default=1.0)
    ap.add_argument("--k", type=float, default=1.0)
    ap.add_argument("--eta", type=float, default=0.5)
    ap.add_argument("--phi", type=float, default=0.5)
    a = ap.parse_args()
    sys.exit(pc.run(lambda run, j: SlidingMode(run, j, a.lam, a.k, a.eta, a.phi)))
