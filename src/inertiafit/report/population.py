"""``report.html`` of a population (issue 33), its figures and the published tables beside it.

:func:`write_population_report` writes, per pooled body, a forest plot (each subject's own and
pooled estimates, the population's predictive for its covariates) and a regression plot (the
pooled subjects against their covariate, the line and its bands); then
``population-tables.csv`` (de Leva's and Dempster–Winter's bias on the pooled subjects) and
``report.html``.
"""

from __future__ import annotations

import html
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from inertiafit import __version__
from inertiafit.errors import InputError
from inertiafit.formatting import ess, interval, number, plural, r_hat
from inertiafit.inference.anthropometric import segment_values
from inertiafit.inference.population import (
    LOG_COVARIATES,
    hdi_bounds,
    natural_terms,
    predictive_draws,
    reported,
)
from inertiafit.inference.priors import priors_from_posterior
from inertiafit.io.outputs import write_csv
from inertiafit.physics import PARAMETERS, REPORTED, UNITS
from inertiafit.plotting.style import (
    DOUBLE_COLUMN,
    PALETTE,
    PRIOR_COLOUR,
    axis_label,
    check_formats,
    new_figure,
    save_figure,
    style_context,
)
from inertiafit.report.figures import safe_stem
from inertiafit.report.html import Details, Fragment, figure_png, write_report

if TYPE_CHECKING:
    from inertiafit.inference.pooling import PopulationPosterior, StudyPosterior

__all__ = ["TABLE_COLUMNS", "write_population_report"]

#: Columns of ``population-tables.csv``.
TABLE_COLUMNS = ["body", "table", "parameter", "bias_median_percent", "bias_lower_percent",
                 "bias_upper_percent", "n_subjects"]  # fmt: skip
_TABLE_NAMES = {"de-leva-female": "de Leva (female)", "de-leva-male": "de Leva (male)",
                "dempster": "Dempster–Winter"}  # fmt: skip
_COVARIATE_UNITS = {"body_mass": "kg", "segment_length": "m", "height": "m"}
#: Hyperparameter draws the figures' bands are computed over (evenly spaced).
_BAND_DRAWS = 4000


def _thin(flat: np.ndarray) -> np.ndarray:
    return flat[np.linspace(0, len(flat) - 1, min(_BAND_DRAWS, len(flat))).round().astype(int)]


def _covariates(pop: PopulationPosterior, body: str) -> list[dict[str, float]]:
    """Each subject's covariates (none for a population opened from its file)."""
    return [s.covariates(body) for s in pop.studies.get(body, [])]


def _forest(pop: PopulationPosterior, body: str, subjects: pd.DataFrame, hdi_prob: float):
    """One panel per quantity, one row per subject: own and pooled HDIs, the predictive."""
    fit, pct = pop.fits[body], f"{100 * hdi_prob:g} %"
    rows = subjects[subjects["body"] == body]
    names = list(dict.fromkeys(rows["subject"]))
    y = np.arange(len(names))[::-1].astype(float)
    rng, z = np.random.default_rng(pop.seed), _thin(fit.flat)
    predictive = [
        predictive_draws(fit.design, z, c, rng, pop.gravity) for c in _covariates(pop, body)
    ]
    with style_context():
        fig = new_figure(None, (DOUBLE_COLUMN, 0.32 * len(names) + 1.1))
        axes = fig.subplots(1, len(REPORTED), sharey=True)
        for ax, p in zip(axes, REPORTED, strict=True):
            r = rows[rows["parameter"] == p].set_index("subject").loc[names]
            for draws, yi in zip(predictive, y, strict=False):  # none without the studies
                ax.fill_betweenx(
                    [yi - 0.4, yi + 0.4],
                    *hdi_bounds(draws[p], hdi_prob),
                    color=PRIOR_COLOUR,
                    alpha=0.15,
                    lw=0,
                )
            for k, (who, dy) in enumerate((("own", 0.15), ("pooled", -0.15))):
                ax.hlines(y + dy, r[f"{who}_hdi_lower"], r[f"{who}_hdi_upper"], color=PALETTE[k])
                ax.plot(
                    r[f"{who}_median"],
                    y + dy,
                    "o",
                    color=PALETTE[k],
                    label=f"{who} (median, {pct} HDI)",
                )
            ax.set_xlabel(axis_label(p))
        axes[0].set_yticks(y, names)
        axes[0].set_ylim(-0.6, len(names) - 0.4)
        handles, labels = axes[0].get_legend_handles_labels()
        if predictive:
            from matplotlib.patches import Patch

            handles.append(Patch(color=PRIOR_COLOUR, alpha=0.3, lw=0))
            labels.append(f"population predictive ({pct} HDI)")
        fig.legend(handles, labels, loc="outside upper center", ncols=3)
    return fig


