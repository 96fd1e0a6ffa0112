"""Comparison tables as text for the terminal (``inertiafit fit`` and ``inertiafit demo``)."""

from __future__ import annotations

import math

import pandas as pd

from inertiafit.formatting import interval, mean_sd, number
from inertiafit.report.result import Result

__all__ = [
    "STUDY_TEXT_COLUMNS",
    "diagnostics_text",
    "fit_comparison_text",
    "study_comparison_text",
    "truth_comparison_text",
]

#: Characters of a trial's note (its flags, or why it was refused) shown in
#: :func:`diagnostics_text`; ``diagnostics.csv`` holds them whole.
NOTE_CHARS = 110


def fit_comparison_text(result: Result) -> str:
    """One body fitted from numbers: prior nominal, posterior, paper's baseline, reference."""
    table = result.comparison
    prior = result.priors[result.posterior.bodies[0]]
    ref_label = prior.reference.get("label", "reference")
    pct = f"{100 * result.hdi_prob:g}% HDI"
    lines = [
        (
            f"{'parameter':<28}{'prior nominal':>14}{'posterior median':>18}  {pct:<22}"
            f"{'paper baseline':>15}  {ref_label}"
        )
    ]
    for _, r in table.iterrows():
        name = f"{r.parameter} [{r.unit}]"
        hdi = interval(r.hdi_lower, r.hdi_upper)
        ref = number(r.reference)
        lines.append(
            f"{name:<28}{r.prior_nominal:>14.4g}{r.posterior_median:>18.4g}  {hdi:<22}"
            f"{r.baseline:>15.4g}  {ref}"
        )
    return "\n".join(lines)


#: Columns the demo prints of a study's comparison table.
STUDY_TEXT_COLUMNS = [
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


def study_comparison_text(result: Result) -> str:
    """A study's bodies beside their ideal models and the paper's baseline."""
    table = result.comparison[STUDY_TEXT_COLUMNS]
    return (
        table.to_string(index=False, float_format=number)
        + "\n(ideal: textbook body; baseline: the paper's multi-start least squares)"
    )


def diagnostics_text(table: pd.DataFrame) -> str:
    """A refused study's per-trial table for the terminal (``diagnostics.csv`` in short).

    A row per trial: file, condition, kind, speed (deg/s), ``I`` and ``M_g`` with their
    standard errors, status and a note — why it was refused, else its flags — cut at
    :data:`NOTE_CHARS` characters.
    """

    def value(row: dict, key: str) -> str:
        v, se = row.get(key), row.get(f"{key}_se")
        if not isinstance(v, int | float) or math.isnan(v):
            return ""
        if isinstance(se, int | float) and math.isfinite(se):
            return mean_sd(v, se)
        return f"{v:.4g}"

    header = ["file", "condition", "kind", "speed", "I (kg m^2)", "M_g (N m)", "status", "note"]
    lines = [header]
    for row in table.to_dict(orient="records"):
        note = row.get("cause") or row.get("flags")
        note = note if isinstance(note, str) else ""
        if len(note) > NOTE_CHARS:
            note = note[: NOTE_CHARS - 3] + "..."
        lines.append(
            [
                str(row["file"]),
                str(row["condition"]),
                str(row["kind"]),
                number(row.get("speed")),
                value(row, "inertia"),
                value(row, "gravity_moment"),
                str(row.get("status") or ""),
                note,
            ]
        )
    widths = [max(len(line[i]) for line in lines) for i in range(len(header) - 1)]
    return "\n".join(
        "  ".join([*(c.ljust(w) for c, w in zip(line, widths, strict=False)), line[-1]]).rstrip()
        for line in lines
    )


def truth_comparison_text(result: Result) -> str:
    """A simulated study's bodies: the truth beside the posterior, and whether the HDI holds it.

    Empty when the result has no :attr:`~inertiafit.report.result.Result.truths`. The ideal
    (textbook) bodies are another question (:func:`study_comparison_text`): a simulation's truth
    may differ from them on purpose.
    """
    if not result.truths:
        return ""
    table = result.comparison.set_index(["body", "parameter"])
    pct = f"{100 * result.hdi_prob:g}% HDI"
    lines = [
        (
            f"{'body':<12}{'parameter':<28}{'truth':>10}{'posterior median':>18}  {pct:<24}"
            f"{'error':>8}  covered"
        )
    ]
    for body, values in result.truths.items():
        for parameter, true in values.items():
            if (body, parameter) not in table.index:
                continue
            r = table.loc[(body, parameter)]
            name = f"{parameter} [{r.unit}]"
            error = 100 * (r.posterior_median - true) / true
            inside = r.hdi_lower <= true <= r.hdi_upper
            lines.append(
                f"{body:<12}{name:<28}{true:>10.4g}{r.posterior_median:>18.4g}  "
                f"{interval(r.hdi_lower, r.hdi_upper):<24}{error:>+7.1f}%  "
                + ("yes" if inside else "NO")
            )
    return "\n".join(lines) + "\n(truth: the values the trials were simulated with)"
