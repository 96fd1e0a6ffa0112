"""What the commands do, callable from Python: fit one body, run the paper's demo."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from inertiafit.physics import GRAVITY, PARAMETERS, UNITS
from inertiafit.priors import Prior, load_prior

#: Optimiser of the paper's baseline in the command line. SLSQP, started from the paper's
#: 101 scaled nominals, reproduces its Table 2 attachment answer (2.80 kg, 0.270 m, 0.065 m
#: against the printed 2.81, 0.269, 0.065) and takes ~40 ms; trust-constr (the closest
#: analogue of fmincon's default interior-point) stops mid-curve at 3.21 kg and takes ~3 s
#: (docs/baseline.md).
BASELINE_METHOD = "SLSQP"


def baseline_for(prior: Prior, inertia: float, gravity_moment: float, gravity: float):
    """The paper's multi-start least-squares answer (feasible-region mean) for these numbers."""
    from inertiafit.baseline import paper_baseline

    return paper_baseline(
        inertia=inertia,
        gravity_moment=gravity_moment,
        nominal=[prior.nominal[p] for p in PARAMETERS],
        lower=[prior.lower[p] for p in PARAMETERS],
        upper=[prior.upper[p] for p in PARAMETERS],
        gravity=gravity,
        method=BASELINE_METHOD,
    )


def comparison(post, prior: Prior, body: str, baseline, hdi_prob: float) -> pd.DataFrame:
    """Side by side per parameter: prior nominal, posterior median and HDI, baseline, reference."""
    s = post.summary(hdi_prob)
    s = s[s.body == body].set_index("parameter")
    base = baseline.estimate if baseline is not None else {}
    nominal = dict(prior.nominal)
    nominal["inertia"] = prior.nominal["mass"] * (
        prior.nominal["radius_of_gyration"] ** 2 + prior.nominal["com_distance"] ** 2
    )
    nominal["gravity_moment"] = prior.nominal["mass"] * GRAVITY * prior.nominal["com_distance"]
    ref = dict(prior.reference)
    if "gravity_moment" not in ref and {"mass", "com_distance"} <= set(ref):
        ref["gravity_moment"] = ref["mass"] * GRAVITY * ref["com_distance"]
    rows = []
    for p in s.index:
        rows.append(
            {
                "parameter": p,
                "unit": UNITS[p],
                "prior_nominal": nominal[p],
                "posterior_median": s.loc[p, "median"],
                "hdi_lower": s.loc[p, "hdi_lower"],
                "hdi_upper": s.loc[p, "hdi_upper"],
                "baseline": base.get(p, math.nan),
                "reference": ref.get(p, math.nan),
            }
        )
    return pd.DataFrame(rows)


def format_comparison(table: pd.DataFrame, prior: Prior, hdi_prob: float) -> str:
    """Readable text of :func:`comparison`."""
    ref_label = prior.reference.get("label", "reference")
    pct = f"{100 * hdi_prob:g}% HDI"
    lines = [
        (
            f"{'parameter':<28}{'prior nominal':>14}{'posterior median':>18}  {pct:<22}"
            f"{'paper baseline':>15}  {ref_label}"
        )
    ]
    for _, r in table.iterrows():
        name = f"{r.parameter} [{r.unit}]"
        interval = f"[{r.hdi_lower:.4g}, {r.hdi_upper:.4g}]"
        ref = "" if np.isnan(r.reference) else f"{r.reference:.4g}"
        lines.append(
            f"{name:<28}{r.prior_nominal:>14.4g}{r.posterior_median:>18.4g}  {interval:<22}"
            f"{r.baseline:>15.4g}  {ref}"
        )
    return "\n".join(lines)


def write_fit_outputs(folder: Path, post, prior: Prior, baseline, hdi_prob: float) -> pd.DataFrame:
    """summary.csv, identification.csv, comparison.csv, posterior.nc, corner.pdf/.png."""
    post.write_summary(folder / "summary.csv", hdi_prob)
    post.identification().to_csv(
        folder / "identification.csv", index=False, float_format="%.8g", lineterminator="\n"
    )
    table = comparison(post, prior, post.bodies[0], baseline, hdi_prob)
    table.to_csv(folder / "comparison.csv", index=False, float_format="%.8g", lineterminator="\n")
    post.save(folder / "posterior.nc")
    fig = post.corner()
    fig.savefig(folder / "corner.pdf")
    fig.savefig(folder / "corner.png", dpi=150)
    return table


def run_fit(
    *,
    prior: str | Path | Prior,
    inertia,
    gravity_moment,
    inertia_se=None,
    inertia_sd=None,
    inertia_n=None,
    gravity_moment_se=None,
    gravity_moment_sd=None,
    gravity_moment_n=None,
    gravity: float = GRAVITY,
    out: str | Path = "inertiafit-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo=print,
    shown_as: str | Path | None = None,
):
    """``inertiafit fit``: posterior of one body, written to ``out`` and printed.

    ``shown_as`` is the folder named in the closing line when ``out`` is a temporary folder
    that will be renamed (the demo).
    """
    from inertiafit.inference import fit_body
    from inertiafit.outputs import output_folder

    prior_obj = load_prior(prior)
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
        seed=seed,
    )
    post.summary(hdi_prob)  # validate hdi_prob before writing anything
    i_obs = float(np.mean(inertia))
    g_obs = float(np.mean(gravity_moment))
    baseline = baseline_for(prior_obj, i_obs, g_obs, gravity)
    with output_folder(out) as folder:
        table = write_fit_outputs(folder, post, prior_obj, baseline, hdi_prob)
    echo(prior_obj.describe())
    echo("")
    echo(post.report(hdi_prob))
    echo("")
    echo(format_comparison(table, prior_obj, hdi_prob))
    echo(
        f"\nwrote {Path(shown_as or out)}/: summary.csv identification.csv comparison.csv posterior.nc "
        "corner.pdf corner.png"
    )
    return post