def _plain_log(axis) -> None:
    """A log axis over a narrow range, ticked in plain numbers (no powers of 10)."""
    from matplotlib import ticker

    axis.set_major_locator(ticker.MaxNLocator(4))
    axis.set_major_formatter(ticker.ScalarFormatter(useOffset=False))
    axis.set_minor_locator(ticker.NullLocator())


def _regression(pop: PopulationPosterior, body: str, subjects: pd.DataFrame, hdi_prob: float):
    """Per parameter: the pooled subjects against its first covariate, the line and its bands.

    A parameter without a covariate shows the subjects side by side and the population level.
    """
    fit, pct = pop.fits[body], f"{100 * hdi_prob:g} %"
    z = _thin(fit.flat)
    terms, covs = natural_terms(fit.design, z), _covariates(pop, body)
    eps = np.random.default_rng(pop.seed).standard_normal((len(z), 1))
    q = (0.5 - hdi_prob / 2, 0.5 + hdi_prob / 2)
    with style_context():
        fig = new_figure(None, (DOUBLE_COLUMN, 2.5))
        for ax, p in zip(fig.subplots(1, len(PARAMETERS)), PARAMETERS, strict=True):
            r = subjects[(subjects["body"] == body) & (subjects["parameter"] == p)]
            c = (fit.design.covariates[p] or (None,))[0]
            if c is None:
                xs, grid, t = np.arange(len(r)), np.array([-0.5, len(r) - 0.5]), np.zeros(2)
                slope = np.zeros(len(z))
                ax.set_xticks(xs, r["subject"])
                ax.set_xlabel("subject")
            else:
                xs = np.array([s.get(c, np.nan) for s in covs])
                lo, hi = (np.nanmin(xs), np.nanmax(xs)) if covs else (fit.design.reference(c),) * 2
                log = c in LOG_COVARIATES
                grid = np.geomspace(lo / 1.05, hi * 1.05) if log else np.linspace(lo, hi)
                t = np.array([fit.design.transformed(c, v) for v in grid])
                slope = terms[p, f"slope:{c}"]
                if log:
                    ax.set_xscale("log")
                    _plain_log(ax.xaxis)
                unit = _COVARIATE_UNITS.get(c)
                ax.set_xlabel(c.replace("_", " ") + (f" [{unit}]" if unit else ""))
            line = terms[p, "intercept"][:, None] + slope[:, None] * t  # (K, grid)
            pred = line + terms[p, "scatter"][:, None] * eps
            ax.fill_between(
                grid,
                *np.exp(np.quantile(pred, q, axis=0)),
                color=PALETTE[0],
                alpha=0.12,
                lw=0,
                label=f"predictive ({pct})",
            )
            ax.fill_between(
                grid,
                *np.exp(np.quantile(line, q, axis=0)),
                color=PALETTE[0],
                alpha=0.3,
                lw=0,
                label=f"line ({pct})",
            )
            ax.plot(grid, np.exp(np.median(line, axis=0)), color=PALETTE[0], label="regression")
            if len(xs) == len(r):
                med = r["pooled_median"].to_numpy()
                ax.errorbar(
                    xs,
                    med,
                    [med - r["pooled_hdi_lower"], r["pooled_hdi_upper"] - med],
                    fmt="o",
                    color=PALETTE[1],
                    label=f"subjects, pooled ({pct} HDI)",
                )
            ax.set_yscale("log")
            _plain_log(ax.yaxis)
            ax.set_ylabel(axis_label(p))
        fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="outside upper center", ncols=4)
    return fig


