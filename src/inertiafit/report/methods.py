"""A Methods section for the paper a result goes into: ``methods.md`` and ``references.bib``.

:func:`methods_sections` writes the text from what a :class:`~inertiafit.report.result.Result`
holds (nothing is recomputed): the protocol as read from the manifest and the trial table
(conditions, bodies, trials per speed, sampling rate), the processing settings (filter, window
rule, lag), each body's prior (:func:`prior_table`), the statistical model, a living joint's
terms with their priors and sources (:func:`living_text`), the sampler with the convergence
reached (R-hat and ESS of the posterior), and the software versions.
:func:`methods_markdown` and :func:`methods_html` render it; citations are Pandoc-style
``[@key]`` or ``[@a; @b]``, each where the work is used (a quoted source with the works it
names), and ``references.bib`` holds exactly the works the text cites (:func:`references_of`).
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

from inertiafit.formatting import ess, interval, mean_sd, plural, r_hat
from inertiafit.inference.priors import Prior
from inertiafit.inference.terms import TERM_KINDS
from inertiafit.physics import PARAMETERS, UNITS
from inertiafit.processing import filtering, living, window
from inertiafit.processing.study import usable_trials
from inertiafit.report.references import (
    REFERENCES,
    Reference,
    bibtex,
    citations,
    cite,
    reference_text,
)
from inertiafit.report.result import Result
from inertiafit.report.tables import to_markdown

__all__ = [
    "METHODS_FILES",
    "living_text",
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
                "bounds": interval(prior.lower[p], prior.upper[p]),
            }
        )
    return pd.DataFrame(rows)


def _sourced(text: str) -> str:
    """A source text with a citation of every work it names: ``text [@key; ...]``."""
    keys = citations(text)
    return f"{text} {cite(keys)}" if keys else text


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
        muscles = sorted(
            {str(m) for t in prov for m in ((t.get("reader") or {}).get("emg") or [])}
        )
        paras.append(
            f"Surface EMG of {_and(muscles) or 'the muscles'} was recorded with the trials to "
            "check that the muscles stayed relaxed: band-pass filtered per SENIAM "
            "[@hermens_2000], an RMS envelope, and an onset threshold of the envelope's rest "
            "mean + k SD held for a minimum time [@hodges_bui_1996]; a trial active in the "
            "windows checked was excluded, flagged or stopped the study, as the manifest's "
            "[emg] on_activity says."
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
        f"The body '{body}' was fitted from reported values rather than trial files (its "
        "inertia and gravity moment about the axis, as a dynamometer measures them by the "
        "method of Son et al. [@son_dynamometer]): "
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
    paras += _evidence(post.tree)
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
    return paras


def _evidence(tree) -> list[str]:
    """What every kind of term says of its evidence in the tree (:meth:`Term.methods`).

    One paragraph lists the phrases, direct measurements first (each in the registry's order),
    each phrase once; the kinds' own sentences follow it, with their citations.
    """
    said = [text for kind in TERM_KINDS.values() for text in kind.methods(tree)]
    said.sort(key=lambda t: not t.measures)  # stable: the registry's order within each
    phrases: list[str] = []
    sentences: list[str] = []
    for t in said:
        cited = f" {cite(t.cite)}" if t.cite else ""
        sentence = t.sentence.rstrip(".") + cited + "." if t.sentence else ""
        phrase = t.phrase + ("" if sentence else cited)
        if sentence and sentence not in sentences:
            sentences.append(sentence)
        if phrase and phrase not in phrases:
            phrases.append(phrase)
    return ([f"Further evidence on the bodies: {_and(phrases)}."] if phrases else []) + sentences


# -- a living joint ----------------------------------------------------------------------------

#: Each joint's angle convention, as the passive prior files state it.
_FLEXION = {"ankle": "plantarflexion positive, 0 = neutral"}
#: The other joints' angles at which a literature curve is taken (:mod:`inertiafit.passive`).
_CURVE_POSE = {"knee": "the hip flexed 90° and the ankle neutral", "ankle": "the knee flexed 90°"}


class _PassivePrior:
    """The living joint's prior as run: each entry's value and its source.

    From the posterior's provenance (``passive.prior``, the ``[passive]`` table merged into the
    shipped file); for a posterior written before it was recorded there, the shipped file as
    installed now, with the joint fit's own prior means and SDs (which hold the manifest's
    overrides) and ``"manifest"`` as the source of any that differ from the file's.
    """

    def __init__(self, result: Result) -> None:
        record = _attrs_json(result, "provenance").get("passive") or {}
        self.record: dict[str, Any] = record.get("prior") or {}
        self.postures: dict[str, Any] = record.get("postures") or {}
        joint = self.record.get("joint") or (Path(str(record.get("path", ""))).stem or "generic")
        self.joint = str(joint)
        self.shipped: dict[str, Any] = {}
        from inertiafit.errors import InputError
        from inertiafit.io.shipped import load_passive_prior

        try:
            self.shipped = load_passive_prior(self.joint)
        except InputError:  # an unknown joint, a file gone or broken: the table's numbers stand
            self.shipped = {}
        table = result.living.get("passive_parameters")
        self.table = (
            table.set_index("parameter") if table is not None and len(table) else pd.DataFrame()
        )

    def value(self, key: str) -> Any:
        """The entry as run: ``(mean, sd)``, a number or ``(lo, hi)``; ``None`` if unknown."""
        if key in self.record and self.record[key] is not None:
            return self.record[key]
        if key in self.table.index and np.isfinite(self.table.loc[key, "prior_sd"]):
            return (
                float(self.table.loc[key, "prior_mean"]),
                float(self.table.loc[key, "prior_sd"]),
            )
        entry = self.shipped.get(key)
        return entry["value"] if isinstance(entry, dict) else None

    def source(self, key: str) -> str:
        """Where the entry's number comes from, with a citation of each work it names."""
        sources = self.record.get("sources") or {}
        text = sources.get(key)
        if text is None:
            entry = self.shipped.get(key)
            shipped = entry if isinstance(entry, dict) else {}
            same = shipped.get("value") is not None and np.allclose(
                np.asarray(shipped["value"], float), np.asarray(self.value(key), float)
            )
            text = shipped.get("source", "manifest") if same else "manifest"
        if text == "manifest":
            return "set in the study's manifest ([passive])"
        if not self.record and key not in self.table.index:
            text = (
                f"{text}; as the prior file gives it, which this posterior.nc does not "
                "record whether the manifest overrode"
            )
        return _sourced(str(text))

    def normal(self, key: str, unit: str) -> str:
        """``N(mean, SD) unit (source)`` of a normal entry."""
        value = self.value(key)
        if value is None:
            return "(prior not recorded)"
        mean, sd = (float(v) for v in value)
        shown = f" {unit}" if unit else ""
        return f"N({mean:.3g}, {sd:.3g}){shown} ({self.source(key)})"

    def estimate(self, key: str, unit: str) -> str:
        """The joint fit's ``mean ± SD unit`` of a parameter, or ``""``."""
        if key not in self.table.index:
            return ""
        row = self.table.loc[key]
        space = "" if unit in ("", "°") else " "
        return f"{mean_sd(float(row['mean']), float(row['sd']), 3)}{space}{unit}"


