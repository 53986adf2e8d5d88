"""A ghost of a real vehicle (a Sybil attack): from START_S to END_S, every packet vehicle
VEHICLE sends is replaced, for its receivers, by one that claims it drives DRIFT m/s faster than
it does and is DRIFT * (t - START_S) m further ahead. The claims are consistent with each other
(a vehicle that speeds up by DRIFT and keeps going), so with DRIFT below what a vehicle can gain
in one step (50 m/s^2 * dt) the controllers' plausibility check lets every forged packet
through: the attack is stealthy, and the receivers open their gaps as the ghost drifts away.
When it vanishes, the real vehicle's next packets look like a jump back and are refused
(`implausible_state`) until a jump that large has become physically possible.

    platoon run configs/table1.toml \\
        --injector "bridge/.venv/bin/python bridge/examples/ghost.py 1 10 30 0.3"
"""

import copy
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.injector as pi  # noqa: E402


class Ghost(pi.Injector):
    def __init__(self, run: pi.Run, vehicle: int, start: float, end: float, drift: float):
        self.run, self.vehicle, self.window, self.drift = run, vehicle, (start, end), drift
        self.forged = 0

    def step(self, step, rx):
        start, end = self.window
        for it in step.tx:
            if start <= step.t < end and self.run.local(it.packet.sender) == self.vehicle:
                it = copy.deepcopy(it)
                it.packet.state[0] += self.drift * (step.t - start)
                it.packet.state[1] += self.drift
                self.forged += 1
            rx.append(it)

    def finish(self):
        print(f"ghost: forged {self.forged} packets", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) != 5:
        print("usage: ghost.py VEHICLE START_S END_S DRIFT_MPS", file=sys.stderr)
        sys.exit(2)
    vehicle, start, end, drift = int(sys.argv[1]), *map(float, sys.argv[2:])
    sys.exit(pi.run(lambda run: Ghost(run, vehicle, start, end, drift)))
