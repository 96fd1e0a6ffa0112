"""Comparison tables as text for the terminal (``inertiafit fit`` and ``inertiafit demo``)."""

from __future__ import annotations

from inertiafit.formatting import interval, number
from inertiafit.report.result import Result

__all__ = ["STUDY_TEXT_COLUMNS", "fit_comparison_text", "study_comparison_text"]


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
