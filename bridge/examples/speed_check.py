"""A misbehaviour detector of one's own, in Python, measured by the run against ground truth:
the paper's law (paper_law.py) whose followers also check that each packet's claimed position
agrees with the sender's previous claim moved by the claimed speeds and accelerations
(position-speed consistency, F2MD's idea, here as a kinematic residual). It only logs: the
commands are paper_law.py's, so the run's trajectories are the built-in run's.

Name the detector in the config and run it as the controller:

    [detection]
    plugin = ["pos_speed"]

    platoon run my.toml --controller "bridge/.venv/bin/python bridge/examples/speed_check.py"

`summary.json`'s `detection` then has its precision, recall, F1 and time to detect per
ground-truth label, and `detections.csv` a row per delivery (`inspected` on those it inspected).
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.controller as pc  # noqa: E402
from paper_law import PaperLaw  # noqa: E402

NAME = "pos_speed"
# The residual a genuine claim may show: 1 cm, plus what an unmodelled jerk of 1 m/s^3 moves a
# vehicle over the gap between the two claims (jerk t^3 / 6).
FLOOR_M, JERK = 0.01, 1.0


class SpeedCheck(PaperLaw):
    def __init__(self, run, platoon):
        super().__init__(run, platoon)
        if NAME not in run.detectors:
            raise SystemExit(
                f"speed_check.py reports detector {NAME!r}: add plugin = [{NAME!r}] to [detection]"
            )
        self.last = {}  # (receiver, sender) -> (step, state) of the last claim it inspected

    def inspect(self, d):
        """The kinematic residual of delivery d against the previous claim of its sender to
        its receiver: {NAME: (flagged, |residual| in m)}, {} with nothing to compare, or None
        for a stale or repeated packet (the packet checks refuse it; not inspected)."""
        p = d.packet
        key = (d.receiver, p.sender)
        before = self.last.get(key)
        if before is not None and p.step <= before[0]:
            return None
        self.last[key] = (p.step, p.state)
        if before is None or not all(math.isfinite(x) for x in p.state):
            return {}
        t = (p.step - before[0]) * self.dt
        (p0, v0, a0), (p1, v1, a1) = before[1], p.state
        # Exact for an acceleration linear in time: p1 = p0 + v0 t + (2 a0 + a1) t^2 / 6, and the
        # same from the other end, averaged.
        ahead = p0 + v0 * t + (2.0 * a0 + a1) * t * t / 6.0
        behind = p1 - v1 * t + (2.0 * a1 + a0) * t * t / 6.0
        residual = abs(p1 - ahead) + abs(p0 - behind)
        return {NAME: (residual > FLOOR_M + JERK * t**3 / 6.0, residual)}

    def receive(self, step, commands):
        for d in step.deliveries:
            if d.receiver == pc.UNKNOWN or d.packet.sender == pc.UNKNOWN:
                continue
            verdicts = self.inspect(d)
            if verdicts is not None:
                step.inspections.append(pc.Inspection(d, verdicts))
        super().receive(step, commands)


if __name__ == "__main__":
    sys.exit(pc.run(SpeedCheck))
