"""Tables for papers: the same frame as CSV, Markdown and LaTeX (booktabs).

CSV keeps every number at full precision for further work; Markdown and LaTeX are formatted for
reading: four significant figures, intervals as ``median [lower, upper]``, units in headers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from inertiafit.formatting import (
    correlation,
    interval,
    mean_sd,
    number,
    r_hat,
    share,
    tail_probability,
)
from inertiafit.io.outputs import write_csv
from inertiafit.physics import UNITS

__all__ = [
    "FAST_TRIAL_DISPLAY",
    "OPTIONAL_TRIAL_DISPLAY",
    "STATIC_TRIAL_DISPLAY",
    "comparison_display",
    "correlation_display",
    "fmt",
    "identification_display",
    "passive_display",
    "speed_effect_display",
    "summary_display",
    "to_latex",
    "to_markdown",
    "trial_tables",
    "tukey_display",
    "write_table",
]

_LATEX_SPECIAL = {
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\^{}",
    "\\": r"\textbackslash{}",
}


#: The table cell of a value (:func:`inertiafit.formatting.number`), under its old name.
fmt = number


def to_markdown(frame: pd.DataFrame, digits: int = 4) -> str:
    """A GitHub-flavoured Markdown table; numeric columns right-aligned."""
    cols = [str(c) for c in frame.columns]
    numeric = [pd.api.types.is_numeric_dtype(frame[c]) for c in frame.columns]
    lines = [
        "| " + " | ".join(cols) + " |",
        "|" + "|".join("---:" if n else ":---" for n in numeric) + "|",
    ]
    for row in frame.itertuples(index=False):
        lines.append("| " + " | ".join(number(v, digits).replace("|", r"\|") for v in row) + " |")
    return "\n".join(lines) + "\n"


def _tex(text: str) -> str:
    return "".join(_LATEX_SPECIAL.get(ch, ch) for ch in text)


def to_latex(frame: pd.DataFrame, *, caption: str = "", label: str = "", digits: int = 4) -> str:
    r"""A LaTeX ``table`` with booktabs rules (``\usepackage{booktabs}``)."""
    numeric = [pd.api.types.is_numeric_dtype(frame[c]) for c in frame.columns]
    spec = "".join("r" if n else "l" for n in numeric)
    lines = [r"\begin{table}", r"  \centering"]
    if caption:
        lines.append(rf"  \caption{{{_tex(caption)}}}")
    if label:
        lines.append(rf"  \label{{{label}}}")
    lines += [
        rf"  \begin{{tabular}}{{{spec}}}",
        r"    \toprule",
        "    " + " & ".join(_tex(str(c)) for c in frame.columns) + r" \\",
        r"    \midrule",
    ]
    for row in frame.itertuples(index=False):
        lines.append("    " + " & ".join(_tex(number(v, digits)) for v in row) + r" \\")
    lines += [r"    \bottomrule", r"  \end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def write_table(
    frame: pd.DataFrame,
    folder: Path,
    stem: str,
    *,
    display: pd.DataFrame | None = None,
    caption: str = "",
) -> list[Path]:
    """``stem.csv`` (full precision) plus ``stem.md`` and ``stem.tex`` (of ``display``)."""
    folder = Path(folder)
    shown = frame if display is None else display
    paths = [folder / f"{stem}.csv", folder / f"{stem}.md", folder / f"{stem}.tex"]
    write_csv(frame, paths[0])
    paths[1].write_text(to_markdown(shown), encoding="utf-8")
    paths[2].write_text(to_latex(shown, caption=caption, label=f"tab:{stem}"), encoding="utf-8")
    return paths


def passive_display(table: pd.DataFrame) -> pd.DataFrame:
    """Readable living-joint table: parameter [unit], mean ± SD, interval, prior, decided by."""

    def prior(row) -> str:
        if pd.isna(row["prior_sd"]):
            return ""
        return mean_sd(row["prior_mean"], row["prior_sd"])

    return pd.DataFrame(
        {
            "parameter": [
                f"{p} [{u}]" for p, u in zip(table["parameter"], table["unit"], strict=True)
            ],
            "mean ± SD": [mean_sd(m, s) for m, s in zip(table["mean"], table["sd"], strict=True)],
            "95% interval": [
                interval(lo, hi) for lo, hi in zip(table["lower"], table["upper"], strict=True)
            ],
            "prior": [prior(r) for _, r in table.iterrows()],
            "decided by": table["pinned_by"].fillna("").astype(str),
        }
    )


def _interval(median: float, lo: float, hi: float) -> str:
    return f"{median:.4g} {interval(lo, hi)}"


def summary_display(summary: pd.DataFrame) -> pd.DataFrame:
    """Readable summary: median with its HDI, mean ± SD, R-hat, ESS; units in the parameter."""
    prob = float(summary["hdi_prob"].iloc[0]) if len(summary) else 0.95
    return pd.DataFrame(
        {
            "body": summary["body"],
            "parameter": [
                f"{p} [{UNITS[p]}]" if p in UNITS else str(p) for p in summary["parameter"]
            ],
            f"median [{100 * prob:g}% HDI]": [
                _interval(m, lo, hi)
                for m, lo, hi in zip(
                    summary["median"], summary["hdi_lower"], summary["hdi_upper"], strict=True
                )
            ],
            "mean ± sd": [
                mean_sd(m, s) for m, s in zip(summary["mean"], summary["sd"], strict=True)
            ],
            "R-hat": [r_hat(v) for v in summary["r_hat"]],
            "ESS bulk": summary["ess_bulk"]
            .round(0)
            .astype(
                "Int64" if summary["ess_bulk"].isna().any() else int  # a living joint's: none
            ),
        }
    )


def identification_display(identification: pd.DataFrame) -> pd.DataFrame:
    """Who pins what: SD ratio, the prior's share, psense, the sources and the prior-data check.

    From :meth:`~inertiafit.posterior.Posterior.identification`; blanks where a value does not
    apply (psense of a box prior, the calibration share without a torque gain, the
    prior-predictive tail probability of a quantity nothing measures).
    """
    frame = identification

    def col(name):
        return frame[name] if name in frame else pd.Series([math.nan] * len(frame))

    return pd.DataFrame(
        {
            "body": frame["body"],
            "parameter": [f"{p} [{UNITS[p]}]" for p in frame["parameter"]],
            "post/prior SD": [share(v) for v in frame["sd_ratio"]],
            "prior share": [share(v) for v in col("prior_share")],
            "calibration share": [share(v) for v in col("calibration_share")],
            "psense prior": [share(v) for v in col("psense_prior")],
            "psense likelihood": [share(v) for v in col("psense_likelihood")],
            "pinned by": col("pinned_by").fillna("").astype(str).to_numpy(),
            "prior-predictive p": [
                _tail(v, c)
                for v, c in zip(
                    col("prior_predictive_p"),
                    col("prior_data_conflict").fillna(False),
                    strict=True,
                )
            ],
        }
    )


def _tail(p: float, conflict: bool) -> str:
    """A prior-predictive tail probability, two significant figures; ``conflict`` marked."""
    if not math.isfinite(p):
        return ""
    text = tail_probability(p)
    return f"{text} (prior-data conflict)" if conflict else text


def correlation_display(correlations: pd.DataFrame) -> pd.DataFrame:
    """Posterior correlations of m, x and rho per body, two decimals."""
    return pd.DataFrame(
        {
            "body": correlations["body"],
            "corr(m, x)": [correlation(v) for v in correlations["corr_m_x"]],
            "corr(m, rho)": [correlation(v) for v in correlations["corr_m_rho"]],
            "corr(x, rho)": [correlation(v) for v in correlations["corr_x_rho"]],
        }
    )


def comparison_display(comparison: pd.DataFrame, hdi_prob: float = 0.95) -> pd.DataFrame:
    """The paper's Tables 2-3 with the posterior: ideal, posterior, baseline, differences."""

    def pct(v):
        return "" if math.isnan(v) else f"{100 * v:+.1f} %"

    return pd.DataFrame(
        {
            "body": comparison["body"],
            "parameter": [
                f"{p} [{u}]"
                for p, u in zip(comparison["parameter"], comparison["unit"], strict=True)
            ],
            "ideal": comparison["ideal"],
            f"posterior median [{100 * hdi_prob:g}% HDI]": [
                _interval(m, lo, hi)
                for m, lo, hi in zip(
                    comparison["posterior_median"],
                    comparison["hdi_lower"],
                    comparison["hdi_upper"],
                    strict=True,
                )
            ],
            "paper's baseline": comparison["baseline"],
            "posterior vs ideal": [pct(v) for v in comparison["posterior_vs_ideal"]],
            "baseline vs ideal": [pct(v) for v in comparison["baseline_vs_ideal"]],
            "identified by (post/prior SD)": [
                f"{who} ({share(r)})"
                for who, r in zip(comparison["identified_by"], comparison["sd_ratio"], strict=True)
            ],
        }
    )


