"""The Python injector SDK's pieces that need no running co-simulation: the dos_jammer
example's interval walk (sorted, merged, a cursor) decides exactly as the built-in test
`a <= t < a + d` does over every interval, and Step reads the states only when asked."""

import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
sys.path.insert(0, os.path.join(HERE, "..", "examples"))

import dos_jammer  # noqa: E402
import platoon.injector as pi  # noqa: E402


def make_run(intervals, dt=0.01, steps=3000):
    config = {"attack": {"kind": "intervals", "intervals": intervals}}
    return pi.Run(
        run_id="t", config=config, dt=dt, steps=steps, vehicles_per_platoon=3, platoons=1
    )


def test_the_interval_walk_equals_testing_every_interval():
    rng = random.Random(7)
    for _ in range(50):
        # Overlapping, touching, nested and unsorted intervals on purpose, half of them starting
        # and ending on step times (where `<=` and `<` differ).
        intervals = [
            [rng.randrange(3000) * 0.01, rng.randrange(300) * 0.01]
            if rng.random() < 0.5
            else [rng.uniform(0, 30), rng.choice([0.0, 0.01, rng.uniform(0, 5)])]
            for _ in range(6)
        ]
        run = make_run(intervals)
        jammer = dos_jammer.DosJammer(run)
        for k in range(run.steps + 1):
            t = k * run.dt
            rx = []
            jammer.step(pi.Step(k, t, ["packet"], None), rx)
            expected = any(a <= t < a + d for a, d in intervals)
            assert (rx != ["packet"]) == expected, (k, t, intervals)


class Inlet:
    def __init__(self):
        self.taken = []

    def take(self, k):
        self.taken.append(k)
        return None if k == 9 else ["state"]


def test_states_are_taken_on_first_read_only():
    inlet = Inlet()
    step = pi.Step(4, 0.04, [], inlet)
    assert inlet.taken == []
    assert step.states == ["state"] and step.states == ["state"]
    assert inlet.taken == [4]
    try:
        pi.Step(9, 0.09, [], inlet).states
    except RuntimeError as e:
        assert "step 9" in str(e)
    else:
        raise AssertionError("missing states must raise")


def test_the_delivery_log_delivers_and_logs_every_item_with_its_action(tmp_path):
    run = make_run([])
    path = tmp_path / "log.csv"
    log = pi.DeliveryLog(run, str(path))
    step = pi.Step(7, 0.07, [], None)
    item = pi.w.LinkPacket(receiver=4, kind=pi.w.LinkPacket.DELIVERY)
    item.packet.sender, item.packet.seq = 3, 12
    rx = []
    log.deliver(step, rx, item, "forge")
    log.dropped(step, item)
    log.close()
    assert rx == [item]
    # Vehicle indices within the platoon (3 vehicles per platoon: wire id 4 is vehicle 1).
    assert path.read_text() == "step,receiver,sender,seq,action\n7,1,0,12,forge\n7,1,0,12,drop\n"
