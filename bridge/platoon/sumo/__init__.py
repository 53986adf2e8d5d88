"""SUMO as the plant of a co-simulated run (`platoon run --plant sumo`).

- `platoon.sumo.plant`: the plant process, started by the run as `python -m platoon.sumo` with
  PLATOON_PLANT_SPEC; drives libsumo with the model's accelerations.
- `platoon.sumo.model`: the vehicle model of crates/model (engine lag, tau schedules, leader
  profile) in Python, bit-identical to Rust (tests/sumo.rs checks it).
- `platoon.sumo.native`: the plant's per-vehicle libsumo calls of a step in C++ (`cpp/`), built
  on first use.

They need libsumo and numpy (bridge/requirements.txt), not the package's compiled core.
"""