def speed_effect_display(effect: pd.DataFrame) -> pd.DataFrame:
    """Per condition and speed: n, mean ± SD, the ANOVA F and p (Tukey pairs left to the CSV)."""
    rows = effect[effect["row"] == "speed"] if "row" in effect else effect
    return pd.DataFrame(
        {
            "condition": rows["condition"],
            "speed [°/s]": rows["speed"],
            "n": rows["n"].astype(int),
            "inertia [kg m^2]": [
                mean_sd(m, s) for m, s in zip(rows["mean"], rows["sd"], strict=True)
            ],
            "ANOVA F": rows["F"],
            "p": rows["p"],
        }
    )


def _pm(value: float, se: float, digits: int = 4) -> str:
    """``value ± se``; the value alone without an SE; blank for NaN."""
    if math.isnan(value):
        return ""
    if math.isnan(se):
        return f"{value:.{digits}g}"
    return mean_sd(value, se, digits)


def _get(row: pd.Series, column: str) -> float:
    value = row.get(column, math.nan)
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _text(row: pd.Series, column: str) -> str:
    value = row.get(column, "")
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)


#: The columns of a condition's table of fast trials in report.html: header (units in it) and
#: how a row shows. A column of ``trials.csv`` to show is one more entry here.
FAST_TRIAL_DISPLAY: list[tuple[str, Callable[[pd.Series], str]]] = [
    ("file", lambda r: _text(r, "file")),
    ("speed [°/s]", lambda r: number(_get(r, "speed"))),
    ("I [kg m²] ± SE", lambda r: _pm(_get(r, "inertia"), _get(r, "inertia_se"))),
    ("I, paper's frame mean [kg m²]", lambda r: number(_get(r, "inertia_frame_mean"))),
    (
        "window [s]",
        lambda r: (
            ""
            if math.isnan(_get(r, "window_start"))
            else f"{_get(r, 'window_start'):.3f}–{_get(r, 'window_end'):.3f}"
        ),
    ),
    ("samples", lambda r: number(_get(r, "n_window"), 6)),
    ("lag [ms] ± SE", lambda r: _pm(1000 * _get(r, "lag"), 1000 * _get(r, "lag_se"), 3)),
    ("residual RMS [N m]", lambda r: number(_get(r, "residual_rms"), 3)),
    ("flags", lambda r: _text(r, "flags")),
]
#: The same for a condition's quasi-static and rest trials.
STATIC_TRIAL_DISPLAY: list[tuple[str, Callable[[pd.Series], str]]] = [
    ("file", lambda r: _text(r, "file")),
    ("kind", lambda r: _text(r, "kind")),
    ("M_g [N m] ± SE", lambda r: _pm(_get(r, "gravity_moment"), _get(r, "gravity_moment_se"))),
    ("phase [rad]", lambda r: number(_get(r, "gravity_phase"), 3)),
    ("offset [N m]", lambda r: number(_get(r, "offset"), 3)),
    ("samples", lambda r: number(_get(r, "n_window"), 6)),
    ("residual RMS [N m]", lambda r: number(_get(r, "residual_rms"), 3)),
    ("flags", lambda r: _text(r, "flags")),
]
#: Shown only when the table has the column (a living body's trials).
OPTIONAL_TRIAL_DISPLAY: dict[str, tuple[str, Callable[[pd.Series], str]]] = {
    "posture": ("posture", lambda r: _text(r, "posture")),
    "damping": ("b [N m s/rad] ± SE", lambda r: _pm(_get(r, "damping"), _get(r, "damping_se"))),
}


