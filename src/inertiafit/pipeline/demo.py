"""``inertiafit demo``: the paper's experiment simulated and run end to end.

The paper's own published numbers are then fitted beside it (``paper-numbers/``), and the
intervals of ``m``, ``x`` and ``rho`` shown shrinking with a weighed mass and a de Leva prior
(``information/``, :mod:`inertiafit.pipeline.information`). It ends with a living forearm
(``living/``, :func:`run_living_demo`): the rigid model's bias beside the living model's
interval.
"""

from __future__ import annotations

import dataclasses
import sys
import tomllib
from collections.abc import Callable
from pathlib import Path

from inertiafit import paper
from inertiafit._checks import check_probability, check_seed
from inertiafit.io.outputs import check_out, guard_outputs, output_folder
from inertiafit.physics import REPORTED
from inertiafit.pipeline.fit import run_fit
from inertiafit.pipeline.information import run_information_demo
from inertiafit.pipeline.study import analyse_study
from inertiafit.report.outputs import figure_workers, write_outputs
from inertiafit.report.text import study_comparison_text, truth_comparison_text
from inertiafit.simulate import paper_study, rigid_view, simulate_living_study

__all__ = [
    "DEMO_IDEALS",
    "DEMO_INDEX",
    "paper_cases",
    "run_demo",
    "run_living_demo",
    "run_paper_demo",
    "simulated_truths",
    "write_demo_index",
]

#: The demo's results that ``index.html`` links, in its order: (path in the output folder,
#: title, the one line saying what it shows). A CSV is also shown as a table on the page.
DEMO_INDEX: tuple[tuple[str, str, str], ...] = (
    (
        "report.html",
        "Rigid study: the paper's experiment simulated",
        (
            "62 simulated trials of the Biodex elbow attachment alone and with a 3 kg disk: the "
            "joint posterior of both bodies beside the simulation's truth, the ideal bodies and "
            "the paper's multi-start estimator."
        ),
    ),
    (
        "paper-numbers/attachment/report.html",
        "Paper numbers: the attachment",
        (
            "Son et al.'s published attachment (Table 2: I = 0.216 ± 0.017 kg m², 30 trials) "
            "fitted from its numbers alone."
        ),
    ),
    (
        "paper-numbers/disk/report.html",
        "Paper numbers: the 3 kg disk",
        (
            "Son et al.'s published disk (Table 3, its inertia by subtraction) fitted from its "
            "numbers alone."
        ),
    ),
    (
        "information/information.csv",
        "Information: a weighed mass and a de Leva prior",
        (
            "How many times narrower the intervals of m, x and rho get when the disk is weighed, "
            "and for a simulated forearm + hand with a de Leva (1996) prior and the attachment "
            "weighed."
        ),
    ),
    (
        "living/report.html",
        "Living forearm: the living model's report",
        (
            "A simulated forearm on a living elbow (passive moments, damping, two postures) "
            "analysed with its joint: the full report."
        ),
    ),
    (
        "living/living.csv",
        "Living forearm: rigid model against living model",
        (
            "The forearm's I and M_g from today's rigid model (one posture, one sweep) and from "
            "the living model, against the simulation's truth: each one's error and whether its "
            "interval covers the truth."
        ),
    ),
)


def simulated_truths(study_dir: Path) -> dict[str, dict[str, float]]:
    """The true values of every body of a simulated study (its ``truth.toml``), SI units."""
    truth = tomllib.loads((study_dir / "truth.toml").read_text(encoding="utf-8"))
    return {
        body: {k: float(values[k]) for k in REPORTED if k in values}
        for body, values in truth["bodies"].items()
    }


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


@guard_outputs
def run_demo(
    *,
    out: str | Path = "demo-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] = print,
    progress: Callable[[str], None] | None = None,
) -> None:
    """The paper's experiment simulated and run end to end, then its published numbers fitted.

    ``out/study/`` holds the simulated trial files, ``study.toml`` and ``truth.toml``; ``out/``
    the outputs of ``inertiafit run``; ``out/paper-numbers/`` the fits of the numbers the paper
    reports (:func:`run_paper_demo`).
    """
    check_seed(seed)
    check_probability(hdi_prob, "hdi_prob")
    say = progress or (lambda msg: print(msg, file=sys.stderr))
    out = Path(out)
    check_out(out)
    with output_folder(out) as folder:
        say("simulating the paper's experiment: 62 trials at 1 kHz")
        manifest = paper_study(folder / "study", seed=seed)
        with manifest.open("a", encoding="utf-8") as fh:
            fh.write(DEMO_IDEALS)
        # the figure workers ready matplotlib while the study is analysed
        with figure_workers() as pool:
            result = analyse_study(manifest, seed=seed, hdi_prob=hdi_prob, echo=say)
            result = dataclasses.replace(result, truths=simulated_truths(manifest.parent))
            say(f"writing {out}")
            write_outputs(folder, result, pool=pool)
        echo("=" * 100)
        echo(f"{result.name}: joint posterior of both bodies")
        echo("=" * 100)
        echo(result.posterior.report(hdi_prob))
        echo("")
        echo("The simulation's truth and the posterior:")
        echo(truth_comparison_text(result))
        echo("")
        echo("The ideal (textbook) bodies, the posterior and the paper's estimator:")
        echo(study_comparison_text(result))
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
        echo("=" * 100)
        echo("Beyond the paper: a weighed mass and an anthropometric prior")
        echo("=" * 100)
        run_information_demo(
            folder / "information", manifest, seed=seed, hdi_prob=hdi_prob, echo=echo, say=say
        )
        echo("")
        echo("=" * 100)
        echo("Beyond the paper: a living forearm (passive joint moments, damping, two postures)")
        echo("=" * 100)
        run_living_demo(folder / "living", seed=seed, hdi_prob=hdi_prob, echo=echo, say=say)
        echo("")
        write_demo_index(folder)
    echo(
        f"wrote {out}/: index.html (every result below, linked), report.html, methods.md, references.bib, summary, comparison, "
        "speed_effect and trials tables (.csv/.md/.tex), posterior.nc, figures; study/ "
        "(simulated trials, truth.toml); paper-numbers/ (report.html each); "
        "information/ (information.csv, forearm-study/); living/ (a living forearm's run, "
        "living.csv)"
    )


