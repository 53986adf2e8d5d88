"""The SUMO plant's radar reads what SUMO sees: the nearest vehicle ahead on the lane, whoever it
is. A car that is not part of the platoon, driving between follower 1 and the leader, is what
follower 1's radar reports, flagged INTRUDER (it is not the platoon's predecessor)."""

import contextlib
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))

import platoon.sumo.plant as sumo_plant  # noqa: E402
import platoon.wire as w  # noqa: E402

NET = os.path.join(HERE, "..", "..", "sumo", "highway", "highway.net.xml")


@contextlib.contextmanager
def sumo_with(tmp, cars):
    """libsumo on the committed highway with `cars` (id, lane position, speed) on lane 0, after
    the step that inserts them; closed on leaving."""
    import libsumo

    routes = os.path.join(tmp, "r.rou.xml")
    with open(routes, "w") as f:
        f.write('<routes><vType id="t" length="4" minGap="0" accel="100" decel="100" '
                'sigma="0" tau="1"/><route id="road" edges="highway"/>\n')
        for vid, pos, v in cars:
            f.write(f'<vehicle id="{vid}" type="t" route="road" depart="0" departLane="0" '
                    f'departPos="{pos}" departSpeed="{v}" insertionChecks="none"/>\n')
        f.write("</routes>\n")
    libsumo.start(["sumo", "-n", NET, "-r", routes, "--step-length", "0.01",
                   "--no-step-log", "true", "--no-warnings", "true"])
    try:
        libsumo.simulationStep()
        yield libsumo
    finally:
        libsumo.close()


def run_with(tmp, intruder: bool):
    """Leader at 200 m, follower 1 at 140 m (lane positions), and maybe a car at 164 m."""
    cars = [("leader", 200.0, 20.0), ("follower1", 140.0, 22.0)]
    if intruder:
        cars.append(("intruder", 164.0, 15.0))
    with sumo_with(tmp, cars) as libsumo:
        sumo_plant.NAMES["per_platoon"], sumo_plant.NAMES["platoons"] = 2, 1
        spec = {
            "dt": 0.01,
            "initial": [[100.0, 20.0, 0.0], [40.0, 22.0, 0.0]],
            "vehicles_per_platoon": 2,
            "lanes": [0],
            "radar_range_m": 150.0,
            "sumo": {"offset_m": 100.0},
        }
        kin = sumo_plant.Kinematics(spec, libsumo, "sumo")
        out = kin.read(0, [0.0, 0.0])
        return [(s.flags, s.gap, s.closing) for s in out]


def test_the_radar_sees_a_car_that_is_not_part_of_the_platoon():
    with tempfile.TemporaryDirectory() as tmp:
        (lead_flags, _, _), (flags, gap, closing) = run_with(tmp, intruder=False)
        assert not lead_flags & w.VehicleState.AHEAD  # the leader has no radar
        assert flags & w.VehicleState.AHEAD and not flags & w.VehicleState.INTRUDER
        assert abs(gap - (60.0 - 4.0)) < 0.5 and abs(closing - 2.0) < 0.1  # the leader
        _, (flags, gap, closing) = run_with(tmp, intruder=True)
        assert flags & w.VehicleState.AHEAD and flags & w.VehicleState.INTRUDER  # not its predecessor
        assert abs(gap - (24.0 - 4.0)) < 0.5 and abs(closing - 7.0) < 0.1  # the car
