"""A Methods section for the paper a result goes into: ``methods.md`` and ``references.bib``.

:func:`methods_sections` writes the text from what a :class:`~inertiafit.report.result.Result`
holds (nothing is recomputed): the protocol as read from the manifest and the trial table
(conditions, bodies, trials per speed, sampling rate), the processing settings (filter, window
rule, lag), each body's prior (:func:`prior_table`), the statistical model, the sampler with the
convergence reached (R-hat and ESS of the posterior), and the software versions.
:func:`methods_markdown` and :func:`methods_html` render it; citations are Pandoc-style
``[@key]`` with their keys in ``references.bib`` (:func:`references_of`).
"""

from __future__ import annotations

import html
import json
import math
import re
from collections.abc import Callable
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit.formatting import plural
from inertiafit.inference.priors import Prior
from inertiafit.physics import PARAMETERS, UNITS
from inertiafit.processing import filtering, window
from inertiafit.processing.study import usable_trials
from inertiafit.report.references import Reference, bibtex, cited, reference_text
from inertiafit.report.result import Result
from inertiafit.report.tables import to_markdown

__all__ = [
    "METHODS_FILES",
    "methods_html",
    "methods_markdown",
    "methods_sections",
    "prior_table",
    "references_of",
    "write_methods",
]

#: The files :func:`write_methods` writes.
METHODS_FILES = ("methods.md", "references.bib")

#: Readable names of the prior parameters.
_NAMES = {
    "mass": "mass m",
    "com_distance": "CoM distance x",
    "radius_of_gyration": "radius of gyration rho",
}


def _and(items: list[str]) -> str:
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