def write_demo_index(folder: Path) -> Path:
    """``folder/index.html``: every result of :data:`DEMO_INDEX` the demo wrote, linked.

    Each link is relative to ``folder`` and comes with its line; a CSV is shown as a table
    too. A result that is not there (a demo stopped early) is left out, so that every link
    on the page opens a file. Returns the page's path.
    """
    import html

    import pandas as pd

    items = []
    for path, title, line in DEMO_INDEX:
        target = folder / path
        if not target.is_file():
            continue
        item = (
            f"<li><a href='{html.escape(path, quote=True)}'>{html.escape(title)}</a> "
            f"<code>{html.escape(path)}</code><br>{html.escape(line)}"
        )
        if target.suffix == ".csv":
            table = pd.read_csv(target)
            item += table.to_html(index=False, float_format=lambda v: f"{v:.4g}", border=0)
        items.append(item + "</li>")
    page = (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        "<title>inertiafit demo</title><style>"
        "body{font-family:system-ui,sans-serif;max-width:60rem;margin:2rem auto;"
        "padding:0 1rem;line-height:1.4}li{margin-bottom:1.2rem}"
        "table{border-collapse:collapse;font-size:0.85rem;margin-top:0.4rem;display:block;"
        "overflow-x:auto}th,td{padding:0.15rem 0.5rem;text-align:right}"
        "th{border-bottom:1px solid #888}</style></head><body>"
        "<h1>inertiafit demo</h1><p>What <code>inertiafit demo</code> wrote, one result a "
        "line; the simulated trial files are in <code>study/</code>.</p>"
        f"<ul>{''.join(items)}</ul></body></html>\n"
    )
    index = folder / "index.html"
    index.write_text(page, encoding="utf-8")
    return index


def run_living_demo(
    out: Path,
    *,
    seed: int,
    hdi_prob: float,
    echo: Callable[[str], None],
    say: Callable[[str], None],
) -> None:
    """A simulated living forearm analysed as living, and as today's rigid model would.

    ``out/study/`` holds the simulated study (two postures, sweeps both ways, rest trials;
    ``truth.toml``) and ``rigid.toml`` (:func:`~inertiafit.simulate.rigid_view`); ``out/``
    the outputs of ``inertiafit run`` on the living study; ``out/living.csv`` the forearm's
    ``I`` and ``M_g``: truth, the rigid model's median and HDI and its error, the living
    model's.
    """
    import warnings

    import pandas as pd

    from inertiafit.errors import ConvergenceWarning, InputError
    from inertiafit.io.outputs import write_csv
    from inertiafit.physics import gravity_moment, inertia

    out.mkdir()
    say("simulating a living forearm: two postures, sweeps both ways, rest trials")
    manifest = simulate_living_study(out / "study", seed=seed, postures="two")
    living = analyse_study(manifest, seed=seed, hdi_prob=hdi_prob, echo=say)
    rigid = None
    with warnings.catch_warnings():
        # the rigid model on a living limb may not converge either: that is its failure
        warnings.simplefilter("ignore", ConvergenceWarning)
        try:
            rigid = analyse_study(rigid_view(manifest), seed=seed, hdi_prob=hdi_prob, echo=say)
        except InputError as exc:  # its gravity model too poor to subtract: refused
            refused = str(exc)
    write_outputs(out, dataclasses.replace(living, truths=simulated_truths(manifest.parent)))
    truth = tomllib.loads((manifest.parent / "truth.toml").read_text(encoding="utf-8"))
    body = truth["bodies"]["forearm"]
    m, rho, x = body["mass"], body["radius_of_gyration"], body["com_distance"]
    true = {"inertia": inertia(m, rho, x), "gravity_moment": gravity_moment(m, x, 9.81)}
    rows = []
    for name, result in (("rigid", rigid), ("living", living)):
        if result is None:
            continue
        summary = result.posterior.summary(hdi_prob).set_index(["body", "parameter"])
        for q, value in true.items():
            median, lo, hi = (
                float(summary.loc[("forearm", q), c]) for c in ("median", "hdi_lower", "hdi_upper")
            )
            rows.append(
                {
                    "model": name,
                    "quantity": q,
                    "truth": float(value),
                    "median": median,
                    "hdi_lower": lo,
                    "hdi_upper": hi,
                    "error": (median - value) / value,
                    "covers": bool(lo <= value <= hi),
                }
            )
    table = pd.DataFrame(rows)
    write_csv(table, out / "living.csv")
    pinned = living.living["passive_parameters"].set_index("parameter")["pinned_by"]
    echo("forearm on a living elbow: the rigid model (one posture, one sweep) and the living one")
    if rigid is None:
        echo(f"  the rigid analysis refuses these files: {refused}")
    for r in rows:
        echo(
            f"  {r['model']:>6} {r['quantity']:<15} {r['median']:.4g} "
            f"[{r['hdi_lower']:.4g}, {r['hdi_upper']:.4g}]  truth {r['truth']:.4g}  "
            f"error {100 * r['error']:+.1f} %  {'covers' if r['covers'] else 'MISSES'}"
        )
    echo(f"  the living M_g is decided by: {pinned.iloc[-1]}")


def run_paper_demo(
    *,
    out: str | Path = "demo-output",
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] = print,
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