def paper_cases() -> list[dict]:
    """The paper's two bodies as reported (Son et al., section 3.1, Tables 2 and 3).

    Attachment: ``I = 0.216 +- 0.017`` kg m^2 over 30 trials (10 per speed; the three speeds
    agree), ``M_g`` = the gravity moment of Table 2's estimate, ``2.81 * 9.81 * 0.269`` N m.
    Disk: ``I_w = 0.594`` kg m^2 as printed (the paper's subtraction of its own means would give
    0.607), its standard error from the two conditions' pooled SDs over 30 trials each; ``M_g =
    2.90 * 9.81 * 0.45`` N m (Table 3). The paper gives no standard error for ``M_g``: 0.05 N m
    (under 1 %) is assumed, about what a quasi-static fit over 90 s of 1 kHz data achieves once
    its correlated residuals are accounted for.
    """
    from inertiafit import paper

    se_disk = paper.weight_inertia_standard_error()
    return [
        {
            "title": "Son et al.: Biodex elbow attachment (Table 2), I = 0.216 +- 0.017 kg m^2, "
            "30 trials",
            "folder": "attachment",
            "prior": "biodex-elbow-attachment",
            "inertia": [0.216],
            "inertia_sd": 0.017,
            "inertia_n": 30,
            "gravity_moment": [paper.implied_gravity_moment(paper.TABLE2_ESTIMATED)],
            "gravity_moment_se": 0.05,
        },
        {
            "title": f"Son et al.: 3 kg disk (Table 3), I_w = {paper.WEIGHT_INERTIA} +- "
            f"{se_disk:.4f} kg m^2 (by subtraction)",
            "folder": "disk",
            "prior": "disk-3kg",
            "inertia": [paper.WEIGHT_INERTIA],
            "inertia_se": se_disk,
            "gravity_moment": [paper.implied_gravity_moment(paper.TABLE3_ESTIMATED)],
            "gravity_moment_se": 0.05,
        },
    ]


#: Ideal models the demo declares for the paper's bodies (Son et al., Tables 1-3).
DEMO_IDEALS = """
[bodies.attachment.ideal]
shape = "square-tube"
outer = 0.03
inner = 0.026
length = 0.45
mass = 2.91
com_distance = 0.225

[bodies.weight.ideal]
shape = "solid-disk"
radius = 0.05
thickness = 0.06
mass = 2.92
com_distance = 0.45
axis = "along"
"""


def run_demo(
    *,
    out: str | Path = "demo-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo=print,
    progress=None,
) -> None:
    """The paper's experiment simulated and run end to end, then its published numbers fitted.

    ``out/study/`` holds the simulated trial files, ``study.toml`` and ``truth.toml``; ``out/``
    the outputs of ``inertiafit run``; ``out/paper-numbers/`` the fits of the numbers the paper
    reports (:func:`run_paper_demo`).
    """
    import sys

    from inertiafit.outputs import output_folder
    from inertiafit.rendering import write_study_outputs
    from inertiafit.simulate import paper_study
    from inertiafit.study import analyse_study

    say = progress or (lambda msg: print(msg, file=sys.stderr))
    out = Path(out)
    with output_folder(out) as folder:
        say("simulating the paper's experiment: 62 trials at 1 kHz")
        manifest = paper_study(folder / "study", seed=seed)
        with manifest.open("a", encoding="utf-8") as fh:
            fh.write(DEMO_IDEALS)
        result = analyse_study(manifest, seed=seed, hdi_prob=hdi_prob, echo=say)
        say(f"writing {out}")
        write_study_outputs(folder, result, hdi_prob=hdi_prob)
        echo("=" * 100)
        echo(f"{result.name}: joint posterior of both bodies")
        echo("=" * 100)
        echo(result.posterior.report(hdi_prob))
        echo("")
        cols = [
            "body",
            "parameter",
            "ideal",
            "posterior_median",
            "hdi_lower",
            "hdi_upper",
            "baseline",
            "ideal_in_hdi",
            "identified_by",
        ]
        echo(result.comparison[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        echo("(ideal: textbook body; baseline: the paper's multi-start least squares)")
        for w in result.warnings:
            echo(f"warning: {w}")
        echo("")
        run_paper_demo(
            out=folder / "paper-numbers",
            seed=seed,
            hdi_prob=hdi_prob,
            echo=echo,
            shown_as=out / "paper-numbers",
        )
    echo(
        f"wrote {out}/: report.html, summary, comparison, speed_effect and trials tables "
        "(.csv/.md/.tex), posterior.nc, figures; study/ (simulated trials); paper-numbers/"
    )


def run_paper_demo(
    *,
    out: str | Path = "demo-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo=print,
    shown_as: str | Path | None = None,
) -> None:
    """The paper's two bodies from its reported numbers (Son et al., section 3 and Tables 2-3)."""
    out = Path(out)
    shown = Path(shown_as or out)
    for case in paper_cases():
        echo("=" * 100)
        echo(case["title"])
        echo("=" * 100)
        run_fit(
            prior=case["prior"],
            inertia=case["inertia"],
            inertia_se=case.get("inertia_se"),
            inertia_sd=case.get("inertia_sd"),
            inertia_n=case.get("inertia_n"),
            gravity_moment=case["gravity_moment"],
            gravity_moment_se=case["gravity_moment_se"],
            out=out / case["folder"],
            seed=seed,
            hdi_prob=hdi_prob,
            echo=echo,
            shown_as=shown / case["folder"],
        )
        echo("")
