"""The SUMO plant: a platoon node that advances SUMO vehicles with the accelerations of the
platoon model, speaking the same iceoryx2 contract as the native plant (`platoon node plant`).

Started by `platoon run --plant sumo` with PLATOON_RUN_ID and PLATOON_PLANT_SPEC (plant.json:
time grid, initial states, leader profile, tau schedules, and the SUMO options). Per step k:
publish the states read from SUMO, wait for commands[k], hold each vehicle's acceleration a[k]
over the step (`setAcceleration`, ballistic update, speed mode 0), step SUMO, check collisions,
and update a[k+1] with the engine lag (platoon_plant.py). Writes SUMO's FCD output and
sumo.json (SUMO version, per-step costs, collisions) into the run directory.
"""

import json
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import platoon_plant  # noqa: E402
import platoon_wire as w  # noqa: E402


class SumoError(Exception):
    """SUMO refused something: the message names SUMO and the step."""


def vehicle_id(i: int) -> str:
    return "leader" if i == 0 else f"follower{i}"


def write_routes(path, spec):
    s = spec["sumo"]
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<routes>",
        f'    <vType id="platoon" length="{s["vehicle_length_m"]!r}" minGap="0" '
        'accel="100" decel="100" emergencyDecel="100" apparentDecel="100" '
        'maxSpeed="100" speedFactor="1" speedDev="0" sigma="0" tau="1"/>',
        f'    <route id="road" edges="{s["edge"]}"/>',
    ]
    for i, (p, v, _) in enumerate(spec["initial"]):
        lines.append(
            f'    <vehicle id="{vehicle_id(i)}" type="platoon" route="road" depart="0" '
            f'departLane="{s["lane"]}" departPos="{p + s["offset_m"]!r}" departSpeed="{v!r}" '
            'insertionChecks="none"/>'
        )
    lines.append("</routes>")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


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
        "--fcd-output", s["fcd"],
        "--fcd-output.acceleration", "true",
        "--no-step-log", "true",
        "--no-warnings", "true",
        "--seed", "0",
    ]
    libsumo.start(args)
    libsumo.simulationStep()  # inserts the vehicles; their state is still the initial one
    n = len(spec["initial"])
    for i in range(n):
        vid = vehicle_id(i)
        libsumo.vehicle.setSpeedMode(vid, 0)
        libsumo.vehicle.setLaneChangeMode(vid, 0)
    return libsumo


def read_states(sumo, n, offset, accel, lane_ids):
    out = []
    for i in range(n):
        vid = vehicle_id(i)
        st = w.VehicleState()
        st.vehicle = i
        st.p = sumo.vehicle.getLanePosition(vid) - offset
        st.v = sumo.vehicle.getSpeed(vid)
        st.a = accel[i]
        out.append(st)
    return out


def run(spec) -> int:
    n = len(spec["initial"])
    steps = int(spec["steps"])
    dt = float(spec["dt"])
    offset = float(spec["sumo"]["offset_m"])
    node = w.Endpoint("plant")
    states_out = node.outlet("states", w.VehicleState, n)
    commands_in = node.inlet("commands", w.Command)
    control = node.control_inlet()
    status = node.status_outlet()

    k = 0
    report = {"sumo_version": None, "steps": 0, "collisions": [], "fcd": spec["sumo"]["fcd"]}
    sumo_ns, bridge_ns = [], []

    def fail(message):
        publisher, wakers = status
        msg = w.ControlMsg()
        msg.kind = w.ControlMsg.FAILED
        msg.node = w.NODES["plant"]
        msg.step = k
        data = message.encode()[:120]
        for j, b in enumerate(data):
            msg.reason[j] = b
        publisher.send_copy(msg)
        for n_ in wakers:
            n_.notify()
        print(f"sumo_plant: {message}", file=sys.stderr)

    try:
        sumo = start_sumo(spec)
        report["sumo_version"] = sumo.getVersion()[1]
        dyn = platoon_plant.Dynamics(spec)
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
        states_out.send(0, 0.0, read_states(sumo, n, offset, dyn.accel, None))
        while True:
            msg = control.receive()
            while msg is not None:
                if msg.payload().contents.kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT):
                    sumo.close()
                    return 0
                msg = control.receive()
            cmds = commands_in.take(k)
            if cmds is None:
                node.wait()
                continue
            t0 = time.perf_counter_ns()
            if len(cmds) != n - 1:
                raise SumoError(f"{len(cmds)} commands for {n - 1} followers")
            u = [0.0] * (n - 1)
            for c in cmds:
                u[c.vehicle - 1] = c.u
            for i in range(n):
                sumo.vehicle.setAcceleration(vehicle_id(i), dyn.accel[i], dt)
            t1 = time.perf_counter_ns()
            sumo.simulationStep()
            t2 = time.perf_counter_ns()
            for c in sumo.simulation.getCollisions():
                report["collisions"].append(
                    {
                        "step": k + 1,
                        "t": (k + 1) * dt,
                        "collider": c.collider,
                        "victim": c.victim,
                        "type": c.type,
                        "position_m": c.pos - offset,
                    }
                )
            dyn.advance(k, u)
            k += 1
            if k > steps:
                report["steps"] = k
                break
            states_out.send(k, k * dt, read_states(sumo, n, offset, dyn.accel, None))
            t3 = time.perf_counter_ns()
            sumo_ns.append(t2 - t1)
            bridge_ns.append((t1 - t0) + (t3 - t2))
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

    report["sumo_step"] = stats(sumo_ns)
    report["bridge_step"] = stats(bridge_ns)
    tmp = spec["sumo"]["report"] + ".partial"
    with open(tmp, "w") as f:
        json.dump(report, f, indent=2)
        f.write("\n")
    os.replace(tmp, spec["sumo"]["report"])
    sumo.close()
    w.send_status(status, w.ControlMsg.DONE, "plant", k - 1)
    while True:
        node.wait()
        msg = control.receive()
        while msg is not None:
            if msg.payload().contents.kind in (w.ControlMsg.STOP, w.ControlMsg.ABORT):
                return 0
            msg = control.receive()


def main() -> int:
    path = os.environ.get("PLATOON_PLANT_SPEC")
    if not path:
        print("sumo_plant: PLATOON_PLANT_SPEC is not set; start me with `platoon run --plant sumo`",
              file=sys.stderr)
        return 2
    with open(path) as f:
        spec = json.load(f)
    return run(spec)


if __name__ == "__main__":
    sys.exit(main())
