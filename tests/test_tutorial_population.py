"""docs/tutorials/population.md runs as printed, and what it shows holds (issue 33, item 6).

The tutorial's ``python`` and ``sh`` blocks are run in order, literally, in an empty folder, by
the runner every tutorial's test shares (``tests/tutorials.py``): the Python blocks in one
namespace (as one session would), each shell block as a script with this environment's ``bin``
first on ``PATH``. It simulates a cohort of 20 subjects,
fits them with ``run-many``, pools them with ``population``, predicts a new subject and fits
the next study under the population's prior. The checks compare the outputs with the truth the
simulation wrote (``truth.toml``) and with de Leva's tables.
"""

import json
import math
import os
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import once_per_run
from tutorials import TUTORIALS, blocks, run_tutorial

from inertiafit import open_posterior
from inertiafit.inference.anthropometric import segment_values
from inertiafit.physics import GRAVITY

# About 5 minutes on two cores (20 studies through run-many, then the population): more than
# the whole suite's budget, so `make tutorials` runs it (INERTIAFIT_TUTORIALS=1), not
# `make test`.
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        os.environ.get("INERTIAFIT_TUTORIALS") != "1",
        reason="the population tutorial takes about 5 minutes: make tutorials",
    ),
]

TUTORIAL = TUTORIALS / "population.md"
SUBJECTS = [f"S{i:02d}" for i in range(1, 21)]
QUANTITIES = ["mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment"]


def _run_tutorial(folder: Path) -> None:
    """Every python and sh block of the tutorial, in order, in ``folder``; logs beside."""
    session = run_tutorial(TUTORIAL, folder, timeout=1800)
    session.namespace["prediction"].to_csv(folder / "prediction.csv", index=False)


@pytest.fixture(scope="session")
def tutorial(tmp_path_factory) -> Path:
    """The folder the tutorial ran in (once per test run, shared by xdist's processes)."""
    return once_per_run(tmp_path_factory, "population-tutorial", _run_tutorial)


def _truth(folder: Path, subject: str) -> dict[str, float]:
    with (folder / subject / "truth.toml").open("rb") as f:
        return tomllib.load(f)["bodies"]["forearm"]


def _covariates(folder: Path, subject: str) -> tuple[float, float]:
    with (folder / subject / "study.toml").open("rb") as f:
        manifest = tomllib.load(f)
    return manifest["subject"]["body_mass"], manifest["bodies"]["forearm"]["segment_length"]


def _cohort(folder: Path) -> pd.DataFrame:
    """Each subject's covariates and true parameters."""
    rows = []
    for s in SUBJECTS:
        body_mass, length = _covariates(folder / "cohort", s)
        rows.append({"subject": s, "body_mass": body_mass, "segment_length": length}
                    | _truth(folder / "cohort", s))  # fmt: skip
    return pd.DataFrame(rows).set_index("subject")


def test_the_tutorial_s_manifests_are_the_ones_written(tutorial):
    # the TOML the page shows is what the simulation wrote (the comment line aside)
    first, second = (block.code for block in blocks(TUTORIAL, "toml"))
    for block, manifest in ((first, "cohort/S01/study.toml"), (second, "S21/study.toml")):
        written = (tutorial / manifest).read_text(encoding="utf-8").splitlines()
        for line in block.splitlines():
            if line.strip() and not line.startswith("#"):
                assert line in written, (manifest, line)


def test_every_subject_is_fitted_and_pooled(tutorial):
    batch = pd.read_csv(tutorial / "cohort-fits" / "batch.csv")
    assert len(batch) == 20
    assert (batch["status"] == "ok").all()
    subjects = pd.read_csv(tutorial / "cohort-population" / "subjects.csv")
    assert sorted(set(subjects["subject"])) == SUBJECTS
    assert set(subjects["body"]) == {"forearm"}
    assert len(subjects) == 20 * 5
    assert (subjects["importance_ess"] >= 30).all()
    log = (tutorial / "tutorial.log").read_text(encoding="utf-8")
    assert "population of 'forearm': 20 subjects" in log
    for name in ("population.csv", "population.nc", "population-tables.csv", "report.html"):
        assert (tutorial / "cohort-population" / name).is_file(), name


