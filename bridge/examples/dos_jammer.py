"""The built-in DoS channel on the Python injector SDK: during an attack interval of the run's
config (`[attack] kind = "intervals"`) nothing is delivered and every vehicle, the leader
included, is told its channel is jammed; otherwise every packet is delivered as sent. With a
config without link attacks, a run with it equals the built-in run byte for byte (tested):

    platoon run configs/paper.toml --injector "bridge/.venv/bin/python bridge/examples/dos_jammer.py"
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.injector as pi  # noqa: E402


class DosJammer(pi.Injector):
    def __init__(self, run: pi.Run):
        attack = run.config.get("attack", {"kind": "none"})
        if attack["kind"] not in ("none", "intervals"):
            raise SystemExit(f"dos_jammer: attack.kind = {attack['kind']!r} is not supported")
        # [a, a + d) per attack, sorted and merged, walked with a cursor as t grows (the same
        # test as the built-in channel's `a <= t < a + d`, without scanning every interval).
        self.intervals = []
        for a, b in sorted((a, a + d) for a, d in attack.get("intervals", [])):
            if self.intervals and a <= self.intervals[-1][1]:
                self.intervals[-1][1] = max(self.intervals[-1][1], b)
            else:
                self.intervals.append([a, b])
        self.next = 0  # the first interval that has not ended
        self.notices = [pi.jammed(v) for v in run.vehicles()]

    def step(self, step, rx):
        t, spans = step.t, self.intervals
        while self.next < len(spans) and t >= spans[self.next][1]:
            self.next += 1
        if self.next < len(spans) and spans[self.next][0] <= t:
            rx.extend(self.notices)
        else:
            rx.extend(step.tx)


if __name__ == "__main__":
    sys.exit(pi.run(DosJammer))
