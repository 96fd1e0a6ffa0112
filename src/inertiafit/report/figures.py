"""The figures of a result, one record each: what the file writer saves and report.html shows.

A figure is a :class:`FigureRecord`: its file stem, the function that draws it, the section of
``report.html`` it appears in, its caption there, and (rarely) the formats it is limited to.
The figures are registered by topic in :data:`FIGURES`: each function registered with
:func:`register_figure` gives its topic's records of a
:class:`~inertiafit.report.result.Result`. :func:`figure_records` lists every topic's, in the
order they were registered; :func:`~inertiafit.report.outputs.write_outputs` saves each record
and :func:`~inertiafit.report.html.study_report` embeds each under its section, so a new figure
is a plot function in :mod:`inertiafit.report.plots` and one registered function (or one record
in a topic here).
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, TypeVar

from inertiafit.processing.study import usable_trials
from inertiafit.report import plots
from inertiafit.report.result import Result, traces_by_condition

__all__ = [
    "FIGURES",
    "FIGURE_SECTIONS",
    "FigureRecord",
    "FigureTopic",
    "figure_records",
    "register_figure",
]

#: The sections of report.html that hold figures, in page order.
FIGURE_SECTIONS = (
    "Posterior",
    "Corner plots",
    "Identification curves",
    "Living joint",
    "Trials",
    "Diagnostics",
)
#: Longest figure stem (UTF-8 bytes): file systems take 255 bytes per name, and the stem gains
#: an extension and, while written, a staging prefix. A condition of four bodies with
#: 64-character names made a 270-byte ``fast-trials-...`` and crashed after sampling.
MAX_STEM_BYTES = 150


def safe_stem(stem: str) -> str:
    """``stem`` itself, or cut to :data:`MAX_STEM_BYTES` with a hash of the whole.

    The cut keeps whole characters and ends in ``-`` and the first 10 hex digits of the full
    stem's SHA-256, so two long names stay apart and the same name always gives the same file.
    """
    raw = stem.encode("utf-8")
    if len(raw) <= MAX_STEM_BYTES:
        return stem
    digest = hashlib.sha256(raw).hexdigest()[:10]
    head = raw[: MAX_STEM_BYTES - len(digest) - 1].decode("utf-8", errors="ignore")
    return f"{head}-{digest}"


@dataclass(frozen=True)
class FigureRecord:
    """One figure of a result.

    Attributes
    ----------
    stem : str
        File name without extension (``corner-attachment`` -> ``corner-attachment.png``);
        one longer than :data:`MAX_STEM_BYTES` is cut (:func:`safe_stem`).
    make : callable
        Draws the figure and returns a new :class:`matplotlib.figure.Figure`.
    section : str
        The section of report.html it is shown in, one of :data:`FIGURE_SECTIONS`.
    caption : str
        Its caption there (also the image's alt text).
    formats : tuple of str, optional
        The only formats it is written in, of those asked for; ``None`` (default): all.
    """

    stem: str
    make: Callable[[], Any]
    section: str
    caption: str
    formats: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "stem", safe_stem(self.stem))
        if self.section not in FIGURE_SECTIONS:
            msg = f"figure {self.stem!r}: section {self.section!r} is not one of {FIGURE_SECTIONS}"
            raise ValueError(msg)

    def formats_of(self, asked: tuple[str, ...]) -> tuple[str, ...]:
        """The formats this figure is written in when ``asked`` are."""
        return asked if self.formats is None else tuple(f for f in asked if f in self.formats)


#: A function giving one topic's figures of a result (none when the result has nothing to show).
FigureTopic = Callable[[Result], Iterable[FigureRecord]]
_F = TypeVar("_F", bound=FigureTopic)

#: The figures of a result by topic, in registration order (:func:`register_figure`): the
#: order :func:`figure_records` lists them in, so the order report.html shows a section's.
FIGURES: dict[str, FigureTopic] = {}


def register_figure(name: str) -> Callable[[_F], _F]:
    """Register a function giving the figures of topic ``name`` of a result (a decorator).

    The function takes a :class:`~inertiafit.report.result.Result` and returns (or yields) the
    topic's records (:class:`FigureRecord`), none when the result has nothing to show; every
    :func:`figure_records` call then lists them after the topics registered before it. Each
    record draws only when called, through a picklable function (a module-level function or
    a :func:`functools.partial` of one): the figures may be drawn in worker processes.

    Raises
    ------
    ValueError
        When a topic of that name is registered already.
    """

    def decorator(func: _F) -> _F:
        if name in FIGURES:
            msg = f"figures {name!r} are registered already"
            raise ValueError(msg)
        FIGURES[name] = func
        return func

    return decorator


def figure_records(result: Result) -> list[FigureRecord]:
    """Every figure of ``result``: each topic's of :data:`FIGURES`, in registration order.

    Each record draws its figure only when called: drawing one figure at a time, saving and
    dropping it, keeps one figure in memory rather than all of them.
    """
    return [record for figures in FIGURES.values() for record in figures(result)]


@register_figure("intervals")
def _intervals_figures(result: Result) -> list[FigureRecord]:
    """The first figure: every body's quantities, posterior against prior."""
    post = result.posterior
    pct = f"{100 * result.hdi_prob:g}%"
    records: list[FigureRecord] = []
    add = records.append
    add(
        FigureRecord(
            "intervals",
            functools.partial(plots.plot_intervals, post, result.hdi_prob),
            "Posterior",
            f"Every body's m, x, rho, I and M_g: the posterior's {pct} HDI (dot: median) over "
            f"the prior's central {pct} interval (grey), both divided by the prior's median on "
            "a log axis; colour and marker say who decides each, as the identification table's "
            "'identified by' does (blue: data; orange: data + prior; vermillion: prior); on the "
            "right the posterior median and HDI in SI units",
        )
    )
    return records


@register_figure("corner")
def _corner_figures(result: Result) -> list[FigureRecord]:
    """Each body's corner plot, and all bodies' together when there are several."""
    post = result.posterior
    records: list[FigureRecord] = []
    add = records.append
    for body in post.bodies:
        add(
            FigureRecord(
                "corner" if result.from_numbers else f"corner-{body}",
                functools.partial(
                    post.corner,
                    body,
                    truths=result.truths.get(body) or None,
                    ideal=result.ideals.get(body) or None,
                ),
                "Corner plots",
                f"{body}: axes zoomed to the posterior; shaded: the prior box; grey: the prior"
                + _lines(result, body),
            )
        )
    if len(post.bodies) > 1:
        add(
            FigureRecord(
                "corner-joint",
                functools.partial(
                    plots.plot_joint_corner,
                    post,
                    truths=result.truths or None,
                    ideals=result.ideals or None,
                ),
                "Corner plots",
                "all bodies together",
            )
        )
    return records


@register_figure("identification")
def _identification_figures(result: Result) -> list[FigureRecord]:
    """Each body's identification curve."""
    post = result.posterior
    records: list[FigureRecord] = []
    add = records.append
    for body in post.bodies:
        add(
            FigureRecord(
                f"identification-{body}",
                functools.partial(
                    plots.plot_identification_curve,
                    post,
                    body,
                    baseline=result.baselines.get(body),
                ),
                "Identification curves",
                f"{body}: posterior draws, the curve at the posterior medians, the prior box "
                "and the paper's per-start solutions",
            )
        )
    return records


@register_figure("living")
def _living_figures(result: Result) -> list[FigureRecord]:
    """A living joint's passive curve and static fit."""
    records: list[FigureRecord] = []
    add = records.append
    if result.living:
        add(
            FigureRecord(
                "passive-curve",
                functools.partial(plots.plot_passive_curve, result.living["passive_curve"]),
                "Living joint",
                "the joint's passive elastic moment (median, 95% band, prior band) and the "
                "gravity moment beside it, both relative to the middle of the swept range",
            )
        )
        if "static_fit" in result.living:
            add(
                FigureRecord(
                    "static-fit",
                    functools.partial(
                        plots.plot_static_fit,
                        result.living["static_fit"],
                        result.living["passive_curve"],
                    ),
                    "Living joint",
                    "the quasi-static and rest trials against the fitted static moment of "
                    "each posture (95% band), and the residuals: what the fit of gravity and "
                    "the passive curve left in each trial",
                )
            )
    return records


@register_figure("trials")
def _trials_figures(result: Result) -> list[FigureRecord]:
    """The trials: fast trials, gravity fits, torque against acceleration, EMG, inertia by speed."""
    records: list[FigureRecord] = []
    add = records.append
    if len(result.trials):
        for cond, traces in traces_by_condition(result.traces).items():
            if any("deceleration" in t for t in traces):  # a living body's: I and b together
                draw = functools.partial(plots.plot_living_fast_trials, traces, title=cond)
                windows = (
                    "shaded: the detected uniform-acceleration window; hatched: the "
                    "uniform-deceleration window, over which the inertia and the viscous "
                    "damping were fitted with it"
                )
            else:
                draw = functools.partial(plots.plot_fast_trials, traces, title=cond)
                windows = "shaded: the detected uniform-acceleration window"
            add(
                FigureRecord(
                    f"fast-trials-{cond}",
                    draw,
                    "Trials",
                    f"{cond}: filtered velocity and acceleration of the fast trials; {windows}",
                )
            )
        if len(result.sweeps):
            add(
                FigureRecord(
                    "gravity-fit",
                    functools.partial(plots.plot_gravity_fit, result.sweeps, result.trials),
                    "Trials",
                    "each quasi-static sweep (dots: means of consecutive samples of the move) "
                    "against its fitted gravity model M_g sin(θ + φ) + c (line; trials.csv), "
                    "and the residuals, measured minus fitted: a wave or a trend left in them "
                    "is what the model does not describe (friction building up at a sweep's "
                    "start, a cable pulling, drift)",
                )
            )
        for cond, traces in traces_by_condition(result.traces).items():
            fitted = _with_inertias(traces, result.trials, cond)
            if not fitted:
                continue
            decel = any("deceleration" in t for t in fitted)
            add(
                FigureRecord(
                    f"tau-alpha-{cond}",
                    functools.partial(plots.plot_tau_alpha, fitted, title=cond),
                    "Trials",
                    f"{cond}: each fast trial's torque less its condition's "
                    + ("static curve, damping and constant" if decel else "gravity model")
                    + " against its acceleration, over the "
                    + (
                        "acceleration window (filled) and the deceleration window (open) "
                        if decel
                        else "acceleration window "
                    )
                    + "the inertia was fitted over; the line's slope is the trial's inertia "
                    "(trials.csv)",
                )
            )
        emg = result.emg_traces
        for cond, rows in emg.groupby("condition", sort=False) if len(emg) else ():
            excluded = rows.loc[rows["status"] == "excluded", "trial"].nunique()
            add(
                FigureRecord(
                    f"emg-{cond}",
                    functools.partial(plots.plot_emg_envelopes, rows, title=str(cond)),
                    "Trials",
                    f"{cond}: EMG envelopes of the fast trials over the rest level, the "
                    f"threshold dashed; {excluded} trial(s) excluded for muscle activity, "
                    "their active stretches shaded",
                )
            )
        used = usable_trials(result.trials)  # a skipped trial has no inertia to draw
        fast = used[used["kind"] == "fast"]
        if len(fast):
            add(
                FigureRecord(
                    "inertia-by-speed",
                    functools.partial(plots.plot_inertia_by_speed, fast),
                    "Trials",
                    "inertia per trial and speed (mean ± SD)",
                )
            )
    return records


@register_figure("diagnostics")
def _diagnostics_figures(result: Result) -> list[FigureRecord]:
    """Each body's walker traces and rank plots."""
    post = result.posterior
    records: list[FigureRecord] = []
    add = records.append
    for body in post.bodies:
        add(
            FigureRecord(
                f"trace-{body}",
                functools.partial(plots.plot_trace, post, body),
                "Diagnostics",
                f"{body}: walker traces",
            )
        )
        add(
            FigureRecord(
                f"rank-{body}",
                functools.partial(plots.plot_rank, post, body),
                "Diagnostics",
                f"{body}: rank plots",
            )
        )
    return records


def _with_inertias(traces: list[dict], trials: Any, condition: str) -> list[dict]:
    """A condition's traces with each trial's inertia from ``trials.csv``; ``[]`` if unmatched.

    The traces are the condition's used fast trials in manifest order, as its usable rows of
    ``trials.csv`` are; each pair must share its acceleration window, or nothing is drawn
    (a table edited by hand, or one written before the fitted torque was stored).
    """
    if not all("inertial_torque" in t for t in traces):
        return []
    used = usable_trials(trials)
    rows = used[(used["kind"] == "fast") & (used["condition"].astype(str) == condition)]
    if len(rows) != len(traces):
        return []
    out = []
    for trace, (_, row) in zip(traces, rows.iterrows(), strict=True):
        same = all(
            abs(float(trace["window"][i]) - float(row[c])) <= 1e-9 * max(1.0, abs(float(row[c])))
            for i, c in enumerate(("window_start", "window_end"))
        )
        if not same:
            return []
        out.append({**trace, "inertia": float(row["inertia"])})
    return out


def _lines(result: Result, body: str) -> str:
    """What the lines of a body's corner plot are, for its caption."""
    said = []
    if body in result.truths:
        said.append("the simulation's truth (solid)")
    if body in result.ideals:
        said.append("the ideal body (dashed)")
    return "; lines: " + " and ".join(said) if said else ""