def _segment(study: StudyPosterior, body: str) -> str | None:
    """The subject's segment: its prior's anthropometric table's, else the body's name."""
    segment = priors_from_posterior(study.posterior)[body].anthropometric.get("segment")
    if segment:
        return str(segment)
    try:
        segment_values("dempster", body, 70.0, 0.3)
    except InputError:
        return None
    return body


def _table_values(table: str, segment: str, body_mass: float, length: float, gravity: float):
    """A table's ``m, x, rho, I, M_g`` ``(5,)`` for one subject (raises InputError)."""
    v = segment_values(table, segment, body_mass, length)
    return reported(np.log([v.mass, v.com_distance, v.radius_of_gyration]), gravity)


def _percent(logs: np.ndarray, prob: float) -> tuple[float, float, float]:
    """Median and central ``prob`` interval of log ratios ``(K,)`` as ``exp - 1``, in %."""
    lo, med, hi = 100 * np.expm1(np.quantile(logs, [0.5 - prob / 2, 0.5, 0.5 + prob / 2]))
    return float(med), float(lo), float(hi)


def _pct(med: float, lo: float, hi: float) -> str:
    return f"{med:+.3g} % [{lo:+.3g}, {hi:+.3g}]"


def _tables(pop: PopulationPosterior, body: str, hdi_prob: float):
    """Each table's bias on the pooled subjects, the typical subject against each, notes."""
    fit = pop.fits[body]
    values: dict[str, dict[int, np.ndarray]] = {}
    notes, segments = [], []
    for i, study in enumerate(pop.studies.get(body, [])):
        covs, segment = study.covariates(body), _segment(study, body)
        if not {"body_mass", "segment_length"} <= set(covs) or segment is None:
            why = "segment unknown (its prior is not from a table)" if segment is None else ""
            notes.append(f"{study.name}: {why or 'no body_mass or segment_length'}; left out.")
            continue
        segments.append(segment)
        sex = (study.subject or {}).get("sex")
        sexes = [sex] if sex in ("female", "male") else ["female", "male"]
        for table in [*(f"de-leva-{s}" for s in sexes), "dempster"]:
            try:
                values.setdefault(table, {})[i] = _table_values(
                    table, segment, covs["body_mass"], covs["segment_length"], pop.gravity
                )
            except InputError as exc:
                notes.append(f"{study.name}: {_TABLE_NAMES[table]}: {exc}")
    terms = natural_terms(fit.design, fit.flat)
    typical = np.log(
        reported(np.column_stack([terms[p, "intercept"] for p in PARAMETERS]), pop.gravity)
    )
    size = ("body_mass", "segment_length")
    reference = {c: fit.design.reference(c) for c in size if c in fit.design.centers}
    rows, versus = [], []
    for table, per in ((t, v) for t, v in values.items() if v):
        own = np.log(np.array(list(per.values())))[:, None, :]  # (n, 1, 5)
        ratio = (own - np.log(reported(fit.pooled[list(per)], pop.gravity))).mean(axis=0)
        rows += [
            [body, table, p, *_percent(ratio[:, j], hdi_prob), len(per)]
            for j, p in enumerate(REPORTED)
        ]
        if len(reference) == len(size):
            mass, length = reference["body_mass"], reference["segment_length"]
            ref = _table_values(table, segments[0], mass, length, pop.gravity)
            for j, p in enumerate(REPORTED):
                diff = _pct(*_percent(np.log(ref[j]) - typical[:, j], hdi_prob))
                typ = float(np.exp(np.median(typical[:, j])))
                versus.append([_TABLE_NAMES[table], p, ref[j], typ, UNITS[p], diff])
    columns = ["table", "parameter", "table value", "typical subject", "unit", "table/typical - 1"]
    return pd.DataFrame(rows, columns=TABLE_COLUMNS), pd.DataFrame(versus, columns=columns), notes


def _shown(frame: pd.DataFrame, columns: list[str], **extra) -> pd.DataFrame:
    """``columns`` of ``frame`` (some replaced by ``extra``) with spaces for underscores."""
    out = frame.assign(**extra)[columns]
    return out.rename(columns=lambda c: c.replace("_", " "))


def _intervals(frame: pd.DataFrame, lower: str, upper: str) -> list[str]:
    return [interval(a, b) for a, b in zip(frame[lower], frame[upper], strict=True)]