def _display(rows: pd.DataFrame, spec: list[tuple[str, Callable[[pd.Series], str]]]):
    extra = [OPTIONAL_TRIAL_DISPLAY[c] for c in OPTIONAL_TRIAL_DISPLAY if c in rows.columns]
    columns = [*spec[:1], *extra, *spec[1:]]
    return pd.DataFrame(
        {head: [show(r) for _, r in rows.iterrows()] for head, show in columns},
        columns=[head for head, _ in columns],
    )


def trial_tables(trials: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """``trials.csv`` for reading: per condition, its quasi-static/rest and its fast trials.

    Each table has the columns that apply to its trials (:data:`STATIC_TRIAL_DISPLAY`,
    :data:`FAST_TRIAL_DISPLAY`), units in the headers; a skipped trial keeps its row, with
    the reason in ``flags``. Titles name the condition and the kind of trials.
    """
    out = []
    for condition, rows in trials.groupby("condition", sort=False):
        fast = rows[rows["kind"] == "fast"]
        static = rows[rows["kind"] != "fast"]
        if len(static):
            kinds = " and ".join(dict.fromkeys(str(k) for k in static["kind"]))
            out.append((f"{condition}: {kinds} trials", _display(static, STATIC_TRIAL_DISPLAY)))
        if len(fast):
            out.append((f"{condition}: fast trials", _display(fast, FAST_TRIAL_DISPLAY)))
    return out


def tukey_display(effect: pd.DataFrame) -> pd.DataFrame:
    """The Tukey HSD pairs of a speed-effect table: difference of means, its CI and p."""
    pairs = effect[effect["row"] == "pair"] if "row" in effect else effect.iloc[0:0]
    return pd.DataFrame(
        {
            "condition": pairs["condition"].astype(str),
            "speeds [°/s]": [
                f"{a:g} vs {b:g}" for a, b in zip(pairs["speed"], pairs["speed_b"], strict=True)
            ],
            "difference of means [kg m²]": [f"{v:+.3g}" for v in pairs["mean_difference"]],
            "95% CI [kg m²]": [
                interval(lo, hi, 3)
                for lo, hi in zip(pairs["ci_lower"], pairs["ci_upper"], strict=True)
            ],
            "p (Tukey HSD)": [f"{v:.3g}" for v in pairs["p_tukey"]],
        }
    )
