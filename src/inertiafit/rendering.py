"""Every table, figure and ``report.html`` of a study, drawn from a :class:`StudyResult`.

``inertiafit run`` draws them right after sampling; ``inertiafit report DIR`` rebuilds the
:class:`StudyResult` from ``posterior.nc`` and ``trials.csv`` (:func:`load_study_result`) and
draws them again — with other formats or another HDI probability — without sampling.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd

from inertiafit.errors import InputError
from inertiafit.physics import PARAMETERS
from inertiafit.priors import Prior
from inertiafit.study import TRIAL_COLUMNS, StudyResult

FORMATS = ("pdf", "png", "svg")


def check_formats(formats) -> tuple[str, ...]:
    """Validate figure formats (``pdf``, ``png``, ``svg``)."""
    out = tuple(f.strip().lower() for f in formats if f.strip())
    bad = [f for f in out if f not in FORMATS]
    if bad or not out:
        raise InputError(
            f"--formats: expected a comma-separated subset of {','.join(FORMATS)}, "
            f"got {','.join(formats)!r}"
        )
    return out


def _save(fig, folder: Path, stem: str, formats: tuple[str, ...]) -> None:
    from inertiafit.plots import save_figure

    save_figure(fig, folder / stem, formats, dpi=150)


def figure_makers(result: StudyResult) -> dict[str, Callable[[], Any]]:
    """The study's figures by file stem, each as a function that draws it.

    Drawing one figure at a time, saving and dropping it, keeps one figure in memory rather
    than all of them.
    """
    from inertiafit import plots

    post = result.posterior
    makers: dict[str, Callable[[], Any]] = {}
    for body in post.bodies:
        truths = result.ideals.get(body) or None
        stem = "corner" if result.kind == "fit" else f"corner-{body}"
        makers[stem] = functools.partial(post.corner, body, truths=truths)
        makers[f"identification-{body}"] = functools.partial(
            plots.plot_identification_curve,
            post,
            body,
            baseline=(result.baselines or {}).get(body),
        )
        makers[f"trace-{body}"] = functools.partial(plots.plot_trace, post, body)
        makers[f"rank-{body}"] = functools.partial(plots.plot_rank, post, body)
    if len(post.bodies) > 1:
        makers["corner-joint"] = functools.partial(
            plots.plot_joint_corner, post, truths=result.ideals or None
        )
    for cond, traces in result.traces.items():
        makers[f"fast-trials-{cond}"] = functools.partial(
            plots.plot_fast_trials, traces, title=cond
        )
    fast = result.trials[result.trials["kind"] == "fast"]
    if len(fast):
        makers["inertia-by-speed"] = functools.partial(plots.plot_inertia_by_speed, fast)
    return makers


def study_figures(result: StudyResult) -> dict[str, Any]:
    """The study's figures by file stem (Matplotlib Figures, none shown)."""
    return {stem: make() for stem, make in figure_makers(result).items()}


def write_tables(folder: Path, result: StudyResult, hdi_prob: float) -> None:
    """summary, identification, comparison, speed_effect and trials as CSV (+ .md, .tex)."""
    from inertiafit.tables import (
        comparison_display,
        speed_effect_display,
        summary_display,
        write_table,
    )

    post = result.posterior
    summary = post.summary(hdi_prob)
    write_table(
        summary,
        folder,
        "summary",
        display=summary_display(summary),
        caption=f"Posterior of every body: median and {100 * hdi_prob:g}% HDI.",
    )
    write_table(
        post.identification(),
        folder,
        "identification",
        caption="Posterior SD over prior SD: who decides each parameter.",
    )
    if result.kind == "fit":  # keep fit's comparison.csv (prior nominal, published reference)
        return
    write_table(
        result.comparison,
        folder,
        "comparison",
        display=comparison_display(result.comparison, hdi_prob),
        caption="Ideal bodies, the posterior and the paper's multi-start estimator.",
    )
    if len(result.trials):
        write_table(
            result.speed_effect,
            folder,
            "speed_effect",
            display=speed_effect_display(result.speed_effect),
            caption="Inertia per condition and speed; one-way ANOVA across speeds.",
        )
        result.trials.to_csv(
            folder / "trials.csv", index=False, float_format="%.8g", lineterminator="\n"
        )


def write_study_outputs(
    folder: Path,
    result: StudyResult,
    *,
    hdi_prob: float = 0.95,
    formats: tuple[str, ...] = ("pdf", "png"),
    save_posterior: bool = True,
) -> None:
    """Every output file of ``run`` into ``folder`` (which must exist)."""
    write_tables(folder, result, hdi_prob)
    if save_posterior:
        result.posterior.save(folder / "posterior.nc")
    from inertiafit.report import figure_png

    # One figure at a time: drawn, saved, its PNG kept for report.html, then let go.
    embedded: dict[str, bytes] = {}
    for stem, make in figure_makers(result).items():
        fig = make()
        _save(fig, folder, stem, formats)
        # Embed the PNG just written rather than drawing the figure once more.
        embedded[stem] = (
            (folder / f"{stem}.png").read_bytes() if "png" in formats else figure_png(fig)
        )
        del fig
    write_html(folder / "report.html", result, embedded, hdi_prob)


