"""What every output is drawn from: one plain-data :class:`Result` for a study or a fit.

A :class:`Result` computes nothing: :func:`make_result` builds it from what the pipeline has
(posterior, priors, trials, speed effect, baselines, traces) and adds the one comparison table
(:func:`~inertiafit.report.comparison.comparison_table`). A study from trial files and one body
fitted from numbers are the same type; a fit simply has no trials.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from inertiafit.inference.priors import Prior
from inertiafit.posterior import Posterior
from inertiafit.processing.study import (
    EMG_TRACE_COLUMNS,
    SWEEP_COLUMNS,
    TRACE_COLUMNS,
    TRIAL_COLUMNS,
)
from inertiafit.report.comparison import FIT_COLUMNS, STUDY_COLUMNS, comparison_table

__all__ = ["Result", "make_result", "traces_by_condition"]


@dataclass(frozen=True)
class Result:
    """Everything the outputs of a study or a fit are drawn from.

    Attributes
    ----------
    name : str
        The study's name, or the fitted prior's.
    posterior : Posterior
        Joint posterior over every body.
    priors : dict of str to Prior
        Each body's prior.
    gravity : float
        m/s^2.
    hdi_prob : float
        Probability of the HDIs in :attr:`comparison`.
    comparison : pandas.DataFrame
        Prior, ideal, reference, posterior and baseline per body and quantity (every column of
        :data:`~inertiafit.report.comparison.COLUMNS`; :attr:`comparison_columns` are shown).
    trials : pandas.DataFrame
        A row per trial (columns :data:`~inertiafit.processing.study.TRIAL_COLUMNS`); empty
        for a body fitted from numbers.
    speed_effect : pandas.DataFrame
        Per condition and speed: n, mean, SD, ANOVA and Tukey pairs; empty without trials.
    traces : pandas.DataFrame
        Filtered fast trials for figures (columns
        :data:`~inertiafit.processing.study.TRACE_COLUMNS`), empty when not available.
    conditions : dict of str to tuple of str
        Condition label → mounted bodies.
    ideals : dict of str to dict
        Ideal (textbook) values of the bodies that declare one (SI units).
    baselines : dict of str to BaselineResult
        The paper's estimator per body, where it could be computed.
    warnings : tuple of str
        Trial flags and other notes, one line each.
    manifest : str
        Path of the study manifest ("" for a fit from numbers).
    living : dict of str to pandas.DataFrame
        A living body's joint (:func:`~inertiafit.processing.living.living_tables`):
        ``passive_parameters`` and ``passive_curve``; empty for a rigid study.
    emg_traces : pandas.DataFrame
        The fast trials' EMG envelopes over their rest levels (columns
        :data:`~inertiafit.processing.study.EMG_TRACE_COLUMNS`); empty without EMG.
    truths : dict of str to dict
        A simulated study's true values per body and quantity (SI units; the demo's
        ``truth.toml``), drawn beside the ideal bodies; empty for measured data.
    sweeps : pandas.DataFrame
        The rigid conditions' quasi-static sweeps as fitted (``sweeps.csv``, columns
        :data:`~inertiafit.processing.study.SWEEP_COLUMNS`); empty when not available.
    """

    name: str
    posterior: Posterior
    priors: dict[str, Prior]
    gravity: float
    hdi_prob: float
    comparison: pd.DataFrame
    trials: pd.DataFrame
    speed_effect: pd.DataFrame
    traces: pd.DataFrame
    conditions: dict[str, tuple[str, ...]]
    ideals: dict[str, dict[str, float]]
    baselines: dict[str, Any]
    warnings: tuple[str, ...]
    manifest: str
    living: dict[str, pd.DataFrame] = field(default_factory=dict)
    emg_traces: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=EMG_TRACE_COLUMNS)
    )
    truths: dict[str, dict[str, float]] = field(default_factory=dict)
    sweeps: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=SWEEP_COLUMNS))

    def summary(self, hdi_prob: float | None = None) -> pd.DataFrame:
        """The posterior's summary; a living body's joint parameters as rows of that body.

        The joint's parameters (stiffness, stops, hysteresis, damping, posture rotations)
        were integrated out or fitted beside the posterior (their posterior is Gaussian):
        ``mean`` and ``median`` are its mean, the HDI its central interval at ``hdi_prob``;
        ``ess_*`` and ``r_hat`` are blank (not sampled).
        """
        prob = self.hdi_prob if hdi_prob is None else hdi_prob
        table = self.posterior.summary(prob)
        if not self.living:
            return table
        from scipy import stats

        joint = self.living["passive_parameters"]
        joint = joint[~joint["parameter"].str.startswith("gravity_moment:")]
        z = float(stats.norm.ppf(0.5 + prob / 2))
        rows = pd.DataFrame(
            {
                "body": joint["body"],
                "parameter": joint["parameter"],
                "mean": joint["mean"],
                "sd": joint["sd"],
                "median": joint["mean"],
                "hdi_lower": joint["mean"] - z * joint["sd"],
                "hdi_upper": joint["mean"] + z * joint["sd"],
                "hdi_prob": prob,
            }
        )
        return pd.concat([table, rows], ignore_index=True)

    def identification(self) -> pd.DataFrame:
        """The posterior's identification table; for a living body, what decided its ``M_g``.

        The living body's ``gravity_moment`` row's ``pinned_by`` adds what told the gravity
        moment of its condition apart from the passive curve (``passive_parameters``'
        ``pinned_by``: the passive prior, a second posture, the horizontal plane).
        """
        table = self.posterior.identification()
        if not self.living:
            return table
        joint = self.living["passive_parameters"]
        said = joint[joint["parameter"].str.startswith("gravity_moment:")]
        if not len(said):
            return table
        body = str(said["body"].iloc[0])
        separated = "; ".join(dict.fromkeys(str(v) for v in said["pinned_by"]))
        rows = (table["body"] == body) & (table["parameter"] == "gravity_moment")
        table.loc[rows, "pinned_by"] = (
            table.loc[rows, "pinned_by"].astype(str)
            + f" (living: M_g told from the passive curve by {separated})"
        )
        return table

    @property
    def from_numbers(self) -> bool:
        """Whether this is one body fitted from reported numbers (no trial files)."""
        return self.trials.empty

    @property
    def comparison_columns(self) -> list[str]:
        """The columns of ``comparison.csv``: a study's, or a fit-from-numbers'.

        A fit from numbers shows its prior's nominal values and the published reference.
        """
        return FIT_COLUMNS if self.from_numbers else STUDY_COLUMNS


def make_result(
    *,
    name: str,
    posterior: Posterior,
    priors: Mapping[str, Prior],
    gravity: float,
    hdi_prob: float,
    trials: pd.DataFrame | None = None,
    speed_effect: pd.DataFrame | None = None,
    traces: pd.DataFrame | None = None,
    conditions: Mapping[str, Sequence[str]] | None = None,
    ideals: Mapping[str, Mapping[str, float]] | None = None,
    baselines: Mapping[str, Any] | None = None,
    warnings: Sequence[str] = (),
    manifest: str = "",
    living: Mapping[str, pd.DataFrame] | None = None,
    emg_traces: pd.DataFrame | None = None,
    truths: Mapping[str, Mapping[str, float]] | None = None,
    sweeps: pd.DataFrame | None = None,
) -> Result:
    """Assemble a :class:`Result` and its comparison table (nothing else is computed)."""
    ideals_ = {k: dict(v) for k, v in (ideals or {}).items()}
    baselines_ = dict(baselines or {})
    return Result(
        name=name,
        posterior=posterior,
        priors=dict(priors),
        gravity=gravity,
        hdi_prob=hdi_prob,
        comparison=comparison_table(
            posterior,
            priors,
            hdi_prob=hdi_prob,
            gravity=gravity,
            ideals=ideals_,
            baselines=baselines_,
        ),
        trials=trials if trials is not None else pd.DataFrame(columns=TRIAL_COLUMNS),
        speed_effect=speed_effect if speed_effect is not None else pd.DataFrame(),
        traces=traces if traces is not None else pd.DataFrame(columns=TRACE_COLUMNS),
        conditions={
            k: tuple(v) for k, v in (conditions or {b: (b,) for b in posterior.bodies}).items()
        },
        ideals=ideals_,
        baselines=baselines_,
        warnings=tuple(warnings),
        manifest=manifest,
        living=dict(living or {}),
        emg_traces=emg_traces
        if emg_traces is not None
        else pd.DataFrame(columns=EMG_TRACE_COLUMNS),
        truths={k: dict(v) for k, v in (truths or {}).items()},
        sweeps=sweeps if sweeps is not None else pd.DataFrame(columns=SWEEP_COLUMNS),
    )


def traces_by_condition(traces: pd.DataFrame) -> dict[str, list[dict]]:
    """The trace table as one list per condition of one dict per trial.

    The shape :func:`~inertiafit.report.plots.plot_fast_trials` draws; a trial fitted over its
    deceleration too (a living body's) has its ``deceleration`` window, ``(start, end)`` (s);
    one whose fitted torque was stored (``inertial_torque``, a ``traces.csv`` written since
    it exists) has it too.
    """
    out: dict[str, list[dict]] = {}
    for (cond, _), rows in traces.groupby(["condition", "trial"], sort=False):
        trace = {
            "time": rows["time"].to_numpy(float),
            "velocity": rows["velocity"].to_numpy(float),
            "acceleration": rows["acceleration"].to_numpy(float),
            "window": (float(rows["window_start"].iloc[0]), float(rows["window_end"].iloc[0])),
            "speed": float(rows["speed"].iloc[0]),
        }
        if "inertial_torque" in rows and rows["inertial_torque"].notna().any():
            trace["inertial_torque"] = rows["inertial_torque"].to_numpy(float)
        if "deceleration_start" in rows and "deceleration_end" in rows:
            start = float(rows["deceleration_start"].iloc[0])
            end = float(rows["deceleration_end"].iloc[0])
            if np.isfinite(start) and np.isfinite(end):
                trace["deceleration"] = (start, end)
        out.setdefault(str(cond), []).append(trace)
    return out