def _living_fit(result: Result) -> Any:
    """The joint fit's dataset in ``posterior.nc`` (``living/fit``), or ``None``."""
    try:
        return result.posterior.tree[f"{living.LIVING_GROUP}/fit"].to_dataset()
    except KeyError:
        return None


def living_text(result: Result) -> list[str]:
    """The Methods paragraphs of a living body: each term of the joint, its prior and source.

    The passive elastic moment ``P`` (its nonparametric prior and the literature curve it is
    centred on), the hysteresis ``h``, the viscous damping ``b``, each posture's rotation of
    gravity ``r_p`` and what told ``M_g`` from ``P``, the rest holds and the fit's check of its
    trials, as the result holds them; empty for a rigid study.
    """
    if not result.living or "passive_parameters" not in result.living:
        return []
    prior = _PassivePrior(result)
    table = prior.table
    joint = prior.joint
    body = str(table["body"].iloc[0]) if "body" in table and len(table) else "the living body"
    zero = prior.record.get("joint_angle_at_zero")
    fit = _living_fit(result)
    curve = str(
        prior.record.get("curve") or (fit.attrs.get("curve") if fit is not None else "smooth")
    )
    angle = (
        f"theta_j = theta + {float(zero):g}°" if zero is not None else "theta_j the joint angle"
    )
    convention = _FLEXION.get(joint, "flexion positive, 0 = full extension")
    paras = [
        (
            f"'{body}' is a living segment on its {joint} joint, which resists being moved: in "
            "every condition that mounts it, the moment the dynamometer applies is "
            "tau = I alpha + M_g sin(theta + phi + r_p) + c + P(theta_j) + b omega + "
            f"h(theta_j) sgn(omega), with {angle} ({convention}). Beyond the rigid body's terms "
            "these are the passive elastic moment P, the viscous damping b, the hysteresis h and "
            "the rotation r_p of gravity in posture p; muscle activity is kept out by the "
            "protocol (and the EMG check, where EMG was recorded). Their priors are the joint's "
            f"shipped passive prior (priors/passive/{joint}.toml) with the manifest's [passive] "
            "entries in its place; each is given below with its source."
        )
    ]

    # P: the literature curve it is centred on, and the smooth part around it
    stops = prior.value("range")
    width = prior.value("stop_width")
    spring = f"a linear spring k (theta_j - theta_rel), k ~ {prior.normal('stiffness', 'N m/rad')}"
    if stops is not None and width is not None:
        lo, hi = (float(v) for v in stops)
        ends = (
            f"exponential end stops at the range ends {lo:g}° and {hi:g}° "
            f"({prior.source('range')}), each stop's moment there "
            f"~ {prior.normal('stop_moment', 'N m')}, fitted as two exponentials "
            f"{float(width) / math.sqrt(2):.3g}° and {float(width) * math.sqrt(2):.3g}° wide "
            f"about an e-folding width of {float(width):g}° ({prior.source('stop_width')})"
        )
    else:
        ends = "exponential end stops at the ends of the joint's range"
    if joint in _CURVE_POSE:
        mean_curve = (
            f"the literature curve s P0(theta_j), P0 Riener & Edrich's passive {joint} moment "
            f"{cite(['riener_edrich_1999'])} with {_CURVE_POSE[joint]} (the device's moment: "
            f"their tissue moment negated), its scale s ~ {prior.normal('curve_scale', '')}; "
            f"plus {spring}; plus {ends}"
        )
    else:
        mean_curve = f"{spring}; plus {ends} (the {joint} has no published passive curve to scale)"
    if curve == "smooth":
        n = (
            sum(str(c).startswith("smooth:") for c in fit["coefficient"].values)
            if fit is not None
            else 0
        )
        basis = f"{n} sine eigenfunctions" if n else "sine eigenfunctions"
        amplitude = prior.estimate("smooth_amplitude", "N m")
        length = prior.estimate("smooth_length", "°")
        found = (
            f" (posterior: amplitude {amplitude}, length-scale {length})"
            if amplitude and length
            else ""
        )
        p_text = (
            "Passive elastic moment P(theta_j): a nonparametric prior, a Gaussian process in the "
            "joint angle (squared-exponential kernel) around the mean curve of the joint's "
            f"prior: {mean_curve}. The process is approximated by {basis} of the Laplacian on "
            f"{living.SMOOTH_BOUNDARY:g} times the swept half range [@solin_sarkka_2020], "
            "their number set by the rule of Riutort-Mayol et al. [@riutort_mayol_2023] "
            f"(at least {living.SMOOTH_FUNCTIONS[0]}, at most {living.SMOOTH_FUNCTIONS[1]}); "
            "its amplitude "
            f"({min(living.SMOOTH_AMPLITUDES):g}-{max(living.SMOOTH_AMPLITUDES):g} N m) and "
            f"length-scale ({min(living.SMOOTH_LENGTHS_DEG):g}-"
            f"{max(living.SMOOTH_LENGTHS_DEG):g}°) have log-uniform hyperpriors on a grid, "
            f"integrated over by each point's evidence{found}."
        )
    else:
        p_text = (
            "Passive elastic moment P(theta_j): the mean curve of the joint's prior alone (the "
            f'manifest\'s [passive] curve = "fixed"): {mean_curve}.'
        )
    paras.append(
        p_text + " The spring's relaxed angle theta_rel is not identified: the offset c "
        "absorbs it, and P is shown relative to its value at mid-range."
    )

    # h
    h = prior.estimate("hysteresis", "N m")
    shape = (
        " Its change over the range is a Gaussian process on the same basis, of amplitude the "
        f"prior's SD and length-scale {living.HYSTERESIS_LENGTH_DEG:g}°."
        if curve == "smooth"
        else ""
    )
    paras.append(
        "Hysteresis h sgn(omega): a moment against the direction of motion, which sweeps in "
        f"both directions separate from P; h ~ {prior.normal('hysteresis', 'N m')}.{shape}"
        + (f" Fitted: h = {h}." if h else "")
    )

    # b
    b_row = table.loc["damping"] if "damping" in table.index else None
    trials = usable_trials(result.trials)
    living_conds = {c for c, bodies in result.conditions.items() if body in bodies}
    fast = trials[(trials["kind"] == "fast") & trials["condition"].isin(living_conds)]
    b_text = f"Viscous damping b omega: b ~ {prior.normal('damping', 'N m s/rad')}. "
    if b_row is not None and str(b_row["pinned_by"]).startswith("prior"):
        b_text += (
            "No fast trial moved the living body, so b is its prior (a slow sweep's b omega "
            "is within its hysteresis)."
        )
    else:
        b_text += (
            f"Each of the {plural(len(fast), 'fast trial')} of the living conditions gives b "
            "with its inertia: least squares of I alpha + b omega + c_t over its "
            "uniform-acceleration window and its uniform-deceleration window together (in "
            "the deceleration the acceleration changes sign while the speed does not, which "
            "tells b omega from I alpha; c_t is the trial's own constant)"
            + (f"; b = {prior.estimate('damping', 'N m s/rad')}" if b_row is not None else "")
            + "."
        )
    paras.append(b_text)

    # r_p, and what told M_g from P
    rotations = [p for p in table.index if str(p).startswith("rotation:")]
    if rotations:
        parts = []
        for k, key in enumerate(rotations):
            name = str(key).removeprefix("rotation:")
            declared = prior.postures.get(name) or {}
            said = []
            if "gravity_rotation" in declared:
                said.append(f"nominal {float(declared['gravity_rotation']):g}°")
            sd = declared.get("gravity_rotation_sd")
            if k == 0:
                said.append("the reference")
            elif sd == "free":
                said.append("free (a flat prior)")
            elif sd is not None:
                said.append(f"prior SD {float(sd):g}° per posture")
            if float(declared.get("axis_tilt", 0.0) or 0.0):
                said.append(f"axis tilted {float(declared['axis_tilt']):g}°")
            fitted = prior.estimate(str(key), "°") if k else ""
            if fitted:
                said.append(f"fitted {fitted}")
            parts.append(f"'{name}'" + (f" ({', '.join(said)})" if said else ""))
        paras.append(
            "Postures: "
            + "; ".join(parts)
            + ". A second posture rotates gravity by r_p and not the passive curve (the joint "
            "moves through the same angles), which tells M_g from P; a posture whose axis is "
            "tilted 90° (motion in the horizontal plane) has no gravity moment. Each rotation "
            "beside the reference's has a Gaussian prior of the declared SDs."
        )
    else:
        paras.append(
            "One posture: gravity and P are told apart on its sweeps by the passive prior only."
        )
    for key in (p for p in table.index if str(p).startswith("gravity_moment:")):
        row = table.loc[key]
        cond = str(key).removeprefix("gravity_moment:")
        leverage = float(row["prior_leverage"])
        grows = (
            f" (its SE grows {leverage:.2f}x when the passive prior's SDs double)"
            if math.isfinite(leverage)
            else ""
        )
        paras.append(
            f"M_g of '{cond}' = {mean_sd(float(row['mean']), float(row['sd']))} N m from the "
            f"joint fit, told from the passive curve by {row['pinned_by'] or 'the prior'}"
            f"{grows}."
        )

    # rest holds, the joint fit and its check
    rest = int(((trials["kind"] == "rest") & trials["condition"].isin(living_conds)).sum())
    sweeps = int(
        ((trials["kind"] == "quasi-static") & trials["condition"].isin(living_conds)).sum()
    )
    flagged = int(np.asarray(fit["flagged"]).sum()) if fit is not None and "flagged" in fit else 0
    paras.append(
        f"The {plural(sweeps, 'quasi-static sweep')}"
        + (
            f" and {plural(rest, 'rest hold')} (quiet holds, each a point of the static moment "
            "within the band ±h a joint at rest may hold, with its own offset inside it)"
            if rest
            else ""
        )
        + " of the living conditions were fitted together as one Bayesian linear regression: "
        "the gravity moment of each condition, an offset per condition and posture, and the "
        "coefficients above with their Gaussian priors, which are integrated out analytically "
        "(the rotations by Gauss-Newton, a Laplace approximation). Each fast trial of a living "
        "condition subtracts the fitted static moment of its posture and direction, the fit's "
        "error carried into its inertia. Each sweep's residual smoothed over its angles by "
        f"Legendre polynomials of degrees 2 to {living.CHECK_DEGREE} is structure the model "
        f"left when its RMS exceeds {living.CHECK_TOLERANCE:g} N m and "
        f"{living.CHECK_RATIO:g} times the trial's white noise in the same projection; "
        + (f"{plural(flagged, 'trial')} showed it." if flagged else "no trial showed it.")
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
        f"Reached: largest R-hat {r_hat(summary['r_hat'].max())}, smallest bulk ESS "
        f"{ess(summary['ess_bulk'].min())} and tail ESS {ess(summary['ess_tail'].min())}, "
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
            priors.append(f"Source: {_sourced(prior.source.rstrip('.'))}.")
    sections: list[tuple[str, list[str | pd.DataFrame]]] = [
        ("Protocol", list(_protocol(result))),
        ("Processing", list(_processing(result))),
        ("Statistical model", list(_model(result))),
        ("Living joint", list(living_text(result))),
        ("Priors", priors),
        ("Sampling and convergence", list(_sampler(result))),
        ("Software", list(_software(result))),
    ]
    return [(h, items) for h, items in sections if items]


#: A Pandoc citation of one or more keys: ``[@a]``, ``[@a; @b]``.
_CITE = re.compile(r"\[(@[A-Za-z0-9_]+(?:; @[A-Za-z0-9_]+)*)\]")


def _cited_keys(text: str) -> list[str]:
    return [k.lstrip("@") for m in _CITE.finditer(text) for k in m.group(1).split("; ")]


def references_of(result: Result) -> list[Reference]:
    """The works the Methods text of ``result`` cites, for ``references.bib``.

    Exactly the keys cited in the text (:func:`methods_sections`), in the order of
    :data:`~inertiafit.report.references.REFERENCES`: a work is listed because the text cites
    it where it is used, and every work cited is listed.
    """
    keys = {
        k
        for _, items in methods_sections(result)
        for item in items
        if isinstance(item, str)
        for k in _cited_keys(item)
    }
    return [r for k, r in REFERENCES.items() if k in keys]


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


def methods_html(result: Result, table_html: Callable[[pd.DataFrame], str]) -> str:
    """The Methods text as an HTML fragment; citations shown as ``(Author year)``."""
    refs = {r.key: r for r in references_of(result)}

    def shown(text: str) -> str:
        escaped = html.escape(text)

        def one(m: re.Match[str]) -> str:
            keys = [k.lstrip("@") for k in m.group(1).split("; ")]
            return "(" + "; ".join(html.escape(refs[k].short) for k in keys if k in refs) + ")"

        return _CITE.sub(one, escaped)

    parts = []
    for heading, items in methods_sections(result):
        parts.append(f"<h3>{html.escape(heading)}</h3>")
        for item in items:
            parts.append(
                table_html(item)
                if isinstance(item, pd.DataFrame)
                else f"<p class='methods'>{shown(item)}</p>"
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
