"""A living segment through the whole pipeline: simulated studies, run, report, redraw.

The coverage over many simulated studies is ``benchmarks/living_coverage.py``; here a small
seeded version of it and the outputs of ``inertiafit run`` and ``inertiafit report``.
"""

import json
import math
import pickle
import shutil
import sys
import tomllib
from pathlib import Path

import pandas as pd
import pytest

from inertiafit.cli import main
from inertiafit.pipeline.redraw import load_result
from inertiafit.posterior import open_posterior
from inertiafit.processing.living import CURVE_COLUMNS
from inertiafit.processing.study import LIVING_ROW_FLAG, process_study
from inertiafit.report import figures as figures_module
from inertiafit.report import outputs as outputs_module
from inertiafit.report.figures import figure_records
from inertiafit.simulate import simulate_living_study

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import living_coverage


@pytest.fixture(scope="module")
def living_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("living")
    manifest = simulate_living_study(root / "study", seed=4, postures="two", trials_per_speed=3)
    out = root / "out"
    assert main(["run", str(manifest), "--out", str(out), "--seed", "1"]) == 0
    return manifest, out


def test_run_writes_the_living_joint(living_run):
    manifest, out = living_run
    truth = tomllib.loads((manifest.parent / "truth.toml").read_text(encoding="utf-8"))
    params = pd.read_csv(out / "passive_parameters.csv").set_index("parameter")
    row = params.loc["gravity_moment:attachment+forearm"]
    assert row["lower"] <= truth["conditions"]["B"]["gravity_moment"] <= row["upper"]
    assert row["pinned_by"].startswith("a second posture")
    rotation = truth["passive"]["postures"]["rotated"]["gravity_rotation"]
    got = params.loc["rotation:rotated"]
    assert abs(got["mean"] - rotation) < 4 * got["sd"]
    assert {"stiffness", "hysteresis", "damping"} <= set(params.index)
    curve = pd.read_csv(out / "passive.csv")
    assert list(curve.columns[: len(CURVE_COLUMNS)]) == list(CURVE_COLUMNS)
    assert (curve["upper"] - curve["lower"]).min() > 0
    assert (out / "passive-curve.png").is_file()
    trials = pd.read_csv(out / "trials.csv")
    living_fast = trials[(trials["condition"] != "attachment") & (trials["kind"] == "fast")]
    assert living_fast["damping"].notna().all()
    assert set(trials["posture"]) == {"upright", "rotated"}
    assert (trials["kind"] == "rest").sum() == 6
    qs = trials[(trials["condition"] != "attachment") & (trials["kind"] == "quasi-static")]
    assert qs["flags"].str.contains(LIVING_ROW_FLAG, regex=False).all()
    summary = pd.read_csv(out / "summary.csv").set_index(["body", "parameter"])
    assert (
        summary.loc[("forearm", "damping"), "ess_bulk"]
        != summary.loc[("forearm", "damping"), "ess_bulk"]
    )  # NaN: not sampled
    assert (
        summary.loc[("forearm", "stiffness"), "hdi_lower"]
        < summary.loc[("forearm", "stiffness"), "hdi_upper"]
    )
    ident = pd.read_csv(out / "identification.csv").set_index(["body", "parameter"])
    assert (
        "living: M_g told from the passive curve by a second posture"
        in ident.loc[("forearm", "gravity_moment"), "pinned_by"]
    )
    assert "living" not in ident.loc[("attachment", "gravity_moment"), "pinned_by"]
    provenance = json.loads(open_posterior(out / "posterior.nc").attrs["provenance"])
    assert provenance["passive"]["path"].endswith("passive/elbow.toml")
    assert len(provenance["passive"]["sha256"]) == 64
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Living joint" in page
    assert "decided by" in page


def test_report_redraws_the_living_joint_from_the_folder(living_run, tmp_path, monkeypatch):
    _, out = living_run
    result = load_result(out)
    assert set(result.living) == {"passive_parameters", "passive_curve", "static_fit"}
    # a started pool of figure workers receives the records pickled
    records = figure_records(result)
    assert "passive-curve" in [r.stem for r in records]
    assert [pickle.loads(pickle.dumps(r)).stem for r in records] == [r.stem for r in records]
    # redrawn on a copy, the living joint's figure only (run drew every figure already)
    folder = tmp_path / "out"
    shutil.copytree(out, folder)
    (folder / "passive-curve.png").unlink()
    (folder / "passive_parameters.md").unlink()
    every = figures_module.figure_records
    monkeypatch.setattr(
        outputs_module,
        "figure_records",
        lambda res: [r for r in every(res) if r.stem == "passive-curve"],
    )
    assert main(["report", str(folder)]) == 0
    for name in ("passive_parameters.csv", "passive.csv", "static_fit.csv"):
        assert (folder / name).read_bytes() == (out / name).read_bytes(), name
    assert (folder / "passive_parameters.md").read_bytes() == (
        out / "passive_parameters.md"
    ).read_bytes()
    assert (folder / "passive-curve.png").is_file()
    assert "Living joint" in (folder / "report.html").read_text(encoding="utf-8")


