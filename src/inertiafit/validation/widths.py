"""What the planner predicts, measured: full simulated studies of a design.

:func:`simulated_widths` simulates studies of a :class:`~inertiafit.planning.design.Design`
as trial files, samples each one's posterior as :func:`~inertiafit.pipeline.study.analyse_study`
does (:func:`~inertiafit.pipeline.study.study_posterior`) and reports
the posterior widths the planner (:func:`~inertiafit.planning.planner.plan`) predicts without
them. ``tests/test_plan.py`` and ``benchmarks/plan.py`` compare the two (docs/validation.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from inertiafit.errors import InputError
from inertiafit.inference.priors import Prior
from inertiafit.planning.design import Design, is_whole, nominal_values

__all__ = ["simulated_widths"]


def simulated_widths(
    bodies: Mapping[str, Any],
    design: Design,
    *,
    priors: Mapping[str, Any] | None = None,
    replicates: int = 4,
    seed: int = 0,
    hdi_prob: float = 0.95,
    folder: str | Path,
    noise: Any = None,
) -> pd.DataFrame:
    """What :func:`plan` predicts, measured: full simulated studies of ``design``.

    ``replicates`` studies are simulated (:func:`~inertiafit.simulate.simulate_study`, trial
    files at 1 kHz with ``noise``, default :meth:`~inertiafit.simulate.Noise.paper`) with the
    nominal values as the truth, and each one's posterior is sampled as
    :func:`~inertiafit.pipeline.study.analyse_study` samples it
    (:func:`~inertiafit.pipeline.study.study_posterior`: the same draws, without the
    baselines and tables nothing here reads). A second mounting is a condition with
    its body moved (``offset``); a weighed body or a balance point is written into the
    manifest with the design's SD, its reading drawn from the truth with that SD (a fresh
    draw per study, as a real scale's would be), where :func:`plan` centres it on the truth.
    Returns a row per body and parameter: the mean over the replicates of the posterior
    ``sd`` and HDI width (``hdi_width``), and the SDs of both over replicates (``sd_sd``,
    ``hdi_width_sd``: the Monte Carlo SE of the means is these over ``sqrt(replicates)``).
    Written under ``folder``. Designs with one quasi-static trial per condition and no
    torque-gain SD only (the simulator writes one quasi-static trial and no calibration).
    """
    from inertiafit.pipeline.study import study_posterior
    from inertiafit.simulate import Noise, simulate_study

    if design.quasi_static_trials != 1:
        raise InputError("simulated_widths: the simulator writes one quasi-static trial")
    if design.torque_gain_sd:
        raise InputError("simulated_widths: torque_gain_sd: the simulator writes no calibration")
    if not (is_whole(replicates) and replicates >= 2):
        raise InputError(f"simulated_widths: replicates: expected >= 2, got {replicates!r}")
    nominal = nominal_values(bodies)
    design.check_bodies(nominal)
    used = [b for b in nominal if any(b in m.bodies for m in design.mountings)]
    specs: dict[str, Any] = {}
    for b in used:
        spec = {**(priors or {}), **design.priors}.get(b)
        if spec is not None:
            if isinstance(spec, Prior):
                raise InputError(f"simulated_widths: prior of '{b}': give a name or a table")
            specs[b] = spec
    measured = design.measured
    rows = []
    for r in range(replicates):
        manifest = simulate_study(
            Path(folder) / f"{design.name}-{r}".replace(" ", "_").replace("/", "_"),
            bodies={
                b: (
                    nominal[b]["mass"],
                    nominal[b]["radius_of_gyration"],
                    nominal[b]["com_distance"],
                )
                for b in used
            },
            conditions=design.mountings,
            speeds=design.speeds,
            trials_per_speed=design.trials_per_speed,
            seed=seed + r,
            noise=Noise.paper() if noise is None else noise,
            priors=specs,
            measured={b: m for b, m in measured.items() if b in used} or None,
        )
        s = study_posterior(manifest, seed=seed + r).summary(hdi_prob)
        s["hdi_width"] = s["hdi_upper"] - s["hdi_lower"]
        s["replicate"] = r
        rows.append(s[["replicate", "body", "parameter", "sd", "hdi_width"]])
    all_rows = pd.concat(rows)
    out = all_rows.groupby(["body", "parameter"], sort=False).agg(
        sd=("sd", "mean"),
        hdi_width=("hdi_width", "mean"),
        sd_sd=("sd", "std"),
        hdi_width_sd=("hdi_width", "std"),
    )
    return out.reset_index()