def write_html(path: Path, result: StudyResult, figures: dict, hdi_prob: float) -> None:
    """The self-contained ``report.html``: tables, embedded figures, diagnostics, provenance."""
    from inertiafit.report import write_report
    from inertiafit.tables import comparison_display, speed_effect_display, summary_display

    post = result.posterior
    a = post.attrs
    diag = (
        f"{a['n_walkers']} walkers, {a['n_steps']} steps ({a['burn']} dropped as burn-in), "
        f"integrated autocorrelation time tau at most {a['tau_max']:.2f} steps, acceptance "
        f"{a['acceptance']:.2f}, sampling {a['sampling_seconds']:.1f} s; "
        + (
            "converged (chain > 50 tau, R-hat <= 1.01, bulk ESS >= 1000 for every quantity)."
            if post.converged
            else "NOT converged: treat the intervals with care."
        )
    )
    summary = post.summary(hdi_prob)
    fig = lambda stem, caption: [(caption, figures[stem])] if stem in figures else []
    sections: list[tuple[str, list]] = [
        (
            "Posterior",
            [
                (
                    f"Median and {100 * hdi_prob:g}% highest-density interval of every body's parameters "
                    "from one joint posterior over all conditions. 'identified by' compares the "
                    "posterior's SD with the prior's: data < 0.3 <= data + prior <= 0.7 < prior."
                ),
                summary_display(summary),
                "pre:" + post.report(hdi_prob),
            ],
        ),
        (
            "Comparison with ideal bodies and the paper's estimator",
            [
                (
                    "ideal: textbook model declared in the manifest; paper's baseline: the multi-start "
                    "least squares of Son et al. Eq. (4), feasible-region mean (a body added to another "
                    "is fitted to the difference of the condition means, as the paper does)."
                ),
                comparison_display(result.comparison, hdi_prob),
            ],
        ),
        (
            "Corner plots",
            [
                *[
                    item
                    for b in post.bodies
                    for item in fig(
                        "corner" if result.kind == "fit" else f"corner-{b}",
                        f"{b}: axes of m, x and rho span the prior box"
                        + ("; lines: ideal body" if b in result.ideals else ""),
                    )
                ],
                *fig("corner-joint", "all bodies together"),
            ],
        ),
        (
            "Identification curves",
            [
                (
                    "Rotation about one axis identifies only m x = M_g/g and I = m (rho^2 + x^2): the "
                    "bodies that fit the data lie on a curve; the prior box decides where on it."
                ),
                *[
                    item
                    for b in post.bodies
                    for item in fig(
                        f"identification-{b}",
                        f"{b}: posterior draws, the curve at the posterior "
                        "medians, the prior box and the paper's per-start solutions",
                    )
                ],
            ],
        ),
    ]
    if len(result.trials):
        sections.append(
            (
                "Trials",
                [
                    *[
                        item
                        for c in result.traces
                        for item in fig(
                            f"fast-trials-{c}",
                            f"{c}: filtered velocity and acceleration of the fast "
                            "trials; shaded: the detected uniform-acceleration window",
                        )
                    ],
                    *fig("inertia-by-speed", "inertia per trial and speed (mean ± SD)"),
                    *(
                        []
                        if result.traces
                        else [
                            (
                                "Trial traces not drawn: the trial files were not "
                                "found when this report was made."
                            )
                        ]
                    ),
                    result.trials,
                ],
            )
        )
        sections.append(
            ("Speed effect", [speed_effect_display(result.speed_effect), result.speed_effect])
        )
    sections.append(
        (
            "Diagnostics",
            [
                diag,
                post.identification(),
                *[
                    item
                    for b in post.bodies
                    for item in fig(f"trace-{b}", f"{b}: walker traces")
                    + fig(f"rank-{b}", f"{b}: rank plots")
                ],
                *(["warn:" + w for w in result.warnings] or ["No trial flags."]),
            ],
        )
    )
    notes = {
        "study": result.name,
        "manifest": result.manifest,
        "seed": a.get("seed"),
        "gravity (m/s^2)": result.gravity,
        "versions": a.get("versions"),
        "sampled coordinates": a.get("sampled_coordinates"),
    }
    write_report(path, title=f"inertiafit: {result.name}", sections=sections, notes=notes)


