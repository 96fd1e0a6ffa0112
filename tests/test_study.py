"""The whole pipeline on simulated studies with known truth, and every bad input of `run`."""

import re
import shutil
import tomllib

import numpy as np
import pandas as pd
import pytest
from cases import PRIORS, TRUTH

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.io.outputs import MARKER
from inertiafit.pipeline.study import DIAGNOSTICS, analyse_study
from inertiafit.processing.study import TRACE_COLUMNS, process_study
from inertiafit.simulate import simulate_study

CONDITIONS = [("attachment",), ("attachment", "weight")]


def truth_of(folder):
    return tomllib.loads((folder / "truth.toml").read_text(encoding="utf-8"))


def simulate(
    folder, seed, *, units=("deg", "N*m", "s"), trials_per_speed=5, speeds=(240, 270, 300)
):
    return simulate_study(
        folder,
        bodies=TRUTH,
        conditions=CONDITIONS,
        speeds=speeds,
        trials_per_speed=trials_per_speed,
        seed=seed,
        angle_unit=units[0],
        torque_unit=units[1],
        time_unit=units[2],
        phi=0.2,
        offset=1.5,
        priors=PRIORS,
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("seed", "units"),
    [(1, ("deg", "N*m", "s")), (2, ("rad", "ft*lbf", "ms")), (3, ("deg", "ft*lbf", "ms"))],
)
def test_pipeline_recovers_the_simulated_truth(tmp_path, seed, units):
    manifest = simulate(tmp_path / "study", seed, units=units)
    truth = truth_of(tmp_path / "study")
    result = analyse_study(manifest, seed=seed)
    trials = result.trials
    for label, cond in zip(("attachment", "attachment+weight"), ("A", "B"), strict=True):
        fast = trials[(trials.condition == label) & (trials.kind == "fast")]
        true_i = truth["conditions"][cond]["inertia"]
        assert fast.inertia.mean() == pytest.approx(true_i, rel=0.02)
        assert fast.inertia_frame_mean.mean() == pytest.approx(true_i, rel=0.05)
        qs = trials[(trials.condition == label) & (trials.kind == "quasi-static")]
        true_g = truth["conditions"][cond]["gravity_moment"]
        assert qs.gravity_moment.iloc[0] == pytest.approx(true_g, rel=0.01)
        assert qs.gravity_phase.iloc[0] == pytest.approx(0.2, abs=0.01)
        assert qs.offset.iloc[0] == pytest.approx(1.5, abs=0.1)
    post = result.posterior
    assert post.converged
    s = post.summary(0.95).set_index(["body", "parameter"])
    inside = []
    for body in ("attachment", "weight"):
        for p in ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment"):
            t = truth["bodies"][body][p]
            inside.append(s.loc[(body, p), "hdi_lower"] <= t <= s.loc[(body, p), "hdi_upper"])
    assert np.mean(inside) >= 0.8, inside
    # The attachment's uncertainty reaches the weight: its inertia is not simply B - A.
    assert (
        s.loc[("weight", "inertia"), "sd"]
        > s.loc[("attachment+weight" if False else "attachment", "inertia"), "sd"] * 0.5
    )


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("small") / "study"
    simulate(folder, 7, trials_per_speed=3, speeds=(240,))
    return folder


@pytest.mark.reproducibility
def test_same_seed_same_summary(small_study):
    a = analyse_study(small_study / "study.toml", seed=3).posterior.summary()
    b = analyse_study(small_study / "study.toml", seed=3).posterior.summary()
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def _copy(small_study, tmp_path):
    dst = tmp_path / "study"
    shutil.copytree(small_study, dst)
    return dst


def _edit(path, func):
    path.write_text(func(path.read_text(encoding="utf-8")))


def _edit_csv(path, func):
    df = pd.read_csv(path)
    func(df).to_csv(path, index=False)


def _fast(folder):
    return folder / "data" / "A_240_02.csv"


