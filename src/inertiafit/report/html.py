"""A self-contained ``report.html``: tables and figures embedded, readable without a network.

:func:`write_report` writes any page of sections; :func:`study_report` lays out the page of a
:class:`~inertiafit.report.result.Result` with the answer first: a table of contents linking
every section, then the posterior (its intervals figure, every body's quantities against their
prior, and its table), what pins what, priors, comparison, corner plots, identification curves,
trial figures, speed effect, diagnostics and methods; the long per-trial tables come last,
folded, before "Inputs and provenance", which lists every input file's SHA-256 and reader
settings as stored in ``posterior.nc``. Skipped trials, if any, come first.

Each section of that page is a :class:`ReportSection` (its anchor, its heading and the
function that builds its items from a :class:`PageContext`, or leaves it out) in one ordered
registry, :data:`REPORT_SECTIONS`, as the figures are records
(:mod:`inertiafit.report.figures`): a new section is a builder and one
:func:`register_report_section`.
"""

from __future__ import annotations

import base64
import html
import io
import json
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from inertiafit.formatting import number, plural
from inertiafit.posterior import Posterior
from inertiafit.posterior.pins import SHARE_NOTE, VERDICT_NOTE
from inertiafit.report.figures import FigureRecord, figure_records
from inertiafit.report.methods import methods_html, prior_table
from inertiafit.report.result import Result
from inertiafit.report.tables import (
    comparison_display,
    correlation_display,
    identification_display,
    passive_display,
    speed_effect_display,
    summary_display,
    trial_tables,
    tukey_display,
)

__all__ = [
    "PRIOR_SHARE_NOTE",
    "REPORT_SECTIONS",
    "Details",
    "Fragment",
    "Heading",
    "PageContext",
    "ReportSection",
    "anchors",
    "conflict_items",
    "derived_items",
    "figure_png",
    "figure_png_base64",
    "prior_items",
    "provenance_line",
    "provenance_table",
    "register_report_section",
    "skipped_trials",
    "study_report",
    "table_html",
    "write_report",
]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222;
  padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; }
