"""report.html leads with the answer (issue 34, item 3): the intervals figure first, a table of
contents linking every section, the per-trial tables folded after the Methods.

Reads conftest's `inertiafit fit` of the paper's disk (``disk_fit``) and its `inertiafit run`
of a two-body study (``study_out``); nothing is sampled here.
"""

from __future__ import annotations

import html
import re

import numpy as np
import pandas as pd
import pytest
from matplotlib.colors import to_rgb

from inertiafit.physics import PARAMETERS, REPORTED
from inertiafit.posterior import open_posterior
from inertiafit.report import plots
from inertiafit.report.figures import FIGURE_SECTIONS, figure_records
from inertiafit.report.html import anchors
from inertiafit.report.plots.intervals import PRIOR_BAR, VERDICT_STYLE

G = 9.81


@pytest.fixture(scope="module")
def disk(disk_fit):
    """The disk's posterior, the intervals figure drawn from it and the table it draws."""
    post = open_posterior(disk_fit / "posterior.nc")
    return post, plots.plot_intervals(post, 0.95), plots.interval_table(post, 0.95)


def bars(fig, kind):
    """``{(body, quantity): (x0, x1, colour)}`` of the figure's ``kind`` bars (gid)."""
    out = {}
    for line in fig.axes[0].get_lines():
        gid = line.get_gid() or ""
        if gid.startswith(f"{kind}:"):
            _, body, quantity = gid.split(":")
            x0, x1 = (float(v) for v in line.get_xdata())
            out[body, quantity] = (x0, x1, to_rgb(line.get_color()))
    return out


def test_intervals_are_the_posterior_hdi_over_the_prior_interval(disk):
    post, fig, table = disk
    (body,) = post.bodies
    assert len(table) == len(REPORTED)
    drawn, prior = bars(fig, "posterior"), bars(fig, "prior")
    assert set(drawn) == set(prior) == {(body, p) for p in REPORTED}
    summary = post.summary(0.95).set_index("parameter")
    box = post.prior_box(body)
    # the prior's central 95 %: of a box, its 2.5 % and 97.5 % points, exactly
    rng = np.random.default_rng(0)
    m, x, rho = (rng.uniform(*box[p], 400_000) for p in PARAMETERS)
    derived = {"inertia": m * (rho**2 + x**2), "gravity_moment": m * G * x}
    for _, row in table.iterrows():
        p = row["parameter"]
        # the posterior's bar ends are its HDI, as summary.csv gives it
        assert row[["hdi_lower", "hdi_upper"]].tolist() == pytest.approx(
            summary.loc[p, ["hdi_lower", "hdi_upper"]].tolist(), rel=1e-12
        )
        if p in PARAMETERS:
            lo, hi = box[p]
            expected = [lo + 0.025 * (hi - lo), lo + 0.975 * (hi - lo)]
            assert row[["prior_lower", "prior_upper"]].tolist() == pytest.approx(
                expected, rel=1e-3
            )
            assert row["prior_median"] == pytest.approx((lo + hi) / 2, rel=1e-3)
        else:  # I and M_g of the box: an independent Monte Carlo of it
            expected = np.quantile(derived[p], [0.025, 0.5, 0.975])
            got = row[["prior_lower", "prior_median", "prior_upper"]].tolist()
            assert got == pytest.approx(expected, rel=0.01)
        # the figure draws those numbers, divided by the prior's median
        scale = row["prior_median"]
        x0, x1, _ = drawn[body, p]
        assert [x0 * scale, x1 * scale] == pytest.approx([row["hdi_lower"], row["hdi_upper"]])
        x0, x1, colour = prior[body, p]
        assert [x0 * scale, x1 * scale] == pytest.approx([row["prior_lower"], row["prior_upper"]])
        assert colour == to_rgb(PRIOR_BAR)
    low, high = fig.axes[0].get_xlim()  # every bar in view
    ends = [v for b in (drawn, prior) for x0, x1, _ in b.values() for v in (x0, x1)]
    assert low < min(ends)
    assert max(ends) < high
    assert fig.axes[0].get_xscale() == "log"


