"""Text and HTML display of a :class:`~inertiafit.posterior.Posterior`.

:func:`text_report` is what ``print(post)`` and the command line show; :func:`html_table` is
the Jupyter display. Both read the posterior's summary, identification and correlation tables,
its "what pins what" lines and, for a study, how many of its trials went into the evidence.
"""

from __future__ import annotations

import html
import json
import math
from collections import Counter
from typing import TYPE_CHECKING, Any, Protocol

from inertiafit.formatting import (
    correlation,
    ess,
    interval,
    plural,
    r_hat,
    share,
    tail_probability,
)
from inertiafit.physics import UNITS
from inertiafit.posterior import pins

if TYPE_CHECKING:  # third-party types only: nothing of this package
    import pandas as pd
    import xarray as xr


class PosteriorView(Protocol):
    """What the display reads of a :class:`~inertiafit.posterior.Posterior`.

    Named here rather than imported: the posterior imports its display.
    """

    tree: xr.DataTree
    bodies: tuple[str, ...]

    @property
    def converged(self) -> bool:
        """Whether the sampler met every convergence criterion."""
        ...

    def calibration_note(self) -> str:
        """One line on the torque calibration's uncertainty."""
        ...

    def conflict_warnings(self) -> list[str]:
        """One line per quantity in prior-data conflict."""
        ...

    def correlations(self) -> pd.DataFrame:
        """Posterior correlations of ``m``, ``x`` and ``rho``."""
        ...

    def identification(self) -> pd.DataFrame:
        """Who decides each quantity."""
        ...

    def prior_predictive(self) -> pd.DataFrame:
        """Each measured quantity against its prior predictive."""
        ...

    def summary(self, hdi_prob: float = 0.95) -> pd.DataFrame:
        """A row per body and parameter."""
        ...

    def what_pins_what(self) -> dict[str, str]:
        """One line per body naming what pins each quantity."""
        ...


__all__ = [
    "correlation_text",
    "html_table",
    "predictive_text",
    "table_rows",
    "text_report",
    "trial_counts",
]


def measured_line(tree, body: str, minimum_mass: float) -> str:
    """What the data measure of ``body``, in words (:func:`pins.measured_quantities`)."""
    measured = pins.measured_quantities(tree, body)
    if len(measured) == 2:
        return (
            f"{body}: the data identify m·x and I; physical consistency needs "
            f"m >= (M_g/g)^2/I = {minimum_mass:.4g} kg"
        )
    if measured == ("gravity_moment",):
        return f"{body}: the data identify m·x alone (no fast trials: its I is the prior's)"
    if measured == ("inertia",):
        return f"{body}: the data identify I alone (its M_g is not measured: the prior's)"
    return f"{body}: the data measure none of its parameters: every interval is its prior's"


def table_rows(post: PosteriorView, hdi_prob: float) -> list[dict[str, Any]]:
    """Summary rows with who identifies each quantity.

    Adds ``identified_by``, ``sd_ratio`` and ``prior_share`` of :meth:`Posterior.identification`.
    """
    s = post.summary(hdi_prob)
    ident = post.identification()
    return [
        {
            **r.to_dict(),
            "identified_by": q["identified_by"],
            "sd_ratio": q["sd_ratio"],
            "prior_share": q["prior_share"],
        }
        for (_, r), (_, q) in zip(s.iterrows(), ident.iterrows(), strict=True)
    ]


def predictive_text(post: PosteriorView) -> str:
    """One line: each measured quantity's prior-predictive tail probability, conflicts marked.

    Empty when nothing is measured (:meth:`Posterior.prior_predictive`).
    """
    from inertiafit.posterior.conflict import CONFLICT_TAIL

    table = post.prior_predictive()
    if not len(table):
        return ""
    parts: dict[str, list[str]] = {}
    for r in table.itertuples(index=False):
        mark = " (conflict)" if r.conflict else ""
        p = tail_probability(r.tail_probability)
        parts.setdefault(str(r.body), []).append(f"{pins.SHORT[str(r.quantity)]} {p}{mark}")
    return (
        "Prior-data check (two-sided prior-predictive tail probability of what the data "
        f"measure; below {CONFLICT_TAIL:g} the prior and the data conflict): "
        + "; ".join(f"{body} {', '.join(v)}" for body, v in parts.items())
    )


def correlation_text(post: PosteriorView) -> list[str]:
    """One line per body: the posterior correlations of m, x and rho."""
    return [
        f"{r.body}: posterior correlations m-x {correlation(r.corr_m_x)}, "
        f"m-rho {correlation(r.corr_m_rho)}, x-rho {correlation(r.corr_x_rho)}"
        for r in post.correlations().itertuples(index=False)
    ]