h3 { font-size: 1.05em; margin-bottom: 0.3em; }
.table { max-width: 100%; overflow-x: auto; margin: 0.5em 0 1.5em; }
table { border-collapse: collapse; font-size: 0.85em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: right; }
th { background: #f4f4f4; } td:first-child, th:first-child { text-align: left; }
td { white-space: nowrap; }
.text { text-align: left; white-space: normal; overflow-wrap: break-word; }
figure { margin: 1em 0; }
img { max-width: 100%; height: auto; border: 1px solid #eee; box-sizing: border-box; }
.note { color: #555; font-size: 0.9em; }
pre { background: #f8f8f8; padding: 0.6em; white-space: pre-wrap; overflow-wrap: anywhere; }
.warn { color: #a33; } details > summary { cursor: pointer; }
p.methods { max-width: 50em; line-height: 1.45; } ol.refs { font-size: 0.9em; }
nav.toc { font-size: 0.9em; margin: 0.5em 0 1em; }
nav.toc ol { display: flex; flex-wrap: wrap; gap: 0.2em 1.4em; list-style: none; padding: 0;
  margin: 0.3em 0 0; }
"""


#: The section of the per-trial tables, after the Methods (see :func:`study_report`), and its
#: anchor.
_TRIAL_TABLES = "Trial tables"
_TRIAL_TABLES_ANCHOR = "trial-tables"


class Heading(str):
    """A sub-heading (``<h3>``) among a section's items."""


class Fragment(str):
    """Trusted HTML among a section's items, written as is (made by inertiafit, escaped)."""


@dataclass(frozen=True)
class Details:
    """A folded block among a section's items: one summary line, its items shown on a click."""

    summary: str
    items: list = field(default_factory=list)


def figure_png(fig, dpi: int = 110) -> bytes:
    """PNG of a Matplotlib figure, for embedding."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def figure_png_base64(fig, dpi: int = 110) -> str:
    """PNG of a Matplotlib figure as base64 text, for embedding."""
    return base64.b64encode(figure_png(fig, dpi)).decode("ascii")


def _is_text(values: pd.Series) -> bool:
    """Whether a column holds words rather than numbers (left-aligned, free to wrap)."""
    if pd.api.types.is_numeric_dtype(values):
        return False
    shown = [str(v) for v in values if isinstance(v, str) and v]
    return any(not _NUMERIC.fullmatch(v) for v in shown)


_NUMERIC = re.compile(r"[-+\u2212]?[\d.,eE+\- ±\[\]%–]*")


def table_html(frame: pd.DataFrame, digits: int = 4) -> str:
    """An HTML table with numbers rounded to ``digits`` significant figures.

    Wrapped in a box that scrolls sideways rather than widen the page; columns of words are
    left-aligned and wrap.
    """
    text = [_is_text(frame[c]) for c in frame.columns]
    head = "".join(
        ("<th class='text'>" if t else "<th>") + f"{html.escape(str(c))}</th>"
        for c, t in zip(frame.columns, text, strict=True)
    )
    rows = "".join(
        "<tr>"
        + "".join(
            ("<td class='text'>" if t else "<td>") + f"{html.escape(number(v, digits))}</td>"
            for v, t in zip(row, text, strict=True)
        )
        + "</tr>"
        for row in frame.itertuples(index=False)
    )
    return (
        f"<div class='table'><table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody>"
        "</table></div>"
    )


def _item_html(entry, heading: str) -> str:
    """One item of a section: a table, a paragraph, a figure with its caption, a fold."""
    caption, item = entry if isinstance(entry, tuple) else ("", entry)
    if isinstance(item, pd.DataFrame):
        return table_html(item)
    if isinstance(item, Details):
        inner = "".join(_item_html(e, heading) for e in item.items)
        return f"<details><summary>{html.escape(item.summary)}</summary>{inner}</details>"
    if isinstance(item, Heading):
        return f"<h3>{html.escape(item)}</h3>"
    if isinstance(item, Fragment):
        return str(item)
    if isinstance(item, str):
        if item.startswith("pre:"):
            return f"<pre>{html.escape(item[4:])}</pre>"
        if item.startswith("warn:"):
            return f"<p class='warn'>{html.escape(item[5:])}</p>"
        return f"<p class='note'>{html.escape(item)}</p>"
    data = (
        base64.b64encode(item).decode("ascii")
        if isinstance(item, bytes)
        else figure_png_base64(item)
    )
    return (
        f"<figure><img alt='{html.escape(caption or heading)}' "
        f"src='data:image/png;base64,{data}'>"
        + (f"<figcaption class='note'>{html.escape(caption)}</figcaption>" if caption else "")
        + "</figure>"
    )


def skipped_trials(trials: pd.DataFrame) -> pd.DataFrame:
    """The skipped rows of a trial table: ``file, condition, kind, speed, reason``.

    Empty for a table without a ``status`` column (written before trials could be skipped).
    """
    columns = ["file", "condition", "kind", "speed", "reason"]
    if "status" not in trials.columns:
        return pd.DataFrame(columns=columns)
    rows = trials[trials["status"] == "skipped"]
    reason = rows["flags"].fillna("").astype(str).str.removeprefix("skipped: ")
    return rows.assign(reason=reason)[columns].reset_index(drop=True)


#: Order of the reader settings in the provenance table (others follow alphabetically).
_SETTINGS_ORDER = ("format", "columns", "units", "calibration", "options", "torque_sign", "window")


def _settings_text(settings: Mapping[str, object]) -> str:
    """Reader settings in one line, the empty ones left out."""
    rank = {key: i for i, key in enumerate(_SETTINGS_ORDER)}
    keys = sorted(settings, key=lambda k: (rank.get(k, len(rank)), k))
    return "; ".join(
        f"{key} = {json.dumps(settings[key], sort_keys=True)}"
        for key in keys
        if settings[key] not in (None, {}, [])
    )


def provenance_table(provenance: Mapping[str, Any]) -> pd.DataFrame:
    """The input files of a study: ``input, file, sha256, status, reader settings``.

    From the ``provenance`` attribute of a study's posterior (see
    :func:`inertiafit.pipeline.study.study_provenance`): the manifest, every trial file and
    every prior file; empty when nothing was recorded.
    """
    rows = []
    manifest = provenance.get("manifest")
    if isinstance(manifest, Mapping):
        rows.append(("manifest", manifest.get("path", ""), manifest.get("sha256", ""), "", ""))
    for trial in provenance.get("trials", []) or []:
        rows.append(
            (
                f"{trial.get('kind', '')} trial, {trial.get('condition', '')}",
                trial.get("file", ""),
                trial.get("sha256") or "(unreadable)",
                trial.get("status", ""),
                _settings_text(trial.get("reader", {})),
            )
        )
    for body, prior in (provenance.get("priors", {}) or {}).items():
        inline = prior.get("path") == "inline"
        rows.append(
            (
                f"prior of {body}",
                "inline table in the manifest" if inline else prior.get("path", ""),
                "" if inline else prior.get("sha256", ""),
                "",
                "",
            )
        )
    return pd.DataFrame(rows, columns=["input", "file", "sha256", "status", "reader settings"])


def anchors(headings: Sequence[str]) -> list[str]:
    """A stable ``id`` for each heading: its words in lower case joined by ``-``, unique.

    ``"What pins what"`` -> ``what-pins-what``; a heading met again gets ``-2``, ``-3``.
    """
    out: list[str] = []
    for heading in headings:
        base = re.sub(r"[^a-z0-9]+", "-", heading.lower()).strip("-") or "section"
        name, k = base, 1
        while name in out:
            k += 1
            name = f"{base}-{k}"
        out.append(name)
    return out


def write_report(
    path: str | Path,
    *,
    title: str,
    sections: list[tuple[str, list]],
    notes: Mapping[str, object] | None = None,
    appendix: list | None = None,
    provenance: str | None = None,
    contents: bool = False,
    ids: Sequence[str] | None = None,
) -> Path:
    """Write a self-contained HTML report.

    Parameters
    ----------
    path : str or pathlib.Path
        Where to write ``report.html``.
    title : str
        Page title.
    sections : list of (heading, items)
        Items are :class:`pandas.DataFrame` (a table), Matplotlib figures or PNG bytes (embedded),
        ``("caption", figure)`` pairs, or strings (a paragraph; ``pre:`` prefix for
        preformatted text, ``warn:`` for a warning).
    notes : mapping, optional
        Key-value pairs listed at the end (inputs, versions, seed).
    appendix : list, optional
        Items (as in a section) shown after ``notes`` under "Inputs and provenance".
    provenance : str, optional
        The one line "Inputs and provenance" shows; ``notes`` and ``appendix`` are folded
        under it (``<details>``) and open on a click.
    contents : bool
        Give every section's heading an ``id`` (:func:`anchors`) and list them all, as links,
        in a table of contents under the title.
    ids : sequence of str, optional
        With ``contents``, an ``id`` for each section (each lower-case words
        joined by ``-``, as :func:`anchors` makes them); default: :func:`anchors` of the
        headings.

    Items may also be a :class:`Heading` (``<h3>``), a :class:`Details` (a folded block of
    items) or a :class:`Fragment` (trusted HTML).
    """
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        "<meta name='viewport' content='width=device-width, initial-scale=1'>",
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    headings = [heading for heading, _ in sections]
    if notes or appendix:
        headings.append("Inputs and provenance")
    given = list(ids or [])
    slugs = anchors([*given, *headings[len(given) :]]) if contents else []

    def h2(k: int) -> str:
        where = f" id='{slugs[k]}'" if contents else ""
        return f"<h2{where}>{html.escape(headings[k])}</h2>"

    if contents:
        links = "".join(
            f"<li><a href='#{a}'>{html.escape(h)}</a></li>"
            for h, a in zip(headings, slugs, strict=True)
        )
        parts.append(
            f"<nav class='toc' id='contents'><strong>Contents</strong><ol>{links}</ol></nav>"
        )
    for k, (heading, items) in enumerate(sections):
        parts.append(h2(k))
        parts.extend(_item_html(entry, heading) for entry in items)
    if notes or appendix:
        parts.append(h2(len(sections)))
        folded: list = []
        if notes:
            folded.append(
                pd.DataFrame({"item": list(notes), "value": [str(v) for v in notes.values()]})
            )
        folded += list(appendix or [])
        line = provenance or "Inputs, software versions and seed"
        parts.append(_item_html(Details(line, folded), "Inputs and provenance"))
    # Records, once the page has loaded, how many embedded figures the browser decoded; a
    # headless-browser test reads it back (nothing is fetched: the page stays offline).
    parts.append(
        "<script>window.addEventListener('load', function () { var n = 0;"
        " for (var i = 0; i < document.images.length; i++) {"
        " if (document.images[i].complete && document.images[i].naturalWidth > 0) { n++; } }"
        " document.body.setAttribute('data-figures-drawn', String(n)); });</script>"
    )
    parts.append("</body></html>")
    path = Path(path)
    path.write_text("\n".join(parts), encoding="utf-8")
    return path


#: A section's anchor: lower-case words and digits joined by ``-`` (what :func:`anchors` makes).
_ANCHOR = re.compile(r"[a-z0-9]+(?:-[a-z0-9]+)*")


@dataclass(frozen=True)
class PageContext:
    """What a section of ``report.html`` may draw on: the result, the options, the figures.

    ``figures`` holds the PNG of each figure by stem and ``records`` says which section each
    belongs to (:class:`~inertiafit.report.figures.FigureRecord`); ``placed`` collects the
    stems :meth:`figures_of` has handed out, so that the page can show the others last.
    """

    result: Result
    hdi_prob: float
    figures: Mapping[str, bytes]
    records: Sequence[FigureRecord]
    placed: set[str] = field(default_factory=set)

    @property
    def posterior(self) -> Posterior:
        """The result's :class:`~inertiafit.posterior.Posterior`."""
        return self.result.posterior

    def figures_of(self, section: str) -> list[tuple[str, bytes]]:
        """The ``(caption, png)`` of every figure drawn for ``section``, in record order."""
        items = []
        for record in self.records:
            if record.section == section and record.stem in self.figures:
                items.append((record.caption, self.figures[record.stem]))
                self.placed.add(record.stem)
        return items

    def unplaced(self) -> list[tuple[str, bytes]]:
        """The ``(caption, png)`` of every drawn figure no section has shown."""
        return [
            (r.caption, self.figures[r.stem])
            for r in self.records
            if r.stem in self.figures and r.stem not in self.placed
        ]


@dataclass(frozen=True)
class ReportSection:
    """One section of a study's ``report.html``.

    Attributes
    ----------
    anchor : str
        Its heading's ``id`` (the link in the table of contents) and its name in
        :data:`REPORT_SECTIONS`: lower-case words and digits joined by ``-``.
    heading : str
        Its heading (``<h2>``); a figure is shown in the section whose heading is its
        record's ``section``.
    build : callable
        ``build(page)`` gets the :class:`PageContext` and returns the section's items (as
        :func:`write_report` takes them), or ``None`` when the section does not apply to this
        result: then the page has no such heading.
    order : int
        Where it comes on the page (smaller first); the built-in sections are 10 to 130.
    """

    anchor: str
    heading: str
    build: Callable[[PageContext], list | None]
    order: int = 200

    def __post_init__(self) -> None:
        if not _ANCHOR.fullmatch(self.anchor):
            msg = f"report section {self.anchor!r}: an anchor is lower-case words joined by '-'"
            raise ValueError(msg)


#: Every section of a study's report.html, by anchor, in page order.
REPORT_SECTIONS: dict[str, ReportSection] = {}


def register_report_section(section: ReportSection) -> ReportSection:
    """Add a section to :data:`REPORT_SECTIONS`, kept in page order (its ``order``)."""
    if section.anchor in REPORT_SECTIONS:
        msg = f"report section {section.anchor!r} is registered already"
        raise ValueError(msg)
    ordered = sorted([*REPORT_SECTIONS.values(), section], key=lambda s: s.order)
    REPORT_SECTIONS.clear()
    REPORT_SECTIONS.update((s.anchor, s) for s in ordered)
    return section


def study_report(
    path: Path,
    result: Result,
    figures: Mapping[str, bytes],
    hdi_prob: float,
    records: Sequence[FigureRecord] | None = None,
) -> Path:
    """The self-contained ``report.html``: tables, embedded figures, diagnostics, provenance.

    Every section of :data:`REPORT_SECTIONS` that applies to ``result``, in order: the page
    leads with the answer (its table of contents, then the "Posterior" section with the
    intervals figure and the summary table); the per-trial tables are folded in the section
    "Trial tables" after the Methods.

    ``figures`` holds the PNG of each figure by stem; ``records`` (default
    :func:`~inertiafit.report.figures.figure_records` of ``result``) says where each goes and
    its caption. Every record with a PNG is shown: in its section, or, if the page has no
    such section for this result, in a last section "Other figures".
    """
    records = figure_records(result) if records is None else records
    page = PageContext(result, hdi_prob, figures, records)
    sections: list[tuple[str, list]] = []
    ids: list[str] = []
    for section in REPORT_SECTIONS.values():
        items = section.build(page)
        if items is not None:
            sections.append((section.heading, items))
            ids.append(section.anchor)
    others = page.unplaced()
    if others:
        sections.append(("Other figures", others))
        ids.append("other-figures")
    notes, appendix, files = _inputs(result)
    return write_report(
        path,
        title=f"inertiafit: {result.name}",
        sections=sections,
        notes=notes,
        appendix=appendix,
        provenance=provenance_line(result, files),
        contents=True,
        ids=ids,
    )


def _inputs(result: Result) -> tuple[dict[str, object], list, pd.DataFrame]:
    """The notes and appendix of "Inputs and provenance", and the input files' table."""
    a = result.posterior.attrs
    notes = {
        "study": result.name,
        "manifest": result.manifest,
        "seed": a.get("seed"),
        "gravity (m/s^2)": result.gravity,
        "versions": a.get("versions"),
        "sampled coordinates": a.get("sampled_coordinates"),
    }
    try:
        provenance = json.loads(a.get("provenance") or "{}")
    except (TypeError, ValueError):
        provenance = {}
    files = provenance_table(provenance if isinstance(provenance, dict) else {})
    appendix: list = []
    if len(files):
        notes["on trial error"] = provenance.get("on_trial_error", "stop")
        appendix = [
            (
                "Every input file with its SHA-256 (of its bytes when the posterior was sampled) "
                "and the reader settings it was read with."
            ),
            files,
        ]
    elif not result.from_numbers:
        notes["input files"] = "not recorded (posterior.nc written before inertiafit kept them)"
    return notes, appendix, files


# -- The sections, in page order ---------------------------------------------------------------


def _skipped_section(page: PageContext) -> list | None:
    """The trials set aside under ``on_trial_error = "skip"``, first, when there are any."""
    trials = page.result.trials
    skipped = skipped_trials(trials)
    if not len(skipped):
        return None
    used = len(trials) - len(skipped)
    return [
        (
            f"warn:{len(skipped)} of {len(trials)} trials could not be read "
            'or processed and were skipped (on_trial_error = "skip"); the posterior, '
            f"the speed effect and the paper's estimator use the other {used}."
        ),
        skipped,
    ]


def _posterior_section(page: PageContext) -> list:
    """The answer: the intervals figure, the summary table, the derived quantities folded."""
    post, hdi_prob = page.posterior, page.hdi_prob
    ident = post.identification()
    return [
        (
            f"Median and {100 * hdi_prob:g}% highest-density interval of every body's "
            f"parameters from one joint posterior over all conditions. {VERDICT_NOTE}."
        ),
        *page.figures_of("Posterior"),
        summary_display(page.result.summary(hdi_prob)),
        post.report(hdi_prob).splitlines()[0] + ".",
        *(
            f"{body}: physical consistency needs m >= (M_g/g)^2/I = "
            f"{float(ident.loc[ident.body == body, 'minimum_mass'].iloc[0]):.4g} kg."
            for body in post.bodies
        ),
        post.calibration_note(),
        *derived_items(page.result, hdi_prob),
    ]


def _pins_section(page: PageContext) -> list:
    """Who decides each quantity, the prior-data check, the posterior correlations."""
    post = page.posterior
    return [
        (
            "One rotation axis pins only m·x (from M_g) and I per body; where the body "
            "sits on the curve of constant m·x and I is decided by the prior unless a "
            "weighed mass, a balance point or a second mounting pins it."
        ),
        PRIOR_SHARE_NOTE,
        *post.what_pins_what().values(),
        *conflict_items(post),
        identification_display(page.result.identification()),
        "Posterior correlations of m, x and rho:",
        correlation_display(post.correlations()),
    ]


def _priors_section(page: PageContext) -> list:
    """Each body's prior (:func:`prior_items`)."""
    return prior_items(page.result)


def _comparison_section(page: PageContext) -> list:
    """The comparison table: prior, ideal body, posterior and the paper's estimator."""
    return [
        (
            "ideal: textbook model declared in the manifest; paper's baseline: the "
            "multi-start least squares of Son et al. Eq. (4), feasible-region mean (a "
            "body added to another is fitted to the difference of the condition means, "
            "as the paper does)."
        ),
        comparison_display(page.result.comparison, page.hdi_prob),
    ]


def _corner_section(page: PageContext) -> list:
    """The corner plots, one per body."""
    return page.figures_of("Corner plots")


def _identification_section(page: PageContext) -> list:
    """The identification curves: where on the curve the data leave each body."""
    return [
        (
            "Rotation about one axis identifies only m·x = M_g/g and I = m (rho^2 + "
            "x^2): the bodies that fit the data lie on a curve. Where the data pin m·x "
            "and I (see 'What pins what'), the prior box decides where on the curve "
            "the body sits."
        ),
        *page.figures_of("Identification curves"),
    ]


def _living_section(page: PageContext) -> list | None:
    """A living body's joint: its passive parameters and figures; none for a rigid study."""
    if not page.result.living:
        return None
    return [
        (
            "A living body's joint adds its passive elastic moment, a hysteresis and "
            "a viscous damping to every trial; they are fitted with gravity over the "
            "quasi-static and rest trials (the passive coefficients integrated out "
            "under their prior) and with the inertia over each fast trial's "
            "acceleration and deceleration windows. 'decided by' says what told the "
            "gravity moment apart from the passive curve: the passive prior (one "
            "posture), or data (a second posture, the horizontal plane)."
        ),
        passive_display(page.result.living["passive_parameters"]),
        *page.figures_of("Living joint"),
    ]


def _trials_section(page: PageContext) -> list | None:
    """The trial figures and a link to the folded tables; none without trials."""
    result = page.result
    if not len(result.trials):
        return None
    no_traces = (
        "Trial traces not drawn: this output folder has no traces.csv "
        "(it is written when the posterior is sampled)."
    )
    return [
        *page.figures_of("Trials"),
        *([] if len(result.traces) else [no_traces]),
        Fragment(
            "<p class='note'>Every trial as processed: the tables of each "
            "condition and kind of trial are folded under "
            f"<a href='#{_TRIAL_TABLES_ANCHOR}'>{_TRIAL_TABLES}</a>, after the "
            "Methods.</p>"
        ),
    ]


def _speed_section(page: PageContext) -> list | None:
    """The inertia per condition and speed, the ANOVA and Tukey pairs; none without trials."""
    result = page.result
    if not len(result.trials):
        return None
    pairs = tukey_display(result.speed_effect)
    return [
        (
            "Inertia per condition and speed (mean ± SD over the trials), with the "
            "one-way ANOVA across speeds of each condition:"
        ),
        speed_effect_display(result.speed_effect),
        *(
            ["Pairs of speeds (Tukey HSD), difference of mean inertias:", pairs]
            if len(pairs)
            else []
        ),
    ]


def _diagnostics_section(page: PageContext) -> list:
    """The sampler's run and convergence, its figures, every trial flag."""
    post = page.posterior
    a = post.attrs
    run = (
        f"{a['n_walkers']} walkers, {a['n_steps']} steps ({a['burn']} dropped as burn-in), "
        f"integrated autocorrelation time tau at most {a['tau_max']:.2f} steps, acceptance "
        f"{a['acceptance']:.2f}, sampling {a['sampling_seconds']:.1f} s; "
        + (
            "converged (chain > 50 tau, R-hat <= 1.01, bulk ESS >= 1000 for every quantity)."
            if post.converged
            else "NOT converged: treat the intervals with care."
        )
    )
    return [
        run,
        *page.figures_of("Diagnostics"),
        *(["warn:" + w for w in page.result.warnings] or ["No trial flags."]),
    ]


def _methods_section(page: PageContext) -> list:
    """The Methods text, as methods.md has it."""
    return [
        (
            "Generated from this analysis; the same text is in methods.md and its "
            "references in references.bib, ready to edit into a manuscript."
        ),
        Fragment(methods_html(page.result, table_html)),
    ]


def _trial_tables_section(page: PageContext) -> list | None:
    """Every trial as processed, a folded table per condition and kind; none without trials."""
    if not len(page.result.trials):
        return None
    tables = [
        Details(f"{title} ({plural(len(table), 'trial')})", [table])
        for title, table in trial_tables(page.result.trials)
    ]
    if not tables:
        return None
    return [
        (
            "Every trial as processed, a table per condition and kind of trial "
            "(click to open; trials.csv has every value at full precision)."
        ),
        *tables,
    ]


#: What the "prior share" column means, where report.html shows it.
PRIOR_SHARE_NOTE = (
    f"{SHARE_NOTE}. The box is shrunk about its centre; power-scaling, as arviz-stats psense "
    "does, leaves a box unchanged, so 'psense prior' is blank for a box."
)


def derived_items(result: Result, hdi_prob: float) -> list:
    """``I_com``, the parameters relative to the subject, the published tables beside them.

    One fold of the "Posterior" section, so that its first screen stays the answer.
    """
    from inertiafit.report.derived import body_sizes, derived_table, published_table

    post = result.posterior
    mass, lengths, sex = body_sizes(post)
    derived = derived_table(post, hdi_prob, body_mass=mass, segment_lengths=lengths)
    pct = f"{100 * hdi_prob:g}%"
    items: list = [
        (
            f"Derived from the draws (median and {pct} HDI): the moment of inertia about the "
            "centre of mass, I_com = m rho^2"
            + (
                "; m as % of the subject's body mass and x, rho as % of the segment length "
                "the manifest gives"
                if mass is not None or lengths
                else " (the manifest's [subject] body_mass and a body's segment_length add "
                "m as % body mass and x, rho as % segment length)"
            )
            + "."
        ),
        derived.rename(columns=lambda c: c.replace("_", " ")),
    ]
    published = published_table(
        post, gravity=result.gravity, body_mass=mass, segment_lengths=lengths, sex=sex
    )
    if len(published):
        items += [
            (
                "The published tables' predictions for this subject's segment beside the "
                "posterior: percent of median = 100 (table / posterior median - 1); posterior "
                "SDs = (table - median) / posterior SD."
            ),
            published.rename(columns=lambda c: c.replace("_", " ")),
        ]
    said = ["I about the centre of mass"]
    if mass is not None or lengths:
        said.append("% body mass and % segment length")
    if len(published):
        said.append("the published tables beside the posterior")
    return [Details("Derived: " + ", ".join(said), items)]


def conflict_items(post) -> list[str]:
    """The prior-data check in the "What pins what" section: each conflict as a warning.

    One ``warn:`` line per quantity in conflict
    (:meth:`~inertiafit.posterior.Posterior.conflict_warnings`), else one line saying the
    check passed.
    """
    from inertiafit.posterior.display import predictive_text

    lines = post.conflict_warnings()
    if lines:
        return ["warn:" + line for line in lines]
    checked = predictive_text(post)
    return [checked] if checked else []


def prior_items(result: Result) -> list:
    """The "Priors" section: per body its prior's kind, parameters, bounds and source."""
    items: list = [
        (
            "The prior of each body's mass m, centre-of-mass distance x and radius of gyration "
            "rho, as the posterior was sampled with it (stored in posterior.nc)."
        )
    ]
    for body, prior in result.priors.items():
        items.append(Heading(body))
        if prior.description:
            items.append(prior.description)
        items.append(prior_table(prior))
        if prior.anthropometric:
            items.append(
                "anthropometric table: "
                + ", ".join(f"{k} {v}" for k, v in prior.anthropometric.items() if v)
            )
        items.append(f"source: {prior.source}" if prior.source else "source: not given")
    return items


def provenance_line(result: Result, files: pd.DataFrame) -> str:
    """One line saying what the result was computed from; the detail is folded under it."""
    a = result.posterior.attrs
    try:
        versions = json.loads(a.get("versions") or "{}")
    except (TypeError, ValueError):
        versions = {}
    tail = f"inertiafit {versions.get('inertiafit', '?')}, seed {a.get('seed')}"
    if result.from_numbers:
        return f"Fitted from reported numbers; {tail}. Details: click to open."
    if not len(files):
        return f"Input files not recorded; {tail}. Details: click to open."
    trials = files[files["input"].str.contains(" trial, ")]
    skipped = int((trials["status"] == "skipped").sum())
    priors = int(files["input"].str.startswith("prior of ").sum())
    return (
        f"{plural(len(trials), 'trial file')}"
        + (f" ({skipped} skipped)" if skipped else "")
        + f", the manifest and {plural(priors, 'prior')}, each with its SHA-256 and reader "
        f"settings; {tail}. Click for every file."
    )


# -- The built-in sections, registered in page order ---------------------------------------------
register_report_section(ReportSection("skipped-trials", "Skipped trials", _skipped_section, 10))
register_report_section(ReportSection("posterior", "Posterior", _posterior_section, 20))
register_report_section(ReportSection("what-pins-what", "What pins what", _pins_section, 30))
register_report_section(ReportSection("priors", "Priors", _priors_section, 40))
register_report_section(
    ReportSection(
        "comparison-with-ideal-bodies-and-the-paper-s-estimator",
        "Comparison with ideal bodies and the paper's estimator",
        _comparison_section,
        50,
    )
)
register_report_section(ReportSection("corner-plots", "Corner plots", _corner_section, 60))
register_report_section(
    ReportSection("identification-curves", "Identification curves", _identification_section, 70)
)
register_report_section(ReportSection("living-joint", "Living joint", _living_section, 80))
register_report_section(ReportSection("trials", "Trials", _trials_section, 90))
register_report_section(ReportSection("speed-effect", "Speed effect", _speed_section, 100))
register_report_section(ReportSection("diagnostics", "Diagnostics", _diagnostics_section, 110))
register_report_section(ReportSection("methods", "Methods", _methods_section, 120))
register_report_section(
    ReportSection(_TRIAL_TABLES_ANCHOR, _TRIAL_TABLES, _trial_tables_section, 130)
)
