"""The paper's controller (Han et al. 2024) re-implemented in Python on the controller SDK, from
its equations and the run's config: the open-loop estimators (2) on the nominal model, the
neighbourhood error q_i and the law u_i = -K q_i (1), the triggering rules (periodic, static
(21), dynamic (4) + (12)), the resilient sampling (11), u_i = 0 while a follower is affected by
an attack, and the packet checks of docs/injector-contract.md.

Every number is computed with the same floating-point operations in the same order as the Rust
controller (crates/control: the estimator's transition matrix times the state column by column,
K q as k0 q0 + k1 q1 + k2 q2, squared norms as (x0^2 + x1^2) + x2^2, and exp from the same C
library), so with a config that uses nothing else (fallback `zero` without dwell or blend, no
guard; configs/paper.toml, configs/table1.toml) a run with it equals the built-in run byte for
byte (tested on configs/paper.toml, its DoS included). Any other config is refused, naming the
key.

    platoon run configs/paper.toml --controller "bridge/.venv/bin/python bridge/examples/paper_law.py"
"""

import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.controller as pc  # noqa: E402

PLAUSIBLE_ACCEL = 50.0  # m/s^2: no vehicle accelerates harder (the packet checks)


def steps_of(period, dt):
    """A period in whole steps, rounded half away from zero as the config loader does."""
    return int(math.floor(period / dt + 0.5))


class Flow:
    """exp(A dt) of the nominal model p' = v, v' = a, a' = -a / tau, applied as nalgebra does:
    row i is (phi_i0 x0 + phi_i1 x1) + phi_i2 x2."""

    def __init__(self, tau, dt):
        e = math.exp(-dt / tau)
        g = tau * (1.0 - e)
        self.phi = ((1.0, dt, tau * (dt - g)), (0.0, 1.0, g), (0.0, 0.0, e))

    def advance(self, x):
        p, v, a = x
        return tuple(r0 * p + r1 * v + r2 * a for r0, r1, r2 in self.phi)


def norm2(x):
    return x[0] * x[0] + x[1] * x[1] + x[2] * x[2]


def plausible(frm, to, t):
    """The sender can have gone from `frm` to `to` in t seconds with |a| <= PLAUSIBLE_ACCEL."""
    a = PLAUSIBLE_ACCEL
    tol = 1e-6 + 1e-12 * max(abs(frm[0]), abs(to[0]))
    return (
        abs(to[2]) <= a
        and abs(to[1] - frm[1]) <= a * t + tol
        and abs(to[0] - frm[0] - frm[1] * t) <= 0.5 * a * t * t + tol
    )


class Follower:
    def __init__(self, i, hears, initial, theta0):
        self.i = i
        self.hears = hears  # whom it receives from, leader first
        self.estimates = [initial[j] for j in hears]
        # The last packet accepted from each neighbour: (step or None, state).
        self.heard = [(None, initial[j]) for j in hears]
        self.own = initial[i]  # its own state as its neighbours estimate it
        self.theta = theta0
        self.resample_at = None  # (11): its last broadcast was jammed
        self.seq = 0
        self.last_u = 0.0
        self.triggered = False
        self.theta_then = theta0