def _attrs_json(result: Result, key: str) -> dict[str, Any]:
    try:
        value = json.loads(result.posterior.attrs.get(key) or "{}")
    except (TypeError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


# -- priors ----------------------------------------------------------------------------------


def prior_table(prior: Prior) -> pd.DataFrame:
    """A body's prior, one row per parameter: distribution, its parameters, bounds, unit."""
    rows = []
    for p in PARAMETERS:
        u = UNITS[p]
        d = prior.distribution.get(p, {})
        kind = prior.kind(p)
        if kind == "uniform":
            what = f"nominal {prior.nominal[p]:.4g} {u}"
        elif kind == "lognormal":
            what = f"median {d['median']:.4g} {u}, SD of log {d['sd_log']:.3g}"
        else:
            what = f"mean {d['mean']:.4g} {u}, SD {d['sd']:.3g} {u}"
        rows.append(
            {
                "parameter": f"{_NAMES[p]} [{u}]",
                "distribution": kind,
                "parameters": what,
                "bounds": f"[{prior.lower[p]:.4g}, {prior.upper[p]:.4g}]",
            }
        )
    return pd.DataFrame(rows)


def _prior_sources(result: Result) -> list[str]:
    """Every source text the result's priors cite (prior files, tables, a passive prior)."""
    texts = [p.source for p in result.priors.values()]
    for prior in result.priors.values():
        table = prior.anthropometric.get("table")
        if table:
            texts.append(_table_citation(table, prior.anthropometric.get("sex")))
    passive = _attrs_json(result, "provenance").get("passive")
    if isinstance(passive, dict) and passive.get("path"):
        texts.append(_passive_text(str(passive["path"])))
    return texts


def _table_citation(name: str, sex: str | None) -> str:
    from inertiafit.errors import InputError
    from inertiafit.inference.anthropometric import resolve_table

    try:
        found = resolve_table(name, sex)
    except InputError:
        return name
    table = found[0]
    return f"{table.citation} {table.spread_source}"


def _passive_text(path: str) -> str:
    """The shipped passive prior of that joint (the file as installed now, by its name)."""
    from inertiafit.errors import InputError
    from inertiafit.io.shipped import passive_prior_path

    try:
        return passive_prior_path(Path(path).stem).read_text(encoding="utf-8")
    except (InputError, OSError):
        return ""


# -- the text --------------------------------------------------------------------------------


def _provenance_trials(result: Result) -> list[dict[str, Any]]:
    trials = _attrs_json(result, "provenance").get("trials", [])
    return [t for t in trials if isinstance(t, dict)] if isinstance(trials, list) else []


def _uses_emg(result: Result) -> bool:
    return any((t.get("reader") or {}).get("emg") for t in _provenance_trials(result))


def _speeds(fast: pd.DataFrame) -> str:
    counts = fast.groupby("speed").size()
    speeds = [f"{s:g}" for s in counts.index]
    if counts.nunique() == 1:
        n = int(counts.iloc[0])
        each = "each of " if len(speeds) > 1 else ""
        return f"{plural(n, 'fast trial')} at {each}{_and(speeds)} °/s"
    return "fast trials at " + _and([f"{s:g} °/s (n = {n})" for s, n in counts.items()])


def _protocol(result: Result) -> list[str]:
    if result.from_numbers:
        return _numbers_protocol(result)
    trials = result.trials
    used = usable_trials(trials)
    bodies = list(result.posterior.bodies)
    paras = [
        (
            f"The study '{result.name}' measured {plural(len(bodies), 'body', 'bodies')} "
            f"({_and(bodies)}) in {plural(len(result.conditions), 'condition')} on an isokinetic "
            f"dynamometer, as in Son et al. [@son_dynamometer]: each condition mounts a set of "
            "bodies on the dynamometer and is moved passively, slowly (quasi-static) for its "
            "gravity moment and fast for its inertia."
        )
    ]
    lines = []
    for label, mounted in result.conditions.items():
        rows = used[used["condition"] == label]
        fast = rows[rows["kind"] == "fast"]
        parts = []
        for kind, word in (("quasi-static", "quasi-static trial"), ("rest", "rest trial")):
            n = int((rows["kind"] == kind).sum())
            if n:
                parts.append(plural(n, word))
        if len(fast):
            parts.append(_speeds(fast))
        lines.append(f"'{label}' ({_and(list(mounted))}): {_and(parts) or 'no trials used'}")
    paras.append("Conditions: " + "; ".join(lines) + ".")
    # an MVC trial (status "reference") is read for its EMG only: not a trial left out; one
    # excluded for muscle activity was read and processed
    status = trials["status"] if "status" in trials else pd.Series("ok", index=trials.index)
    reference = int((status == "reference").sum())
    excluded = int((status == "excluded").sum())
    skipped = len(trials) - len(used) - reference - excluded
    if skipped:
        paras.append(
            f"{plural(skipped, 'trial')} of {len(trials)} could not be read or processed and "
            "were left out (listed in the report)."
        )
    if excluded:
        paras.append(
            f"{plural(excluded, 'trial')} of {len(trials)} showed muscle activity in the EMG "
            "and were excluded from the analysis (listed in the report)."
        )
    if reference:
        paras.append(
            f"{plural(reference, 'maximal voluntary contraction')} gave each muscle's MVC "
            "level (the peak of its EMG envelope); the activity threshold was at least a "
            "fraction of it."
        )
    prov = _provenance_trials(result)
    rates = sorted({float(t["sampling_rate"]) for t in prov if t.get("sampling_rate")})
    formats = sorted({str((t.get("reader") or {}).get("format")) for t in prov} - {"None"})
    recorded = []
    if rates:
        recorded.append("sampled at " + _and([f"{r:g} Hz" for r in rates]))
    if formats:
        recorded.append("read from " + _and(formats) + " files")
    if recorded:
        paras.append(f"The trials were {_and(recorded)}.")
    if _uses_emg(result):
        paras.append(
            "Surface EMG was recorded with the trials to check that the muscles stayed "
            "relaxed (band-pass per SENIAM [@hermens_2000], RMS envelope, onset threshold of "
            "rest mean + k SD [@hodges_bui_1996])."
        )
    return paras


def _numbers_protocol(result: Result) -> list[str]:
    inputs = _attrs_json(result, "inputs")
    body = result.posterior.bodies[0]
    parts = []
    for key, symbol, unit in (("inertia", "I", "kg m^2"), ("gravity_moment", "M_g", "N m")):
        obs = inputs.get(key) or {}
        if "center" not in obs:
            continue
        n = len(obs.get("values") or [])
        df = obs.get("df")
        kind = (
            f"Student-t with {df:g} degrees of freedom"
            if isinstance(df, int | float) and math.isfinite(df)
            else "Gaussian"
        )
        parts.append(
            f"{symbol} = {obs['center']:.4g} {unit} (scale {obs['scale']:.3g} {unit}; {kind}"
            + (f"; {plural(n, 'value')}" if n > 1 else "")
            + ")"
        )
    text = (
        f"The body '{body}' was fitted from reported values rather than trial files: "
        + (_and(parts) if parts else "its inertia and gravity moment")
        + f", with gravity g = {result.gravity:g} m/s^2."
    )
    return [text]


def _processing(result: Result) -> list[str]:
    if result.from_numbers:
        return []
    used = usable_trials(result.trials)
    fast = used[used["kind"] == "fast"]
    paras = [
        (
            f"Torque and angular velocity were low-pass filtered with a zero-lag (forward-backward) "
            f"Butterworth filter of order {filtering.ORDER} and cut-off {filtering.CUTOFF:g} Hz; the "
            "angular acceleration is the derivative of the filtered velocity. The gravity moment "
            "M_g, its phase and an offset of each condition were fitted by least squares to its "
            "quasi-static trial(s), their standard errors corrected for autocorrelated residuals."
        )
    ]
    prov = _provenance_trials(result)
    manual = sum(
        1 for t in prov if t.get("kind") == "fast" and (t.get("reader") or {}).get("window")
    )
    n_fast = max(len(fast), sum(1 for t in prov if t.get("kind") == "fast"))
    rule = (
        "The uniform-acceleration window of each fast trial was found automatically: the "
        "longest stretch of the velocity's rise that follows a straight line within "
        f"{100 * window.TOLERANCE:g} % of its rise and carries the speed through at least "
        f"{100 * window.MIN_SPEED_CHANGE:g} % of the preset speed, ending where the acceleration "
        f"falls to {100 * window.LEVEL:g} % of the line's slope"
    )
    if manual:
        rule += f" ({plural(manual, 'window')} of {n_fast} set by hand in the manifest)"
    if len(fast):
        width = 1000 * (fast["window_end"] - fast["window_start"])
        rule += (
            f"; windows lasted {np.nanmedian(width):.0f} ms (median; range "
            f"{np.nanmin(width):.0f}-{np.nanmax(width):.0f} ms)"
        )
    paras.append(rule + ".")
    if len(fast) and "lag" in fast:
        lag = fast["lag"].astype(float)
        se = fast["lag_se"].astype(float) if "lag_se" in fast else pd.Series(np.nan, fast.index)
        fixed = (se == 0).sum()
        known = lag.notna()
        if known.any():
            text = "The torque channel's lag behind the velocity was removed from every fast trial"
            if fixed == known.sum():
                text += f", fixed by the manifest at {1000 * lag[known].median():.1f} ms."
            else:
                text += (
                    ", estimated per trial within the manifest's bounds "
                    f"(median {1000 * lag[known].median():.1f} ms, range "
                    f"{1000 * lag[known].min():.1f} to {1000 * lag[known].max():.1f} ms)"
                    + (
                        f"; fixed by the manifest for {plural(int(fixed), 'trial')}"
                        if fixed
                        else ""
                    )
                    + "."
                )
            paras.append(text)
    paras.append(
        "The inertia of each fast trial is the least-squares slope of the measured torque minus "
        "the condition's gravity model against the angular acceleration within its window "
        "(I alpha = M - M_g sin(theta + phi) - c)."
    )
    return paras


def _model(result: Result) -> list[str]:
    post = result.posterior
    cd = post.tree["constant_data"]
    paras = [
        "Each body is described by its mass m, the distance x of its centre of mass from the "
        "rotation axis and its radius of gyration rho about the centre of mass. Rotation about "
        "one axis identifies per body only the first moment m·x = M_g/g and the inertia about "
        "the axis I = m (rho^2 + x^2); a condition's observed I and M_g are the sums over its "
        "mounted bodies. The mean inertia of a condition's fast trials enters as a Student-t "
        "likelihood (unknown trial scatter under a Jeffreys prior, n - 1 degrees of freedom), "
        "widened by the error of the condition's gravity model that all its fast trials share; "
        "its quasi-static M_g enters as a Gaussian with its standard error."
        if not result.from_numbers
        else "The body is described by its mass m, the distance x of its centre of mass from "
        "the rotation axis and its radius of gyration rho about the centre of mass; the data "
        "identify only m·x = M_g/g and I = m (rho^2 + x^2), entered with the likelihoods above."
    ]
    extra = []
    for name, label in (
        ("measured_mass", "a weighed mass"),
        ("measured_com_distance", "a balance point"),
    ):
        if name in cd and np.isfinite(np.asarray(cd[name], float)).any():
            extra.append(label)
    if "offset" in cd and np.any(np.asarray(cd["offset"], float) != 0):
        extra.append("a second mounting at another distance from the axis")
    if "added_inertia" in cd and np.any(np.asarray(cd["added_inertia"], float) != 0):
        extra.append("known added masses")
    if extra:
        paras.append(f"Further evidence on the bodies: {_and(extra)}.")
    gain = float(cd["torque_gain_sd"]) if "torque_gain_sd" in cd else 0.0
    paras.append(
        f"The torque channel's gain was given a log-normal uncertainty of {100 * gain:g} % "
        "(one factor on every observed I and M_g)."
        if gain > 0
        else "The torque calibration was taken as exact (no gain uncertainty declared)."
    )
    kinds = sorted({result.priors[b].kind(p) for b in result.priors for p in PARAMETERS})
    paras.append(
        "Priors on (m, x, rho) are independent per parameter ("
        + _and(kinds)
        + "), each bounded by its box; they are listed per body below. Where the data leave a "
        "parameter free along the curve of constant m·x and I, its prior decides it; the "
        "report's identification table gives each quantity's posterior-to-prior SD ratio."
    )
    if result.living:
        paras.append(
            "The living joint adds a passive elastic moment, a hysteresis and a viscous "
            "damping to every trial; their priors come from the shipped passive prior of the "
            "joint, and they are fitted with the gravity model and the inertia."
        )
    return paras


def _sampler(result: Result) -> list[str]:
    post = result.posterior
    a = post.attrs
    summary = post.summary(result.hdi_prob)
    moves = str(a.get("moves", ""))
    how = (
        "a blocked Gibbs sampler (independence Metropolis-Hastings for the shared attachment "
        "and for each body mounted on it)"
        if moves == "blocked"
        else f"the affine-invariant ensemble sampler emcee [@foreman_mackey_emcee_2013] with "
        f"'{moves}' moves"
    )
    para = (
        f"The joint posterior of (log m·x, log I) per body was sampled with {how}, "
        f"{a.get('n_walkers')} walkers for {a.get('n_steps')} steps of which the first "
        f"{a.get('burn')} were dropped as burn-in (seed {a.get('seed')}); the position along "
        "each body's curve of constant m·x and I is drawn exactly given the sampled pair. "
        "Sampling ran until the chain was longer than 50 integrated autocorrelation times "
        "(estimated with emcee [@foreman_mackey_emcee_2013]), the rank-normalised split R-hat "
        f"[@vehtari_rhat_2021] of every quantity was at most {a.get('r_hat_max_target', 1.01):g} "
        f"and its bulk ESS at least {a.get('ess_min_target', 1000):g} (computed with ArviZ "
        "[@kumar_arviz_2019])."
    )
    tau = float(a.get("tau_max", math.nan))
    reached = (
        f"Reached: largest R-hat {summary['r_hat'].max():.3f}, smallest bulk ESS "
        f"{summary['ess_bulk'].min():.0f} and tail ESS {summary['ess_tail'].min():.0f}, "
        f"autocorrelation time at most {tau:.2f} steps, acceptance "
        f"{float(a.get('acceptance', math.nan)):.2f}; "
        + (
            "every criterion was met."
            if post.converged
            else "the criteria were NOT all met: treat the intervals with care."
        )
    )
    intervals = (
        f"Parameters are reported as posterior medians with {100 * result.hdi_prob:g} % "
        "highest-density intervals; the corner plots were drawn with corner "
        "[@foreman_mackey_corner_2016]."
    )
    return [para, reached, intervals]


def _software(result: Result) -> list[str]:
    versions = _attrs_json(result, "versions")
    for pkg in ("matplotlib", "corner"):  # the figures are drawn now, with these
        try:
            versions.setdefault(pkg, version(pkg))
        except PackageNotFoundError:
            continue
    if not versions:
        return ["Software versions were not recorded."]
    first = versions.pop("inertiafit", None)
    listed = ", ".join(f"{k} {v}" for k, v in sorted(versions.items()))
    return [
        (f"inertiafit {first} " if first else "inertiafit ")
        + f"with {listed} (Python packages; the sampling ones as recorded in posterior.nc)."
    ]


def methods_sections(result: Result) -> list[tuple[str, list[str | pd.DataFrame]]]:
    """The Methods text as ``(heading, items)``; an item is a paragraph or a prior table."""
    priors: list[str | pd.DataFrame] = []
    for body, prior in result.priors.items():
        what = f"Prior of '{body}'" + (f": {prior.description}" if prior.description else "")
        priors.append(what + ".")
        priors.append(prior_table(prior))
        if prior.source:
            priors.append(f"Source: {prior.source}.")
    sections: list[tuple[str, list[str | pd.DataFrame]]] = [
        ("Protocol", list(_protocol(result))),
        ("Processing", list(_processing(result))),
        ("Statistical model", list(_model(result))),
        ("Priors", priors),
        ("Sampling and convergence", list(_sampler(result))),
        ("Software", list(_software(result))),
    ]
    return [(h, items) for h, items in sections if items]


def references_of(result: Result) -> list[Reference]:
    """The works the Methods text of ``result`` cites, for ``references.bib``."""
    return cited(_prior_sources(result), emg=_uses_emg(result))


def methods_markdown(result: Result) -> str:
    """``methods.md``: the Methods text with Pandoc citations and the prior tables."""
    lines = [
        f"# Methods: {result.name}",
        "",
        (
            "Generated by inertiafit from this analysis. Citations are Pandoc's `[@...]`; their "
            "entries are in references.bib. Edit freely."
        ),
    ]
    for heading, items in methods_sections(result):
        lines += ["", f"## {heading}", ""]
        for item in items:
            lines.append(to_markdown(item).rstrip() if isinstance(item, pd.DataFrame) else item)
            lines.append("")
    lines += ["## References", ""]
    lines += [f"- [@{r.key}] {reference_text(r)}" for r in references_of(result)]
    return "\n".join(lines).rstrip() + "\n"


_CITE = re.compile(r"\[@([A-Za-z0-9_]+)\]")


def methods_html(result: Result, table_html: Callable[[pd.DataFrame], str]) -> str:
    """The Methods text as an HTML fragment; citations shown as ``(Author year)``."""
    refs = {r.key: r for r in references_of(result)}

    def cite(text: str) -> str:
        escaped = html.escape(text)
        return _CITE.sub(
            lambda m: f"({html.escape(refs[m.group(1)].short)})" if m.group(1) in refs else "",
            escaped,
        )

    parts = []
    for heading, items in methods_sections(result):
        parts.append(f"<h3>{html.escape(heading)}</h3>")
        for item in items:
            parts.append(
                table_html(item)
                if isinstance(item, pd.DataFrame)
                else f"<p class='methods'>{cite(item)}</p>"
            )
    parts.append("<h3>References</h3><ol class='refs'>")
    parts += [f"<li>{html.escape(reference_text(r))}</li>" for r in refs.values()]
    parts.append("</ol>")
    return "\n".join(parts)


def write_methods(folder: str | Path, result: Result) -> list[str]:
    """``methods.md`` and ``references.bib`` into ``folder``; their names."""
    folder = Path(folder)
    (folder / "methods.md").write_text(methods_markdown(result), encoding="utf-8")
    (folder / "references.bib").write_text(bibtex(references_of(result)), encoding="utf-8")
    return list(METHODS_FILES)
