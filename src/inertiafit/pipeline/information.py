"""How much each piece of information pins ``m``, ``x`` and ``rho``: the demo's last part.

Rotation about one axis identifies ``m x`` and ``I``; where ``(m, x, rho)`` sit on the curve
of those two values is the prior's call unless something else speaks. Two cases, each fitted
several times on the same processed trials with one more piece of information each time:

* the paper's 3 kg weight (the demo's simulated study): its ±50 % box, then the box and its
  mass read off a scale (SD 5 g; the reading is the simulated truth plus that error);
* a forearm + hand on the elbow attachment (a simulated 72.5 kg man, forearm 0.27 m long):
  a ±50 % box around the de Leva (1996) values, then the de Leva prior itself
  (:func:`inertiafit.inference.priors.anthropometric_prior`); the attachment's own box, then
  the box and the attachment weighed (in the same fit as the de Leva prior: weighing the
  attachment says nothing about where the forearm sits on its curve).

For every fit the 95 % HDI widths of ``m``, ``x`` and ``rho`` and how many times narrower
they are than with the box alone are printed and written to ``information.csv``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from inertiafit.inference.evidence import condition_evidence, study_priors
from inertiafit.inference.fit import fit
from inertiafit.inference.model import Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior, anthropometric_prior
from inertiafit.io.manifest import load_study
from inertiafit.io.outputs import write_csv
from inertiafit.physics import PARAMETERS
from inertiafit.posterior.pins import SHORT
from inertiafit.processing.study import ProcessedStudy, process_study
from inertiafit.simulate import PAPER_TRUTH, Noise, simulate_study

__all__ = ["FOREARM", "information_table", "run_information_demo"]

#: The simulated subject of the forearm case: de Leva (1996) male, body mass and forearm length.
FOREARM: dict[str, str | float] = {
    "anthropometric": "de-leva-male",
    "segment": "forearm+hand",
    "body_mass": 72.5,
    "segment_length": 0.27,
}
#: SD of a kitchen scale reading (kg).
SCALE_SD = 0.005


def _box_like(prior: Prior, name: str) -> Prior:
    """A ±50 % box around a prior's nominal values: what a lab without a table would use."""
    n = prior.nominal
    return Prior.box(
        name,
        mass=n["mass"],
        com_distance=n["com_distance"],
        radius_of_gyration=n["radius_of_gyration"],
        spread=0.5,
    )


def _fit_widths(
    processed: ProcessedStudy,
    priors: Mapping[str, Prior],
    measured: Mapping[str, Mapping[str, Observation]],
    seed: int,
    hdi_prob: float,
) -> dict[str, dict[str, float]]:
    """Fit the processed study with these priors and measurements: HDI widths per body."""
    study = processed.study
    model = Model(
        priors,
        condition_evidence(processed),
        gravity=study.gravity,
        torque_gain_sd=study.calibration.torque_gain_sd,
        measured=measured,
    )
    summary = fit(model, seed=seed).summary(hdi_prob)
    width = summary["hdi_upper"] - summary["hdi_lower"]
    return {
        body: {p: float(width[(summary["body"] == body) & (summary["parameter"] == p)].iloc[0])
               for p in PARAMETERS}
        for body in model.bodies
    }  # fmt: skip


def information_table(rows: list[dict]) -> pd.DataFrame:
    """Rows of ``body``, ``information`` and a width per parameter → with ``x narrower``."""
    frame = pd.DataFrame(rows)
    for p in PARAMETERS:
        base = frame.groupby("body")[p].transform("first")
        frame[f"{p}_narrower"] = base / frame[p]
    return frame


def _text(frame: pd.DataFrame, hdi_prob: float) -> str:
    head = f"{'body':<10} {'information':<46}" + "".join(
        f"{SHORT[p] + ' HDI width':>17}" for p in PARAMETERS
    )
    title = (
        f"How the {100 * hdi_prob:g} % HDIs of m, x and rho shrink with each piece of "
        "information (widths in kg, m, m; times narrower than the box)"
    )
    lines = [
        title,
        head,
        "-" * len(head),
    ]
    for _, r in frame.iterrows():
        cells = "".join(f"{r[p]:>10.3g} ({r[f'{p}_narrower']:>4.1f}x)" for p in PARAMETERS)
        lines.append(f"{r['body']:<10} {r['information']:<46}{cells}")
    return "\n".join(lines)


