"""LMI design checks (Theorems 1 and 2 of the paper): `platoon design` of the command."""

from __future__ import annotations

from . import _config_arg, _native


def check_gain(
    config: dict | str = "paper",
    *,
    gain: tuple[float, float, float] | None = None,
    c: float = 0.0,
    theorem: int = 1,
    time_headway: float | None = None,
) -> dict:
    """Evaluates a gain K on a scenario's topology, as `platoon design check-gain` does, and
    returns its report (check.json) as a dict: closed-loop eigenvalues over the tau range
    (`stable_over_tau_range`, `worst_max_real`), the smallest beta1/beta2 for which LMI (13)
    holds (`min_ratio_at_c`, None where infeasible), string stability, ...

    config: a dict, a TOML file's path or an embedded scenario's name. gain: (K1, K2, K3)
    (None: the config's control.gain). c: the decay parameter. theorem: 1 (the nominal tau)
    or 2 (both ends of the tau range). time_headway: overrides the spacing policy's (s).
    A check cannot be stopped halfway: Ctrl-C returns at once and leaves it to finish.

    Raises ConfigError for an invalid config (file, line, key), PlatoonError for an option no
    check can use (a negative time_headway, a gain that is not three finite numbers) or when
    the SDP solver fails. A gain that (13) does not certify is no error: the report says so."""
    import json

    return json.loads(
        _native().check_gain(
            _config_arg(config),
            {
                "gain": None if gain is None else [float(k) for k in gain],
                "c": float(c),
                "theorem": int(theorem),
                "time_headway": None if time_headway is None else float(time_headway),
            },
        )
    )
