"""Comparison tables as text for the terminal (``inertiafit fit`` and ``inertiafit demo``)."""

from __future__ import annotations

from inertiafit.formatting import interval, number
from inertiafit.report.result import Result

__all__ = [
    "STUDY_TEXT_COLUMNS",
    "fit_comparison_text",
    "study_comparison_text",
    "truth_comparison_text",
]


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