_INTRO = (
    "Each subject's study gave draws of the body's mass m, CoM distance x and radius of gyration "
    "rho under its own prior. The population regresses log m, log x and log rho on the subjects' "
    "covariates, with a correlated scatter between subjects. Its hyperparameters are sampled "
    "from the stored draws reweighted from each subject's prior to the population (importance "
    "reweighting, Hogg, Myers & Bovy 2010, ApJ 725:2166), and each subject's pooled estimate is "
    "its own draws reweighted to the population. A subject's importance-weight ESS says how many "
    "of its draws carry that weight; 'decided by' compares a hyperparameter's posterior SD with "
    "its hyperprior's (data < 0.3 <= data + prior <= 0.7 < prior)."
)
_TABLES_NOTE = (
    "Each table's prediction for each subject (its body mass, segment length and sex; both de "
    "Leva tables where the sex is unknown) against the pooled subject: bias = per posterior "
    "draw, the mean over subjects of log(table / pooled), shown as exp(bias) - 1, median "
    "[{pct} interval]."
)
_POPULATION_NOTE = (
    "The typical subject (at {reference}), slopes (elasticities: 1 is isometric scaling), "
    "scatters (SD of the log between subjects) and correlations; median and {pct} HDI."
)
#: The sub-sections of a body's section, by anchor.
_PARTS = {"population": "Population", "forest": "Subjects, own and pooled",
          "regression": "Regressions", "tables": "Published tables",
          "subjects": "Subjects table", "diagnostics": "Diagnostics"}  # fmt: skip
_CAPTIONS = {
    "forest": "{body}: each subject's own and pooled median and {pct} HDI; grey: the "
    "population's predictive for its covariates",
    "regression": "{body}: the pooled subjects against the covariate, the regression line "
    "(median), its {pct} band and the lighter {pct} predictive band",
}


def _body_items(pop, body, anchor, summary, subjects, hdi_prob, figures):
    """One body's section, its line in the introduction, its rows of the tables' CSV."""
    fit, pct = pop.fits[body], f"{100 * hdi_prob:g} %"
    table = summary[summary["body"] == body]
    bias, versus, notes = _tables(pop, body, hdi_prob)
    prior = [f"{r.parameter} {r.term}" for r in table.itertuples() if r.decided_by == "prior"]
    each = ", ".join(f"{n} {ess(e)}" for n, e in zip(fit.subjects, fit.ess, strict=True))
    line = (
        f"{body}: {plural(len(fit.subjects), 'subject')}; importance-weight ESS of "
        f"{fit.n_draws} draws each: {each}. Decided by the hyperprior, not the subjects: "
        f"{', '.join(prior) or 'nothing'}."
    )
    diag = pd.DataFrame({"subject": fit.subjects, "importance ESS": fit.ess.round()})
    if len(fit.ess_low) == len(fit.subjects):
        diag["importance ESS, 5th percentile over hyperparameter draws"] = fit.ess_low.round()
    diag["population mass in the prior box"] = fit.box_mass
    rows = subjects[subjects["body"] == body]
    own = _intervals(rows, "own_hdi_lower", "own_hdi_upper")
    pooled = _intervals(rows, "pooled_hdi_lower", "pooled_hdi_upper")
    columns = ["subject", "parameter", "own_median", "own_HDI", "pooled_median", "pooled_HDI"]
    subjects_shown = _shown(
        rows, [*columns, "width_ratio", "unit"], own_HDI=own, pooled_HDI=pooled
    )
    columns = ["parameter", "term", "median", "HDI", "unit", "decided_by", "ess_bulk", "r_hat"]
    hdi = _intervals(table, "hdi_lower", "hdi_upper")
    rhats = [r_hat(v) for v in table["r_hat"]]
    shown = _shown(table, columns, HDI=hdi, ess_bulk=table["ess_bulk"].round(), r_hat=rhats)
    cols = ("bias_median_percent", "bias_lower_percent", "bias_upper_percent")
    percent = [_pct(*v) for v in zip(*(bias[c] for c in cols), strict=True)]
    names = [_TABLE_NAMES[t] for t in bias["table"]]
    bias_shown = _shown(
        bias, ["table", "parameter", "bias", "n_subjects"], table=names, bias=percent
    )
    runs = ", ".join(
        f"{k.replace('_', ' ')} {number(v)}" for k, v in fit.diagnostics.items() if k != "mode"
    )
    h3 = {k: Fragment(f"<h3 id='{anchor}-{k}'>{html.escape(v)}</h3>") for k, v in _PARTS.items()}
    items = [
        h3["population"],
        _POPULATION_NOTE.format(reference=table["reference"].iloc[0], pct=pct),
        shown,
        h3["forest"],
        (_CAPTIONS["forest"].format(body=body, pct=pct), figures[0]),
        h3["regression"],
        (_CAPTIONS["regression"].format(body=body, pct=pct), figures[1]),
        h3["tables"],
        _TABLES_NOTE.format(pct=pct),
        bias_shown if len(bias) else "No subject could be compared with a table.",
        *(
            ["The typical subject against each table at the reference covariates:", versus]
            if len(versus)
            else []
        ),
        *notes,
        h3["subjects"],
        Details(
            f"own and pooled estimates of {plural(len(fit.subjects), 'subject')}", [subjects_shown]
        ),
        h3["diagnostics"],
        f"Hyperparameters: {runs}.",
        diag,
    ]
    return items, line, bias


