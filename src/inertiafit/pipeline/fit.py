"""One body from reported numbers: ``inertiafit fit`` and the result it draws from."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from inertiafit._checks import check_gravity, check_probability, check_seed
from inertiafit.baseline import BaselineResult, paper_baseline
from inertiafit.errors import InputError, PriorDataConflictWarning
from inertiafit.inference.fit import fit_body
from inertiafit.inference.priors import Prior, load_prior
from inertiafit.io.outputs import check_out, guard_outputs, output_folder
from inertiafit.measured import Measurement
from inertiafit.physics import GRAVITY
from inertiafit.plotting.style import DEFAULT_FORMATS, check_formats
from inertiafit.posterior import Posterior
from inertiafit.report.outputs import figure_workers, write_outputs
from inertiafit.report.result import Result, make_result
from inertiafit.report.text import fit_comparison_text

__all__ = ["fit_result", "prior_baseline", "run_fit"]


def prior_baseline(
    prior: Prior, inertia: float, gravity_moment: float, gravity: float
) -> dict[str, BaselineResult]:
    """The paper's multi-start answer for one body's numbers inside its prior box, by name.

    :func:`~inertiafit.baseline.paper_baseline` with its default method.
    """
    return {
        prior.name: paper_baseline(
            inertia=inertia,
            gravity_moment=gravity_moment,
            nominal=prior.nominal,
            lower=prior.lower,
            upper=prior.upper,
            gravity=gravity,
        )
    }


def fit_result(
    post: Posterior,
    prior: Prior,
    *,
    inertia: float,
    gravity_moment: float,
    gravity: float,
    hdi_prob: float,
    require_baseline: bool = True,
) -> Result:
    """The :class:`~inertiafit.report.result.Result` of one body fitted from numbers.

    The paper's estimator is computed at the evidence's centres ``inertia`` and
    ``gravity_moment``. When the estimator fails (:class:`~inertiafit.errors.InputError`) the error propagates,
    or, with ``require_baseline=False`` (redrawing a saved fit), the result has no baseline.
    """
    try:
        baselines = prior_baseline(prior, inertia, gravity_moment, gravity)
    except InputError:
        if require_baseline:
            raise
        baselines = {}
    return make_result(
        name=prior.name,
        posterior=post,
        priors={prior.name: prior},
        gravity=gravity,
        hdi_prob=hdi_prob,
        baselines=baselines,
    )


@guard_outputs
def run_fit(
    *,
    prior: str | Path | Prior,
    inertia: float | Sequence[float],
    gravity_moment: float | Sequence[float],
    inertia_se: float | None = None,
    inertia_sd: float | None = None,
    inertia_n: int | None = None,
    gravity_moment_se: float | None = None,
    gravity_moment_sd: float | None = None,
    gravity_moment_n: int | None = None,
    gravity: float = GRAVITY,
    torque_gain_sd: float = 0.0,
    out: str | Path = "inertiafit-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] = print,
    shown_as: str | Path | None = None,
    mass: float | None = None,
    mass_sd: float | None = None,
    com_distance: float | None = None,
    com_distance_sd: float | None = None,
    formats: tuple[str, ...] | list[str] = DEFAULT_FORMATS,
    measured: Sequence[Measurement] = (),
) -> Posterior:
    """``inertiafit fit``: posterior of one body, written to ``out`` and printed.

    ``shown_as`` is the folder named in the closing line when ``out`` is a temporary folder
    that will be renamed (the demo). ``measured`` (direct measurements of the body,
    :class:`~inertiafit.measured.Measurement`), or the pairs ``mass``/``mass_sd`` (a weighing,
    kg) and ``com_distance``/``com_distance_sd`` (a balance point, m), are passed to
    :func:`~inertiafit.inference.fit.fit_body`. ``out`` is checked first
    (:func:`~inertiafit.io.outputs.check_out`). ``out`` receives the same set of outputs as
    ``inertiafit run`` (:func:`~inertiafit.report.outputs.write_outputs`: tables, figures in
    ``formats``, ``methods.md``, ``references.bib``, ``report.html``), less the trial tables.
    """
    check_seed(seed)
    fmts = check_formats(formats)
    check_probability(hdi_prob, "hdi_prob")
    check_gravity(gravity)
    check_out(out, inputs=[prior.path if isinstance(prior, Prior) else prior])
    prior_obj = load_prior(prior)
    # The figure workers start now and ready matplotlib while the posterior is sampled.
    with figure_workers() as pool, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PriorDataConflictWarning)  # said below, as `run` does
        post = fit_body(
            prior_obj,
            inertia=inertia,
            gravity_moment=gravity_moment,
            inertia_se=inertia_se,
            inertia_sd=inertia_sd,
            inertia_n=inertia_n,
            gravity_moment_se=gravity_moment_se,
            gravity_moment_sd=gravity_moment_sd,
            gravity_moment_n=gravity_moment_n,
            gravity=gravity,
            torque_gain_sd=torque_gain_sd,
            seed=seed,
            mass=mass,
            mass_sd=mass_sd,
            com_distance=com_distance,
            com_distance_sd=com_distance_sd,
            measured=measured,
        )
        result = fit_result(
            post,
            prior_obj,
            inertia=float(np.mean(inertia)),
            gravity_moment=float(np.mean(gravity_moment)),
            gravity=gravity,
            hdi_prob=hdi_prob,
        )
        with output_folder(out) as folder:
            written = write_outputs(folder, result, formats=fmts, pool=pool)
    echo(prior_obj.describe())
    echo("")
    echo(post.report(hdi_prob))
    echo("")
    echo(fit_comparison_text(result))
    for w in caught:
        if issubclass(w.category, PriorDataConflictWarning):
            echo(f"warning: {w.message}")
        else:  # anything else as it came, under the caller's filters
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    tables = sorted({n.rsplit(".", 1)[0] for n in written if n.endswith(".md")} - {"methods"})
    figures = sorted({n.rsplit(".", 1)[0] for n in written if n.rsplit(".", 1)[-1] in fmts})
    echo(
        f"\nwrote {Path(shown_as or out)}/: report.html, methods.md, references.bib, "
        f"posterior.nc; tables {', '.join(tables)} (.csv/.md/.tex); figures "
        f"{', '.join(figures)} ({', '.join(fmts)})"
    )
    return post
