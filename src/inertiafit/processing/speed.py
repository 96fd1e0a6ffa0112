"""Does the inertia depend on the speed? One-way ANOVA and Tukey HSD per condition.

The paper tests whether the per-trial inertias of a condition differ between the preset speeds
(240, 270, 300 deg/s) with a one-way ANOVA and Tukey's HSD post hoc test (section 3.1). A rigid
body's inertia does not depend on speed; a significant difference points at a processing or
recording problem (a window that changes with speed, a filter lag, saturation).

:func:`speed_effect` returns one tidy table, ``speed_effect.csv`` (``docs/cli.md``), with two
kinds of rows (column ``row``):

- ``"speed"``: one per condition and speed: ``n``, ``mean``, ``sd`` (ddof 1) of the inertia,
  and the condition's ANOVA ``F`` and ``p`` repeated on each row;
- ``"pair"``: one per condition and pair of speeds ``speed < speed_b``: Tukey's
  ``mean_difference`` (``mean(speed) - mean(speed_b)``), ``p_tukey`` and the
  ``ci_lower``/``ci_upper`` of the difference at ``confidence`` (the ANOVA ``F``, ``p``
  repeated too).

Columns that do not apply to a row are NaN. With fewer than two speeds, or a speed with fewer
than two trials, ``F``, ``p`` and the pairs are not defined: NaN, and no pair rows.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import stats

__all__ = [
    "COLUMNS",
    "speed_effect",
    "tukey_pairs",
]

COLUMNS = (
    "condition",
    "row",
    "speed",
    "speed_b",
    "n",
    "mean",
    "sd",
    "F",
    "p",
    "mean_difference",
    "p_tukey",
    "ci_lower",
    "ci_upper",
)


def _groups(
    trials: pd.DataFrame | Mapping[str, Mapping[float, Sequence[float]]], value: str
) -> dict[str, dict[float, np.ndarray]]:
    if isinstance(trials, pd.DataFrame):
        missing = {"condition", "speed", value} - set(trials.columns)
        if missing:
            msg = f"speed_effect: trials table lacks column(s) {sorted(missing)}"
            raise KeyError(msg)
        fast = trials.dropna(subset=["speed", value])
        out: dict[str, dict[float, np.ndarray]] = {}
        for (condition, speed), group in fast.groupby(["condition", "speed"], sort=True):
            out.setdefault(str(condition), {})[float(speed)] = group[value].to_numpy(float)
        return out
    return {
        str(c): {float(s): np.asarray(v, dtype=float) for s, v in sorted(by_speed.items())}
        for c, by_speed in trials.items()
    }


def tukey_pairs(
    samples: Sequence[np.ndarray], confidence: float = 0.95
) -> tuple[list[tuple[int, int]], list[float], list[float], list[float]]:
    """Tukey's HSD for every pair ``i < j`` of groups, as scipy computes it, for the pairs only.

    The numbers are those of :func:`scipy.stats.tukey_hsd` (equal variances), which
    integrates the studentized range for all ``k x k`` entries (diagonal and both triangles)
    and finds its quantile by root-finding on nested integrals; here the tail probability is
    integrated once per pair and the quantile once per ``(confidence, k, df)``
    (:func:`_studentized_range_quantile`). Same formulas, same floating-point operations,
    the same numbers.

    Returns
    -------
    pairs, mean_differences, p_values, ci_radii : lists
        Per pair ``(i, j)``: ``mean(i) - mean(j)``, its p-value, and the half-width of its
        ``confidence`` interval (symmetric about the difference).
    """
    k = len(samples)
    means = np.asarray([np.mean(x) for x in samples])
    sizes = np.asarray([x.size for x in samples])
    variances = np.asarray([np.var(x, ddof=1) for x in samples])
    mse = np.sum(variances * (sizes - 1)) / (np.sum(sizes) - k)
    if np.unique(sizes).size == 1:
        normalize = np.full((k, k), 2 / sizes[0])
    else:
        normalize = 1 / sizes + 1 / sizes[None].T
    stand_err = np.sqrt(normalize * mse / 2)
    df = int(np.sum(sizes) - k)
    differences = means[None].T - means
    pairs = list(itertools.combinations(range(k), 2))
    rows, cols = (np.array(v, dtype=int) for v in zip(*pairs, strict=True))
    t_stat = np.abs(differences[rows, cols]) / stand_err[rows, cols]
    p_values = np.atleast_1d(stats.studentized_range.sf(t_stat, k, df))
    radii = _studentized_range_quantile(confidence, k, df) * stand_err[rows, cols]
    return (
        pairs,
        [float(v) for v in differences[rows, cols]],
        [float(v) for v in p_values],
        [float(v) for v in radii],
    )


@functools.lru_cache(maxsize=32)
def _studentized_range_quantile(confidence: float, k: int, df: int) -> float:
    # ~0.13 s of root-finding on a double integral; a study's conditions usually share k, df.
    return float(stats.studentized_range.ppf(confidence, k, df))


def speed_effect(
    trials: pd.DataFrame | Mapping[str, Mapping[float, Sequence[float]]],
    *,
    value: str = "inertia",
    confidence: float = 0.95,
) -> pd.DataFrame:
    """Per-speed summaries, one-way ANOVA and Tukey HSD of the inertia, per condition.

    Parameters
    ----------
    trials : pandas.DataFrame or mapping
        Either a table with columns ``condition``, ``speed`` (deg/s) and ``value`` (rows
        without a speed, the quasi-static trials, are ignored), such as ``trials.csv``; or a
        mapping ``condition -> {speed -> inertias}``.
    value : str
        Column to analyse (``"inertia"`` or ``"inertia_frame_mean"``).
    confidence : float
        Confidence level of the Tukey intervals.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COLUMNS`; rows as described in the module docstring.

    Raises
    ------
    KeyError
        If the table lacks a needed column.
    """
    rows = []
    nan = math.nan
    for condition, by_speed in _groups(trials, value).items():
        speeds = sorted(by_speed)
        samples = [by_speed[s] for s in speeds]
        # ANOVA needs two groups of two, and some spread within groups (else F is 0/0 or inf).
        testable = (
            len(samples) >= 2
            and all(x.size >= 2 for x in samples)
            and any(np.ptp(x) > 0 for x in samples)
        )
        f_stat, p_value = nan, nan
        if testable:
            anova = stats.f_oneway(*samples)
            f_stat, p_value = float(anova.statistic), float(anova.pvalue)
        for s, x in zip(speeds, samples, strict=True):
            rows.append(
                {
                    "condition": condition,
                    "row": "speed",
                    "speed": s,
                    "n": int(x.size),
                    "mean": float(np.mean(x)) if x.size else nan,
                    "sd": float(np.std(x, ddof=1)) if x.size >= 2 else nan,
                    "F": f_stat,
                    "p": p_value,
                }
            )
        if not testable:
            continue
        for (i, j), diff, p_pair, radius in zip(*tukey_pairs(samples, confidence), strict=True):
            rows.append(
                {
                    "condition": condition,
                    "row": "pair",
                    "speed": speeds[i],
                    "speed_b": speeds[j],
                    "F": f_stat,
                    "p": p_value,
                    "mean_difference": diff,
                    "p_tukey": p_pair,
                    "ci_lower": diff - radius,
                    "ci_upper": diff + radius,
                }
            )
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    return table.astype({"n": "Int64"})