def write_population_report(
    folder: Path,
    pop: PopulationPosterior,
    *,
    hdi_prob: float = 0.95,
    formats: tuple[str, ...] | list[str] = ("png",),
) -> list[str]:
    """Write a population's figures, ``population-tables.csv`` and ``report.html`` in ``folder``.

    Per body: ``population-forest-<body>`` and ``population-regression-<body>`` in each of
    ``formats``. Returns the names of the files written (figures, the CSV, the page).
    """
    folder, formats = Path(folder), check_formats(formats)
    summary, subjects = pop.summary(hdi_prob), pop.subjects(hdi_prob)
    written: list[str] = []

    def save(fig, stem: str) -> bytes:
        """Save a figure in every format; its PNG for the page."""
        stem = safe_stem(stem)
        save_figure(fig, folder / stem, formats)
        written.extend(f"{stem}.{f}" for f in formats)
        return (folder / f"{stem}.png").read_bytes() if "png" in formats else figure_png(fig)

    intro, sections, biases = [_INTRO], [], []
    toc, anchors = ["<li><a href='#what'>What this is</a></li>"], {"What this is": "what"}
    for k, body in enumerate(pop.fits):
        heading = f"Population of {body}"
        anchors[heading] = anchor = f"b{k}-" + re.sub(r"[^A-Za-z0-9]+", "-", body).strip("-")
        figures = [
            save(draw(pop, body, subjects, hdi_prob), f"population-{name}-{body}")
            for name, draw in (("forest", _forest), ("regression", _regression))
        ]
        items, line, bias = _body_items(pop, body, anchor, summary, subjects, hdi_prob, figures)
        intro.append(line)
        biases.append(bias)
        sections.append((heading, items))
        toc.append(
            f"<li><a href='#{anchor}'>{html.escape(heading)}</a><ul>"
            + "".join(f"<li><a href='#{anchor}-{p}'>{t}</a></li>" for p, t in _PARTS.items())
            + "</ul></li>"
        )
    frame = pd.concat(biases, ignore_index=True) if biases else pd.DataFrame()
    write_csv(frame.reindex(columns=TABLE_COLUMNS), folder / "population-tables.csv")
    written.append("population-tables.csv")
    notes = {"inertiafit": __version__, "seed": pop.seed, "gravity (m/s^2)": pop.gravity}
    notes.update(
        {f"studies of {b}": ", ".join(s.label for s in st) for b, st in pop.studies.items()}
    )
    path = write_report(
        folder / "report.html",
        title=f"inertiafit population: {', '.join(pop.fits)}",
        sections=[
            ("Contents", [Fragment(f"<ul>{''.join(toc)}</ul>")]),
            ("What this is", intro),
            *sections,
        ],
        notes=notes,
    )
    text = path.read_text(encoding="utf-8")
    for heading, anchor in anchors.items():  # write_report's headings get their anchors
        h = html.escape(heading)
        text = text.replace(f"<h2>{h}</h2>", f"<h2 id='{anchor}'>{h}</h2>", 1)
    path.write_text(text, encoding="utf-8")
    return [*written, "report.html"]