class PaperLaw(pc.Controller):
    def __init__(self, run, platoon):
        c = run.config
        dt = run.dt
        refuse = None
        fb = c.get("fallback", {})
        if c["control"].get("law", "paper") != "paper":
            refuse = 'control.law (only "paper")'
        elif fb.get("mode", "zero") != "zero" or fb.get("per_vehicle"):
            refuse = 'fallback.mode (only "zero")'
        elif fb.get("dwell_s", 0.0) != 0.0 or fb.get("blend_s", 0.0) != 0.0:
            refuse = "fallback.dwell_s and fallback.blend_s (only 0)"
        elif c.get("guard", {}).get("enabled", False):
            refuse = "guard.enabled (only false)"
        elif fb.get("cut_in") is not None:
            refuse = "fallback.cut_in (only absent)"
        elif c["trigger"]["rule"] not in ("dynamic", "static", "periodic"):
            refuse = 'trigger.rule (only "dynamic", "static" or "periodic")'
        if refuse:
            raise SystemExit(f"paper_law.py does not implement this config's {refuse}")
        tr = c["trigger"]
        self.rule = tr["rule"]
        self.k0, self.k1, self.k2 = c["control"]["gain"]
        self.beta1, self.beta2 = c["control"]["beta1"], c["control"]["beta2"]
        self.resilient = tr.get("resilient", True)
        self.h_steps = steps_of(tr["h_s"], dt)
        self.check_steps = steps_of(tr.get("check_period_s", dt), dt)
        self.period = steps_of(tr["period_s"], dt) if self.rule == "periodic" else None
        self.phi = tr.get("phi", 0.0)
        self.theta0 = tr.get("theta0", 0.0) if self.rule == "dynamic" else 0.0
        # theta' = -rho theta - eta s, integrated exactly over a step with s held.
        if self.rule == "dynamic":
            rho, eta = tr["rho"], tr["eta"]
            self.decay = math.exp(-rho * dt)
            self.theta_gain = eta * ((1.0 - self.decay) / rho if rho > 0.0 else dt)
        platoon_cfg = c["platoon"]
        self.spacing = platoon_cfg["spacing_m"]
        self.headway = (
            platoon_cfg.get("time_headway_s", 0.0)
            if platoon_cfg.get("spacing_policy", "constant") == "time_headway"
            else 0.0
        )
        period = c.get("leader", {}).get("broadcast_period_s")
        self.leader_every = 1 if period is None else steps_of(period, dt)
        self.flow = Flow(c["plant"]["tau_nominal_s"], dt)
        self.dt = dt
        self.topology = run.topology
        self.followers = None  # built from the states of step 0: the initial states
        self.leader_seq = 0
        # The leader's acceleration of the step before: what its packets carry as u.
        self.leader_last_a = 0.0
        self.refused = [0] * 6

    def start(self, states):
        initial = [(s.p, s.v, s.a) for s in states]
        self.followers = [
            Follower(i, self.topology.in_neighbours[i], initial, self.theta0)
            for i in range(1, len(initial))
        ]

    def q(self, f):
        """q_i = sum over neighbours j of x^_i - x^_j - [(j - i) g, 0, 0], g = l + h_t v of the
        rear vehicle of the two."""
        q0 = q1 = q2 = 0.0
        own = f.own
        for j, e in zip(f.hears, f.estimates):
            rear = own[1] if j < f.i else e[1]
            q0 = q0 + (own[0] - e[0])
            q1 = q1 + (own[1] - e[1])
            q2 = q2 + (own[2] - e[2])
            q0 -= (float(j) - float(f.i)) * (self.spacing + self.headway * rear)
        return (q0, q1, q2)

    def s(self, f, x, q):
        """beta1 |x^_i - x_i|^2 - beta2 |q_i|^2."""
        own = f.own
        eps = (own[0] - x[0], own[1] - x[1], own[2] - x[2])
        return self.beta1 * norm2(eps) - self.beta2 * norm2(q)

    def transmit(self, step, tx):
        k = step.k
        if self.followers is None:
            self.start(step.states)
        leader = step.states[0]
        if k % self.leader_every == 0:
            self.leader_seq += 1
            tx.append(
                pc.Packet(0, self.leader_seq, k, (leader.p, leader.v, leader.a), self.leader_last_a)
            )
        self.leader_last_a = leader.a
        for f in self.followers:
            s = step.states[f.i]
            x = (s.p, s.v, s.a)
            if k == 0:
                fire = True  # t = 0 samples under every rule
            elif f.resample_at is not None:
                fire = k >= f.resample_at
            elif self.rule == "periodic":
                fire = k % self.period == 0
            elif k % self.check_steps != 0:
                fire = False
            elif self.rule == "static":
                fire = self.s(f, x, self.q(f)) > 0.0
            else:
                fire = self.s(f, x, self.q(f)) - self.phi * f.theta > 0.0
            f.triggered = fire
            f.theta_then = f.theta
            if fire:
                f.own = x
                f.seq += 1
                tx.append(pc.Packet(f.i, f.seq, k, x, f.last_u))

    def admit(self, k, d):
        """The packet checks; the follower and the sender's slot, or None (counted)."""
        pk = d.packet
        if not all(math.isfinite(x) for x in pk.state) or not math.isfinite(pk.u):
            self.refused[0] += 1
            return None
        if pk.step > k:
            self.refused[2] += 1
            return None
        n = len(self.followers)
        if not 1 <= d.receiver <= n or pk.sender not in self.followers[d.receiver - 1].hears:
            self.refused[1] += 1
            return None
        f = self.followers[d.receiver - 1]
        slot = f.hears.index(pk.sender)
        last_step, last_state = f.heard[slot]
        if last_step is not None and pk.step <= last_step:
            self.refused[3] += 1
            return None
        if pk.seq > pk.step + 1:
            self.refused[4] += 1
            return None
        since = 0 if last_step is None else last_step
        if not plausible(last_state, pk.state, (pk.step - since) * self.dt):
            self.refused[5] += 1
            return None
        f.heard[slot] = (pk.step, pk.state)
        return f, slot

    def receive(self, step, commands):
        k = step.k
        for d in step.deliveries:
            got = self.admit(k, d)
            if got is not None:
                f, slot = got
                x = d.packet.state
                for _ in range(d.packet.step, k):  # a delayed sample, propagated to now
                    x = self.flow.advance(x)
                f.estimates[slot] = x
        for f in self.followers:
            jam = step.jammed[f.i]
            if f.triggered and self.resilient:
                f.resample_at = k + self.h_steps if jam else None
            affected = jam or f.resample_at is not None
            q = self.q(f)
            u = 0.0 if affected else -(self.k0 * q[0] + self.k1 * q[1] + self.k2 * q[2])
            if not affected and self.rule == "dynamic":
                s = step.states[f.i]
                x = (s.p, s.v, s.a)
                f.theta = max(self.decay * f.theta - self.theta_gain * self.s(f, x, q), 0.0)
            f.last_u = u
            commands.append(
                pc.Command(
                    u,
                    theta=f.theta_then,
                    affected=affected,
                    mode=pc.ZERO if affected else pc.COOP,
                    triggered=f.triggered,
                )
            )
            # Every estimate advances to step k + 1.
            f.own = self.flow.advance(f.own)
            f.estimates = [self.flow.advance(e) for e in f.estimates]

    def rejected(self):
        return tuple(self.refused)


if __name__ == "__main__":
    sys.exit(pc.run(PaperLaw))