BAD = {
    "missing file": (lambda d: _fast(d).unlink(), r"A_240_02\.csv"),
    "unknown body": (
        lambda d: _edit(
            d / "study.toml",
            lambda t: t.replace(
                'bodies = ["attachment", "weight"]', 'bodies = ["attachment", "arm"]', 1
            ),
        ),
        r"unknown body 'arm'",
    ),
    "no quasi-static trial": (
        lambda d: _edit(
            d / "study.toml",
            lambda t: "[[trials]]".join(
                block for block in t.split("[[trials]]") if "B_quasistatic" not in block
            ),
        ),
        r"quasi-static",
    ),
    "misnamed column": (
        lambda d: _edit(_fast(d), lambda t: t.replace("torque", "moment", 1)),
        r"A_240_02\.csv.*torque",
    ),
    "unknown unit": (
        lambda d: _edit(
            d / "study.toml", lambda t: t.replace('torque = "N*m"', 'torque = "kgf*m"')
        ),
        r"kgf\*m",
    ),
    "NaN": (
        lambda d: _edit_csv(_fast(d), lambda f: f.assign(torque=f.torque.where(f.index != 50))),
        r"A_240_02\.csv.*torque",
    ),
    "gap": (
        lambda d: _edit_csv(_fast(d), lambda f: f.drop(index=range(100, 110))),
        r"A_240_02\.csv.*(gap|step)",
    ),
    "time not increasing": (
        lambda d: _edit_csv(
            _fast(d), lambda f: f.assign(time=np.where(f.index == 80, 0.0, f.time))
        ),
        r"A_240_02\.csv.*(increas|monoton)",
    ),
    "no acceleration window": (
        lambda d: _edit_csv(
            _fast(d), lambda f: f.assign(velocity=240.0, angle=np.linspace(0, 90, len(f)))
        ),
        r"A_240_02\.csv.*window",
    ),
    "sampling rate": (
        lambda d: _edit_csv(_fast(d), lambda f: f.iloc[::2]),
        r"A_240_02\.csv.*sampling rate",
    ),
    "negative inertia": (
        lambda d: _edit_csv(_fast(d), lambda f: f.assign(torque=-f.torque + 2 * 1.5)),
        r"A_240_02\.csv.*torque_sign",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_study_input_is_one_line_exit_2_and_leaves_nothing(
    small_study, tmp_path, capsys, case
):
    folder = _copy(small_study, tmp_path)
    corrupt, match = BAD[case]
    corrupt(folder)
    out = tmp_path / "out"
    assert main(["run", str(folder / "study.toml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("inertiafit: error: ")
    assert re.search(match, err), err
    # a trial that could not be used leaves its per-trial table, and nothing else (issue 21)
    assert not out.exists() or sorted(p.name for p in out.iterdir()) == [MARKER, DIAGNOSTICS]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]  # no temp left


def test_process_study_can_be_used_alone(small_study):
    processed = process_study(small_study / "study.toml")
    assert set(processed.gravity) == {"attachment", "attachment+weight"}
    traces = processed.traces
    assert list(traces.columns) == TRACE_COLUMNS
    assert traces[traces.condition == "attachment"]["trial"].nunique() == 3
    with pytest.raises(InputError, match="not found"):
        process_study(small_study / "nope.toml")


@pytest.mark.slow
def test_one_attachment_several_segments_share_its_uncertainty(tmp_path):
    truth = {
        "attachment": (2.85, 0.12, 0.24),
        "forearm1": (1.45, 0.06, 0.20),
        "forearm2": (1.60, 0.065, 0.21),
    }
    priors = {
        "attachment": PRIORS["attachment"],
        "forearm1": {"mass": 1.5, "radius_of_gyration": 0.07, "com_distance": 0.19},
        "forearm2": {"mass": 1.5, "radius_of_gyration": 0.07, "com_distance": 0.19},
    }
    manifest = simulate_study(
        tmp_path / "s",
        bodies=truth,
        conditions=[("attachment",), ("attachment", "forearm1"), ("attachment", "forearm2")],
        speeds=(240, 300),
        trials_per_speed=4,
        seed=5,
        phi=0.1,
        offset=-0.8,
        priors=priors,
    )
    result = analyse_study(manifest, seed=5)
    post = result.posterior
    assert post.converged
    assert post.bodies == ("attachment", "forearm1", "forearm2")
    s = post.summary(0.95).set_index(["body", "parameter"])
    for body, (m, rho, x) in truth.items():
        i_true = m * (rho**2 + x**2)
        assert (
            s.loc[(body, "inertia"), "hdi_lower"]
            <= i_true
            <= s.loc[(body, "inertia"), "hdi_upper"]
        )
        assert (
            s.loc[(body, "gravity_moment"), "hdi_lower"]
            <= m * 9.81 * x
            <= s.loc[(body, "gravity_moment"), "hdi_upper"]
        )
    # A heavier attachment leaves less for each segment: their inertias are anti-correlated.
    att = post.draws("attachment", "inertia").ravel()
    for seg in ("forearm1", "forearm2"):
        assert np.corrcoef(att, post.draws(seg, "inertia").ravel())[0, 1] < -0.3
    # and through the attachment the two segments are positively correlated
    r12 = np.corrcoef(
        post.draws("forearm1", "inertia").ravel(), post.draws("forearm2", "inertia").ravel()
    )[0, 1]
    assert r12 > 0.1


def test_several_quasi_static_trials_combine_by_inverse_variance():
    from inertiafit.processing.study import condition_gravity

    rows = pd.DataFrame(
        {
            "condition": ["A", "A", "B"],
            "kind": ["quasi-static"] * 3,
            "gravity_moment": [7.0, 7.3, 19.0],
            "gravity_moment_se": [0.1, 0.2, 0.05],
        }
    )
    # weights 100 and 25: (700 + 182.5) / 125
    assert condition_gravity(rows) == pytest.approx({"A": 7.06, "B": 19.0})


def test_a_larger_ess_target_stores_more_draws_and_is_recorded(small_study):
    """``ess_min`` (``--ess-min``): sampling goes on until every quantity's bulk ESS reaches
    it, so a population of studies gets more draws per subject; the target is in posterior.nc.
    The default (1000) is the negative control: the same study stops with fewer draws."""
    from inertiafit.pipeline.study import study_posterior

    default = study_posterior(small_study / "study.toml", seed=3)
    more = study_posterior(small_study / "study.toml", seed=3, ess_min=20_000)
    assert default.attrs["ess_min_target"] == 1000
    assert more.attrs["ess_min_target"] == 20_000
    assert more.summary()["ess_bulk"].min() >= 20_000
    assert default.summary()["ess_bulk"].min() < 20_000
    assert more.draws("attachment", "mass").size >= 2 * default.draws("attachment", "mass").size


@pytest.mark.parametrize("bad", [50, 1e6, float("nan")])
def test_a_bad_ess_target_is_one_line_before_any_work(small_study, tmp_path, capsys, bad):
    out = tmp_path / "out"  # (text that is no number is argparse's: tested with every option)
    argv = ["run", str(small_study / "study.toml"), "--out", str(out), "--ess-min", str(bad)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("inertiafit: error: --ess-min: expected a number in [100, 100000]")
    assert not out.exists()
    with pytest.raises(InputError, match=r"^ess_min: expected a number in \[100, 100000\]"):
        analyse_study(small_study / "study.toml", ess_min=bad)