def priors_from_posterior(post) -> dict[str, Prior]:
    """The prior boxes stored in a posterior's ``constant_data``."""
    cd = post.tree["constant_data"]
    out = {}
    for body in post.bodies:
        vals = {
            key: {p: float(cd[key].sel(body=body, parameter=p)) for p in PARAMETERS}
            for key in ("nominal", "lower", "upper")
        }
        out[body] = Prior(
            name=body, nominal=vals["nominal"], lower=vals["lower"], upper=vals["upper"]
        )
    return out


def load_study_result(folder: str | Path, *, hdi_prob: float = 0.95) -> StudyResult:
    """Rebuild a :class:`StudyResult` from an output folder, without sampling.

    Needs ``posterior.nc``; ``trials.csv`` for the trial tables and figures (a ``fit`` folder
    has none). The fast-trial traces are re-read from the trial files when the manifest
    recorded in the posterior still exists.
    """
    from inertiafit.result import open_posterior

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such output folder")
    post = open_posterior(folder / "posterior.nc")
    inputs = json.loads(post.attrs.get("inputs", "{}") or "{}")
    priors = priors_from_posterior(post)
    gravity = float(post.tree["constant_data"]["gravity"])
    trials_path = folder / "trials.csv"
    if trials_path.is_file():
        trials = pd.read_csv(
            trials_path, dtype={"flags": str, "file": str, "condition": str, "kind": str}
        )
        missing = sorted(set(TRIAL_COLUMNS) - set(trials.columns))
        if missing:
            raise InputError(
                f"{trials_path}: column '{missing[0]}' missing; "
                "not a trials.csv written by inertiafit"
            )
        trials["flags"] = trials["flags"].fillna("").astype(str)
    else:
        trials = pd.DataFrame(columns=TRIAL_COLUMNS)
    conditions = {k: tuple(v) for k, v in inputs.get("conditions", {}).items()}
    baselines = None
    if not conditions:  # a single body fitted from numbers
        body = post.bodies[0]
        conditions = {body: (body,)}
        baselines = _fit_baseline(post, priors[body], inputs, gravity)
    traces: dict[str, list[dict]] = {}
    manifest = inputs.get("manifest", "")
    if manifest and not Path(manifest).is_file():
        # The demo writes its study inside the output folder, under a temporary name.
        moved = folder / "study" / Path(manifest).name
        manifest = str(moved) if moved.is_file() else manifest
    if manifest and Path(manifest).is_file() and len(trials):
        from inertiafit.study import process_study

        try:
            traces = process_study(manifest).traces
        except InputError:
            traces = {}
    return StudyResult(
        name=inputs.get("name", inputs.get("prior", post.bodies[0])),
        posterior=post,
        trials=trials,
        conditions=conditions,
        priors=priors,
        ideals={k: dict(v) for k, v in inputs.get("ideals", {}).items()},
        traces=traces,
        warnings=list(inputs.get("warnings", [])),
        manifest=manifest,
        gravity=gravity,
        hdi_prob=hdi_prob,
        baselines=baselines,
        kind="fit" if baselines is not None else "study",
    )


def _fit_baseline(post, prior: Prior, inputs: dict, gravity: float) -> dict[str, Any]:
    from inertiafit.commands import baseline_for

    try:
        i = float(inputs["inertia"]["center"])
        g = float(inputs["gravity_moment"]["center"])
    except (KeyError, TypeError, ValueError):
        return {}
    if not (math.isfinite(i) and math.isfinite(g)):
        return {}
    try:
        return {post.bodies[0]: baseline_for(prior, i, g, gravity)}
    except InputError:
        return {}


def redraw(
    folder: str | Path, *, formats=("pdf", "png"), hdi_prob: float = 0.95, echo=print
) -> StudyResult:
    """``inertiafit report``: redraw tables, figures and ``report.html`` in place.

    Everything is drawn into a temporary folder first and moved into ``folder`` only when all
    of it succeeded; ``posterior.nc`` and ``trials.csv`` are read, never rewritten.
    """
    import shutil
    import tempfile

    if not 0 < hdi_prob < 1:
        raise InputError(f"--hdi-prob: expected a probability in (0, 1), got {hdi_prob}")
    fmts = check_formats(formats)
    folder = Path(folder)
    result = load_study_result(folder, hdi_prob=hdi_prob)
    with tempfile.TemporaryDirectory(prefix=".report-", dir=folder) as tmp:
        write_study_outputs(
            Path(tmp), result, hdi_prob=hdi_prob, formats=fmts, save_posterior=False
        )
        written = sorted(p.name for p in Path(tmp).iterdir() if p.name != "trials.csv")
        for name in written:
            shutil.move(Path(tmp) / name, folder / name)
    echo(
        f"redrew {len(written)} files in {folder}: report.html and "
        + ", ".join(n for n in written if n != "report.html")
    )
    return result