def test_the_typical_subject_holds_the_cohort_s_truth(tutorial):
    # The cohort's own typical subject: each true log parameter regressed on its covariate
    # (log body mass for m, log forearm length for x and rho) at the population's reference
    # (the geometric means), the intercepts then combined into I and M_g as population.csv does
    cohort = _cohort(tutorial)
    table = pd.read_csv(tutorial / "cohort-population" / "population.csv")
    typical = table[(table["body"] == "forearm") & (table["term"] == "typical")]
    typical = typical.set_index("parameter")
    covariate = {"mass": "body_mass", "com_distance": "segment_length",
                 "radius_of_gyration": "segment_length"}  # fmt: skip
    at = {}
    for p, c in covariate.items():
        x = np.log(cohort[c]) - np.log(cohort[c]).mean()
        _slope, intercept = np.polyfit(x, np.log(cohort[p]), 1)
        at[p] = math.exp(intercept)
    true_inertia = at["mass"] * (at["radius_of_gyration"] ** 2 + at["com_distance"] ** 2)
    true_moment = at["mass"] * GRAVITY * at["com_distance"]
    for p, true in (("inertia", true_inertia), ("gravity_moment", true_moment)):
        row = typical.loc[p]
        assert row["hdi_lower"] < true < row["hdi_upper"], (p, true, row.to_dict())
        # measured: a few per cent wide, decided by the subjects
        assert (row["hdi_upper"] - row["hdi_lower"]) / row["median"] < 0.15
        assert row["decided_by"] == "data"
    # the subjects' scatter (8 % drawn) is found, and the correlations are the hyperprior's
    scatter = table[table["term"] == "scatter"]
    assert ((scatter["hdi_lower"] < 0.08) & (scatter["hdi_upper"] > 0.08)).all()
    correlations = table[table["term"].str.startswith("correlation")]
    assert (correlations["decided_by"] == "prior").all()


def test_each_subject_keeps_what_it_measured(tutorial):
    # Three fast trials measure each subject's I to a few per cent (up to 4.4 % off here) and
    # pooling leaves it, and M_g, where his own study put it
    subjects = pd.read_csv(tutorial / "cohort-population" / "subjects.csv")
    for p in ("inertia", "gravity_moment"):
        rows = subjects[subjects["parameter"] == p].set_index("subject")
        true = pd.Series({s: _truth(tutorial / "cohort", s)[p] for s in SUBJECTS})
        error = (rows["pooled_median"] / true - 1).abs()
        assert error.max() < 0.05, (p, error.round(4).to_dict())
        moved = (rows["pooled_median"] / rows["own_median"] - 1).abs()
        assert moved.max() < 0.01, (p, moved.round(4).to_dict())
        inside = (rows["pooled_hdi_lower"] < true) & (true < rows["pooled_hdi_upper"])
        assert inside.sum() >= 17, (p, inside.to_dict())
    # ... while m, x and rho, which the data leave on a ridge, are not narrowed (the tutorial
    # says so): the population places them no better than each subject's de Leva prior did
    ridge = subjects[subjects["parameter"].isin(QUANTITIES[:3])]
    assert (ridge.groupby("parameter")["width_ratio"].median() > 1.0).all()


def test_the_tables_bias_on_these_subjects_is_the_cohort_s(tutorial):
    # de Leva against the truth: the tables' bias the report states is the cohort's own
    cohort = _cohort(tutorial)
    tables = pd.read_csv(tutorial / "cohort-population" / "population-tables.csv")
    row = tables[(tables["table"] == "de-leva-male") & (tables["parameter"] == "inertia")].iloc[0]
    de_leva = [
        segment_values("de-leva-male", "forearm+hand", bm, length).inertia
        for bm, length in zip(cohort["body_mass"], cohort["segment_length"], strict=True)
    ]
    bias = 100 * (math.exp(np.mean(np.log(np.array(de_leva) / cohort["inertia"]))) - 1)
    assert row["bias_lower_percent"] < bias < row["bias_upper_percent"], (bias, row.to_dict())
    assert row["n_subjects"] == 20


def test_the_prediction_is_near_de_leva_s(tutorial):
    # the cohort is de Leva's values with an 8 % scatter: a new subject's predictive interval
    # holds de Leva's value for him, and its median is within 25 % of it
    prediction = pd.read_csv(tutorial / "prediction.csv").set_index("parameter")
    assert list(prediction.index) == QUANTITIES
    dl = segment_values("de-leva-male", "forearm+hand", 80.0, 0.28)
    table = {p: getattr(dl, p) for p in QUANTITIES[:4]}
    table["gravity_moment"] = dl.mass * GRAVITY * dl.com_distance
    for p, value in table.items():
        row = prediction.loc[p]
        assert row["hdi_lower"] < value < row["hdi_upper"], (p, value, row.to_dict())
        assert abs(row["median"] / value - 1) < 0.25, (p, value, row.to_dict())


def test_the_next_study_starts_from_the_population(tutorial):
    fit = tutorial / "S21-fit"
    summary = pd.read_csv(fit / "summary.csv").set_index("parameter")
    truth = _truth(tutorial, "S21")
    for p in ("inertia", "gravity_moment"):
        assert summary.loc[p, "median"] == pytest.approx(truth[p], rel=0.03)
    # its prior is the population's prediction for him: the same medians (other draws)
    priors = json.loads(open_posterior(fit / "posterior.nc").attrs["priors"])["forearm"]
    assert priors["description"].startswith("population of 'forearm' (20 subjects)")
    prediction = pd.read_csv(tutorial / "prediction.csv").set_index("parameter")
    for p in QUANTITIES[:3]:
        assert priors["distribution"][p]["kind"] == "lognormal"
        median = priors["distribution"][p]["median"]
        assert median == pytest.approx(prediction.loc[p, "median"], rel=0.02), p