def test_interval_colours_are_the_verdict_of_identification_csv(disk_fit, disk):
    _, fig, _ = disk
    csv = pd.read_csv(disk_fit / "identification.csv").set_index(["body", "parameter"])
    verdict = csv["identified_by"].to_dict()
    # the paper's disk: its mass, CoM distance, I and M_g are the data's, its rho the box's
    assert {p: v for (_, p), v in verdict.items()} == {
        "mass": "data",
        "com_distance": "data",
        "radius_of_gyration": "prior",
        "inertia": "data",
        "gravity_moment": "data",
    }
    drawn = bars(fig, "posterior")
    for key, who in verdict.items():
        assert drawn[key][2] == to_rgb(VERDICT_STYLE[who][0]), key
    assert to_rgb(VERDICT_STYLE["data"][0]) != to_rgb(VERDICT_STYLE["prior"][0])
    # the legend names the prior's bar and every verdict
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == [
        "prior: central 95 %",
        "posterior 95 % HDI, decided by data",
        "posterior 95 % HDI, decided by data + prior",
        "posterior 95 % HDI, decided by prior",
    ]
    # the right-hand labels: the posterior median and HDI in SI units
    right = [t.get_text() for t in fig.axes[1].get_yticklabels()]
    assert len(right) == 5
    assert right[3].startswith("0.59")
    assert right[3].endswith("kg m²")


def test_the_intervals_figure_is_the_first_of_the_report(disk_fit, study_out):
    for folder in (disk_fit, study_out):
        page = (folder / "report.html").read_text(encoding="utf-8")
        assert (folder / "intervals.png").is_file()
        first = page.index("<img ")
        alt = re.match(r"<img alt='([^']*)'", page[first:]).group(1)
        assert html.unescape(alt).startswith("Every body's m, x, rho, I and M_g")
        assert page.index("<h2 id='posterior'>") < first < page.index("<h2 id='corner-plots'>")
        # before the summary table: the figure is the answer at a glance
        assert first < page.index("<table>", page.index("<h2 id='posterior'>"))
    assert FIGURE_SECTIONS[0] == "Posterior"


def test_intervals_record_is_registered_first(study_out):
    from inertiafit.pipeline.redraw import load_result

    records = figure_records(load_result(study_out))
    assert records[0].stem == "intervals"
    assert records[0].section == "Posterior"
    assert sum(r.stem == "intervals" for r in records) == 1


def test_contents_link_every_section_of_the_report(study_out):
    page = (study_out / "report.html").read_text(encoding="utf-8")
    headings = re.findall(r"<h2 id='([^']+)'>([^<]*)</h2>", page)
    assert page.count("<h2") == len(headings)  # every section has its anchor
    ids = [i for i, _ in headings]
    assert len(set(ids)) == len(ids)
    nav = re.search(r"<nav class='toc'[^>]*>(.*?)</nav>", page).group(1)
    assert re.findall(r"<li><a href='#([^']+)'>([^<]*)</a></li>", nav) == headings
    assert page.index("<nav class='toc'") < page.index("<h2")
    assert [html.unescape(t) for _, t in headings] == [
        "Posterior",
        "What pins what",
        "Priors",
        "Comparison with ideal bodies and the paper's estimator",
        "Corner plots",
        "Identification curves",
        "Trials",
        "Speed effect",
        "Diagnostics",
        "Methods",
        "Trial tables",
        "Inputs and provenance",
    ]


def section(page: str, anchor: str) -> str:
    start = page.index(f"<h2 id='{anchor}'>")
    end = page.find("<h2", start + 1)
    return page[start : end if end >= 0 else len(page)]


def test_trial_tables_come_folded_after_diagnostics_and_methods(study_out):
    page = (study_out / "report.html").read_text(encoding="utf-8")
    tables = section(page, "trial-tables")
    assert page.index("<h2 id='diagnostics'>") < page.index("<h2 id='methods'>")
    assert page.index("<h2 id='methods'>") < page.index("<h2 id='trial-tables'>")
    # every table of the section is inside its own fold, named by condition, kind and count
    folds = re.findall(r"<details><summary>([^<]*)</summary>(.*?)</details>", tables)
    assert [s for s, _ in folds] == [
        "attachment: quasi-static trials (1 trial)",
        "attachment: fast trials (6 trials)",
        "attachment+weight: quasi-static trials (1 trial)",
        "attachment+weight: fast trials (6 trials)",
    ]
    assert [body.count("<table>") for _, body in folds] == [1, 1, 1, 1]
    assert tables.count("<table>") == 4
    assert sum(body.count("<tr>") for _, body in folds) == 4 + 2 + 12
    # the Trials section keeps its figures and links to the tables; it holds no table now
    trials = section(page, "trials")
    assert "<table>" not in trials
    assert "<a href='#trial-tables'>Trial tables</a>" in trials
    assert trials.count("<img ") >= 3


def test_anchors_are_stable_and_unique():
    assert anchors(
        ["What pins what", "Comparison with ideal bodies and the paper's estimator"]
    ) == [
        "what-pins-what",
        "comparison-with-ideal-bodies-and-the-paper-s-estimator",
    ]
    assert anchors(["Trials", "trials", "***"]) == ["trials", "trials-2", "section"]