def run_information_demo(
    out: str | Path,
    manifest: str | Path,
    *,
    seed: int = 0,
    hdi_prob: float = 0.95,
    echo: Callable[[str], None] = print,
    say: Callable[[str], None] = lambda _msg: None,
) -> pd.DataFrame:
    """The two cases of the module docstring on the demo's simulated paper study ``manifest``.

    ``manifest`` was written by :func:`inertiafit.simulate.paper_study`, whose truth is
    :data:`~inertiafit.simulate.PAPER_TRUTH`. Writes ``out/information.csv`` and
    ``out/forearm-study/`` (the simulated forearm trials); returns the table.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([seed, 13])
    rows: list[dict] = []

    # 1. The paper's weight, weighed.
    say("fitting the paper's weight again with its mass weighed")
    study = load_study(manifest)
    processed = process_study(study)
    priors = study_priors(study)
    truth = {
        name: {p: float(getattr(body, p)) for p in PARAMETERS}
        for name, body in PAPER_TRUTH.items()
    }
    reading = truth["weight"]["mass"] + SCALE_SD * rng.standard_normal()
    weighed = Observation.from_mean_se(reading, SCALE_SD, where="weighed mass")
    for label, measured in (
        ("prior box (±50 %)", {}),
        (f"box + weighed mass ({reading:.3f} ± {SCALE_SD:g} kg)", {"weight": {"mass": weighed}}),
    ):
        widths = _fit_widths(processed, priors, measured, seed, hdi_prob)
        rows.append({"body": "weight", "information": label, **widths["weight"]})

    # 2. A forearm + hand on the attachment, de Leva prior.
    say("simulating a forearm + hand on the elbow attachment (de Leva 1996, 72.5 kg man)")
    de_leva = anthropometric_prior(
        "de-leva-male",
        "forearm+hand",
        72.5,
        0.27,
        name="forearm",
    )
    draw = de_leva.sample(1, rng)
    forearm = {p: float(draw[p][0]) for p in PARAMETERS}
    attachment = truth["attachment"]
    forearm_manifest = simulate_study(
        out / "forearm-study",
        bodies={
            "attachment": (
                attachment["mass"],
                attachment["radius_of_gyration"],
                attachment["com_distance"],
            ),
            "forearm": (
                forearm["mass"],
                forearm["radius_of_gyration"],
                forearm["com_distance"],
            ),
        },
        conditions=[("attachment",), ("attachment", "forearm")],
        trials_per_speed=5,
        seed=seed,
        noise=Noise.paper(),
        priors={"attachment": "biodex-elbow-attachment", "forearm": dict(FOREARM)},
        name="Forearm + hand on the elbow attachment (simulated)",
    )
    study = load_study(forearm_manifest)
    say("processing the forearm study")
    processed = process_study(study)
    base = study_priors(study)
    att_reading = attachment["mass"] + SCALE_SD * rng.standard_normal()
    att_weighed = {"attachment": {"mass": Observation.from_mean_se(att_reading, SCALE_SD)}}
    box = _fit_widths(processed, {**base, "forearm": _box_like(de_leva, "forearm")}, {}, seed,
                      hdi_prob)  # fmt: skip
    informed = _fit_widths(processed, {**base, "forearm": de_leva}, att_weighed, seed, hdi_prob)
    rows += [
        {"body": "forearm", "information": "prior box (±50 % around de Leva)", **box["forearm"]},
        {"body": "forearm", "information": "de Leva (1996) male prior", **informed["forearm"]},
        {"body": "attachment", "information": "prior box (±50 %)", **box["attachment"]},
        {
            "body": "attachment",
            "information": f"box + weighed mass ({att_reading:.3f} ± {SCALE_SD:g} kg)",
            **informed["attachment"],
        },
    ]
    frame = information_table(rows)
    write_csv(frame, out / "information.csv")
    echo(_text(frame, hdi_prob))
    return frame