def test_rigid_study_has_no_living_outputs(tmp_path):
    from inertiafit.simulate import simulate_study

    manifest = simulate_study(
        tmp_path / "s",
        bodies={"attachment": (2.9, 0.13, 0.225)},
        conditions=[("attachment",)],
        speeds=(240,),
        trials_per_speed=2,
    )
    processed = process_study(manifest)
    assert processed.living is None
    assert "posture" not in processed.trials.columns


@pytest.mark.slow
@pytest.mark.parametrize(("design", "seed"), [("one", 101), ("two", 102)])
def test_small_seeded_coverage_of_the_living_forearm(design, seed):
    # One study of the benchmark per design: the living posterior's median within 3.5
    # posterior SDs (the HDI width / 3.92) of the truth, for I and M_g; the rigid fit of the
    # same files reads the forearm's M_g more than 10 % high (the bias), or the
    # processing refuses that reading outright.
    r = living_coverage.one_study(design, seed, rigid_posterior=False)
    for q in ("I", "M_g"):
        sd = r[f"living {q} width"] / (2 * 1.96)
        assert abs(r[f"living {q} error"]) < 3.5 * sd, (q, r)
    assert "rigid refused" in r or r["rigid processed M_g error"] > 0.10, r
    assert math.isfinite(r["damping_z"])


def test_passive_curve_figure_draws_the_band_and_each_gravity_curve(living_run):
    from inertiafit.report.plots import plot_passive_curve

    _, out = living_run
    curve = pd.read_csv(out / "passive.csv")
    fig = plot_passive_curve(curve)
    (ax,) = fig.axes
    labels = [line.get_label() for line in ax.get_lines()]
    assert "passive elastic moment" in labels
    assert "gravity moment, attachment+forearm" in labels
    assert len(ax.collections) == 2  # the prior's band and the posterior's


@pytest.mark.slow
def test_living_bodies_pool_as_rigid_ones_do(living_run, monkeypatch):
    """Issue 33: a living body's draws pool into a population as a rigid body's do. Its stored
    interim density is its own prior's at each draw (the joint's parameters marginalised
    out), so the population divides out the right prior; three subjects with this study's
    data pool back to what each measured (I and M_g within 3 %), with the joint's parameters
    in no table. Short hyperparameter runs: the population's accuracy is test_population.py's."""
    import functools
    import warnings

    import numpy as np

    from inertiafit.errors import ConvergenceWarning, InertiafitWarning
    from inertiafit.inference import pooling
    from inertiafit.inference.priors import priors_from_posterior

    _, out = living_run
    monkeypatch.setattr(
        pooling, "fit_population", functools.partial(pooling.fit_population, max_steps=600)
    )
    posts = []
    for i, (mass, length) in enumerate(((70.0, 0.26), (78.0, 0.28), (86.0, 0.30))):
        post = open_posterior(out / "posterior.nc")
        subject = {"id": f"S{i + 1}", "body_mass": mass, "height": None, "sex": None}
        post.tree.attrs["inputs"] = json.dumps(
            {"subject": subject | {"covariates": {}}, "segment_length": {"forearm": length}}
        )
        posts.append(post)
    draws = pooling.subject_draws(
        pooling.StudyPosterior("S1", posts[0], None), "forearm", {"body_mass": 70.0}
    )
    theta = np.exp(draws.log_theta)
    prior = priors_from_posterior(posts[0])["forearm"].log_density(*theta.T)
    np.testing.assert_allclose(draws.log_interim - draws.log_interim.mean(),
                               prior - prior.mean(), atol=1e-9)  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        warnings.simplefilter("ignore", InertiafitWarning)
        pop = pooling.population(posts, bodies=["forearm"], seed=0)
    summary = pop.summary()
    assert set(summary["body"]) == {"forearm"}
    assert not summary["parameter"].str.contains("passive|damping|joint").any()
    subjects = pop.subjects()
    assert len(subjects) == 3 * 5
    ig = subjects[subjects["parameter"].isin(["inertia", "gravity_moment"])]
    np.testing.assert_allclose(ig["pooled_median"], ig["own_median"], rtol=0.03)
