"""The state-falsification attacks of the built-in channel as an injector of one's own (an
outsider altering the copies of one sender's packets on their links), to copy and vary:

    platoon run my.toml --injector "bridge/.venv/bin/python bridge/examples/falsify.py drift --sender 2 --value 0.5 0 0"

kinds (`--value`, from `--start` seconds on):
  offset           the claimed [p, v, a] plus a constant vector
  random_offset    plus normal noise of std [p, v, a] per copy (seeded: `--seed`)
  drift            plus a vector that grows by `value` per second (a ramp)
  feigned_braking  the claimed acceleration replaced by `value` (m/s^2)
  accel_scale      the claimed acceleration multiplied by `value`

The run measures what it did on the wire (`summary.json` `wire`: `altered`) and, with
`[detection]`, labels every delivered packet against what the controller sent, as for the
built-in channel's attacks: the detectors' figures and `detections.csv` need nothing from the
injector. Replace mode: the config's own `[attack]` and `[[channel.attacks]]` are not applied.
"""

import argparse
import os
import random
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.injector as pi  # noqa: E402

KINDS = ("offset", "random_offset", "drift", "feigned_braking", "accel_scale")


def parse(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=KINDS)
    ap.add_argument("--sender", type=int, required=True, help="the wire id whose packets it alters")
    ap.add_argument("--start", type=float, default=0.0, help="from this time on (s)")
    ap.add_argument("--value", type=float, nargs="+", required=True)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    want = 1 if a.kind in ("feigned_braking", "accel_scale") else 3
    if len(a.value) != want:
        ap.error(f"{a.kind} takes {want} value{'s' if want > 1 else ''}, got {len(a.value)}")
    return a


class Falsify(pi.Injector):
    def __init__(self, args):
        self.a = args
        self.rng = random.Random(args.seed)

    def alter(self, state, t):
        a, x = self.a, self.a.value
        if a.kind == "offset":
            for i in range(3):
                state[i] += x[i]
        elif a.kind == "random_offset":
            for i in range(3):
                state[i] += self.rng.gauss(0.0, x[i])
        elif a.kind == "drift":
            for i in range(3):
                state[i] += x[i] * (t - a.start)
        elif a.kind == "feigned_braking":
            state[2] = x[0]
        else:
            state[2] *= x[0]

    def step(self, step, rx):
        for it in step.tx:
            if it.packet.sender == self.a.sender and step.t >= self.a.start:
                it = type(it).from_buffer_copy(it)  # a copy: the tx sample stays as sent
                self.alter(it.packet.state, step.t)
            rx.append(it)


if __name__ == "__main__":
    args = parse(sys.argv[1:])
    sys.exit(pi.run(lambda run: Falsify(args)))
