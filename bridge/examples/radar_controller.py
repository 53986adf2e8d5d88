"""A controller service you can copy, on the raw protocol (no SDK): every follower runs a
constant-spacing ACC on its radar (the plant's view of the vehicle ahead in each VehicleState)
and nobody broadcasts. It is a complete iceoryx2 node of a platoon run:

    platoon run configs/table1.toml --controller "bridge/.venv/bin/python bridge/examples/radar_controller.py"

Per step k it waits for states[k], publishes tx[k] (empty: no broadcasts), waits for rx[k]
(ignored: it hears nobody), publishes commands[k] (one per follower, in order), and after the
last step reports DONE, as docs/controller-contract.md asks.

To test how a run treats a faulty controller, `--crash-at K` exits with status 1 at step K,
`--hang-at K` stops answering at step K (sleeps), `--spam-at K` publishes commands[K] again and
again and never tx[K + 1], `--wrong-ids-at K` sends the commands of step K for the wrong
vehicles, `--nan-at K` sends a NaN command at step K and `--bad-mode-at K` a command whose
mode code names no mode (12).
"""

import argparse
import os
import sys
import time
import tomllib

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import platoon.wire as w  # noqa: E402

KP, KV = 0.45, 1.2  # u = KP (gap - desired) - KV closing


def stopped(control) -> bool:
    msg = control.receive()
    while msg is not None:
        if msg.payload().contents.kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT):
            return True
        msg = control.receive()
    return False


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for fault in ("crash", "hang", "spam", "wrong-ids", "nan", "bad-mode"):
        ap.add_argument(f"--{fault}-at", type=int, default=None, metavar="K")
    args = ap.parse_args()

    with open(os.environ["PLATOON_CONFIG"], "rb") as f:
        config = tomllib.load(f)
    dt = config["simulation"]["dt_s"]
    last = round(config["simulation"]["duration_s"] / dt)
    n1 = config["platoon"]["followers"] + 1
    platoons = config.get("fleet", {}).get("platoons", 1)
    desired = config["platoon"]["spacing_m"] - config["platoon"].get("vehicle_length_m", 0.0)
    followers = [j * n1 + i for j in range(platoons) for i in range(1, n1)]

    node = w.Endpoint("controller")
    states_in = node.inlet("states", w.VehicleState)
    rx_in = node.inlet("rx", w.LinkPacket)
    tx_out = node.outlet("tx", w.LinkPacket, 1, grow=False)
    cmd_out = node.outlet("commands", w.Command, len(followers), grow=False)
    control = node.control_inlet()
    status = node.status_outlet()  # kept for the whole run
    w.send_status(status, w.ControlMsg.READY, "controller")

    k, states = 0, None
    while True:
        if states is None:
            if k == args.crash_at:
                print(f"radar_controller: crashing at step {k}", file=sys.stderr)
                return 1
            if k == args.hang_at:
                print(f"radar_controller: hanging at step {k}", file=sys.stderr, flush=True)
                while True:
                    time.sleep(1)
            states = states_in.take(k)
            if states is not None:
                tx_out.send(k, k * dt, [])
        if states is not None:
            rx = rx_in.take(k)
            if rx is not None:
                commands = []
                for g in followers:
                    s = states[g]
                    u = KP * (s.gap - desired) - KV * s.closing if s.flags & s.AHEAD else 0.0
                    commands.append(w.Command(vehicle=g, u=max(-6.0, min(2.0, u))))
                if k == args.wrong_ids_at:
                    for c in commands:
                        c.vehicle -= 1  # the first one lands on the leader
                if k == args.nan_at:
                    commands[0].u = float("nan")
                if k == args.bad_mode_at:
                    commands[0].flags |= 12 << w.Command.MODE_SHIFT
                cmd_out.send(k, k * dt, commands)
                if k == args.spam_at:
                    while not stopped(control):  # commands[K] forever, until STOP or ABORT
                        cmd_out.send(k, k * dt, commands)
                        time.sleep(0.005)
                    return 0
                states = None
                if k == last:
                    w.send_status(status, w.ControlMsg.DONE, "controller", k)
                    while not stopped(control):
                        node.wait()
                    return 0
                k += 1
                continue
        if stopped(control):
            return 0
        node.wait()


if __name__ == "__main__":
    sys.exit(main())