def trial_counts(post: PosteriorView) -> str | None:
    """One line counting a study's trials by what became of them; ``None`` without trials.

    From the trials table a study's posterior keeps in its ``inputs`` (``inertiafit run``):
    used (``ok``), excluded for muscle activity, skipped (``on_trial_error``), MVC references.
    A posterior fitted from numbers has no trials and no line.
    """
    try:
        trials = json.loads(post.tree.attrs.get("inputs", "{}")).get("trials") or {}
    except (TypeError, ValueError, AttributeError):
        return None
    status = trials.get("status") if isinstance(trials, dict) else None
    if not status:
        return None
    from inertiafit.processing.trials import (
        STATUS_EXCLUDED,
        STATUS_OK,
        STATUS_REFERENCE,
        STATUS_SKIPPED,
    )

    counts: Counter[str] = Counter(status)
    parts = [f"{plural(len(status), 'trial')}: {counts[STATUS_OK]} in the evidence"]
    if counts[STATUS_EXCLUDED]:
        parts.append(f"{counts[STATUS_EXCLUDED]} excluded for muscle activity (EMG)")
    if counts[STATUS_SKIPPED]:
        parts.append(f"{counts[STATUS_SKIPPED]} skipped (could not be processed)")
    if counts[STATUS_REFERENCE]:
        parts.append(f"{plural(counts[STATUS_REFERENCE], 'MVC reference')}, not evidence")
    return "; ".join(parts) + " (trials.csv says which and why)"


def text_report(post: PosteriorView, hdi_prob: float = 0.95) -> str:
    """Readable text: the table with intervals, who identifies what, diagnostics."""
    a = post.tree.attrs
    pct = f"{100 * hdi_prob:g}% HDI"
    width = max(6, *(len(b) for b in post.bodies)) + 2
    lines = [
        f"inertiafit posterior: {plural(len(post.bodies), 'body')}; {a.get('n_walkers')} walkers x "
        f"{post.tree['posterior'].sizes['draw']} draws kept of {a.get('n_steps')} steps; "
        f"tau {float(a.get('tau_max', math.nan)):.1f} steps; seed {a.get('seed')}; "
        + ("converged" if post.converged else "NOT CONVERGED"),
        (
            f"{'body':<{width}}{'parameter':<28}{'median':>10}  {pct:<24}{'sd':>10}  "
            f"{'R-hat':>6} {'ESS':>6} {'prior share':>11}  identified by (post/prior SD)"
        ),
    ]
    for r in table_rows(post, hdi_prob):
        p = r["parameter"]
        name = f"{p} [{UNITS[p]}]"
        hdi = interval(r["hdi_lower"], r["hdi_upper"])
        lines.append(
            f"{r['body']:<{width}}{name:<28}{r['median']:>10.4g}  {hdi:<24}{r['sd']:>10.3g}  "
            f"{r_hat(r['r_hat']):>6} {ess(r['ess_bulk']):>6} {share(r['prior_share']):>11}  "
            f"{r['identified_by']} ({share(r['sd_ratio'])})"
        )
    ident = post.identification()
    for body in post.bodies:
        mmin = float(ident.loc[ident.body == body, "minimum_mass"].iloc[0])
        lines.append(measured_line(post.tree, body, mmin))
    lines.append(f"What pins what. {pins.VERDICT_NOTE}. {pins.SHARE_NOTE}:")
    lines += [f"  {line}" for line in post.what_pins_what().values()]
    checked = predictive_text(post)
    if checked:
        lines.append(checked)
    lines += correlation_text(post)
    lines.append(post.calibration_note())
    counts = trial_counts(post)
    if counts is not None:
        lines.append(counts)
    return "\n".join(lines)


_HTML_HEAD = (
    "body",
    "parameter",
    "unit",
    "median",
    "95% HDI",
    "sd",
    "R-hat",
    "ESS bulk",
    "prior share",
    "identified by",
)


def html_table(post: PosteriorView, hdi_prob: float = 0.95) -> str:
    """An HTML table of the summary with who identifies what (the Jupyter display)."""
    head = "".join(f"<th>{h}</th>" for h in _HTML_HEAD).replace(
        "95% HDI", f"{100 * hdi_prob:g}% HDI"
    )
    body = "".join(
        "<tr>"
        + "".join(
            f"<td>{html.escape(str(v))}</td>"
            for v in (
                r["body"],
                r["parameter"],
                UNITS[r["parameter"]],
                f"{r['median']:.4g}",
                interval(r["hdi_lower"], r["hdi_upper"]),
                f"{r['sd']:.3g}",
                r_hat(r["r_hat"]),
                ess(r["ess_bulk"]),
                share(r["prior_share"]),
                f"{r['identified_by']} ({share(r['sd_ratio'])})",
            )
        )
        + "</tr>"
        for r in table_rows(post, hdi_prob)
    )
    status = "converged" if post.converged else "<b>not converged</b>"
    pins = "".join(f"<li>{html.escape(line)}</li>" for line in post.what_pins_what().values())
    pins += "".join(f"<li><b>{html.escape(line)}</b></li>" for line in post.conflict_warnings())
    corr = "".join(f"<li>{html.escape(line)}</li>" for line in correlation_text(post))
    counts = trial_counts(post)
    trials = "" if counts is None else f"<p>{html.escape(counts)}</p>"
    return (
        f"<div><p><b>inertiafit posterior</b> ({status}, seed {post.tree.attrs.get('seed')})"
        f"</p><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
        f"<p>What pins what:</p><ul>{pins}</ul><ul>{corr}</ul>"
        f"<p>{html.escape(post.calibration_note())}</p>{trials}</div>"
    )
