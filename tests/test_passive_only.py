"""Passive-only studies (issue 32, item 4): slow sweeps and holds without fast trials.

What every lab that corrects isokinetic torque for gravity, or measures passive stiffness,
records: the static curve with its band, its split into gravity and passive where the design
allows, the hysteresis, and the figure of the fit, from ``inertiafit run``. Files without a
velocity column (the real ankle's) get the angle's derivative (``derive_velocity``).
"""

import contextlib
import gzip
import io
import math
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.io import read_trial
from inertiafit.io.manifest import load_study
from inertiafit.io.trial import make_trial
from inertiafit.processing.study import process_study
from inertiafit.simulate import simulate_living_study

ANKLE = Path(__file__).parent / "data" / "tecchio-ankle"
SWEEPS = ("Pas_Long2Sho", "Pas_Sho2Long")
HOLDS = ("Pas_-15", "Pas_-10", "Pas_5", "Pas_10", "Pas_20", "Pas_25")

# -- a velocity derived from the angle ---------------------------------------------------------

RATE, SIGMA = 1000.0, math.radians(0.1)  # the real ankle's rate and angle noise


def _sine(seed=0, seconds=10.0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / RATE)
    w = 2 * math.pi * 0.2
    angle = math.radians(20.0) * np.sin(w * t)
    truth = math.radians(20.0) * w * np.cos(w * t)
    torque = 2.0 + 0.5 * angle
    return t, angle + rng.normal(0.0, SIGMA, t.size), truth, torque


def test_a_derived_velocity_has_the_savitzky_golay_slope_error():
    # A quadratic Savitzky-Golay derivative at a window's centre is the least-squares slope
    # of N samples: SD = sigma sqrt(12 / (N (N^2 - 1))) / step. 101 samples, 0.1 deg noise:
    # 0.34 deg/s. Over 10 000 samples (their errors correlated over 101) the RMS is
    # known to ~ +-5 %; the sine's own curvature adds < 0.01 deg/s.
    t, angle, truth, torque = _sine()
    trial = make_trial(t, angle, None, torque, source="sine.csv")
    assert trial.attrs["velocity_source"] == "derived"
    n = 101
    expected = SIGMA * math.sqrt(12.0 / (n * (n * n - 1))) * RATE
    inner = slice(n, -n)  # the window's ends fit one-sided
    rms = float(np.sqrt(np.mean((trial["velocity"].values - truth)[inner] ** 2)))
    assert rms == pytest.approx(expected, rel=0.15)
    # negative control: neighbours' differences multiply the noise by the rate
    naive = np.gradient(angle, t)
    assert np.sqrt(np.mean((naive - truth)[inner] ** 2)) > 20 * expected


def test_a_shorter_window_trades_noise_for_speed():
    t, angle, truth, torque = _sine(seed=1)
    short = make_trial(t, angle, None, torque, source="s.csv", velocity_window=0.02)
    long = make_trial(t, angle, None, torque, source="s.csv")
    err = [float(np.std((d["velocity"].values - truth)[200:-200])) for d in (short, long)]
    # 21 samples against 101: (101 / 21)^1.5 = 10.5x the noise
    assert err[0] / err[1] == pytest.approx(
        (101 * (101**2 - 1) / (21 * (21**2 - 1))) ** 0.5, rel=0.2
    )


def test_a_recorded_velocity_is_read_as_before():
    t, angle, truth, torque = _sine()
    assert "velocity_source" not in make_trial(t, angle, truth, torque, source="x").attrs


@pytest.mark.parametrize(
    ("window", "expected"),
    [
        (0.002, r"window 0\.002 s is 3 samples .* expected at least 5"),
        (100.0, r"at most the trial's 10000"),
        (-1.0, "expected a positive number of seconds"),
        (math.nan, "expected a positive number of seconds"),
    ],
)
def test_a_bad_window_is_one_line(window, expected):
    t, angle, _, torque = _sine()
    with pytest.raises(InputError, match=expected) as err:
        make_trial(t, angle, None, torque, source="sine.csv", velocity_window=window)
    assert str(err.value).startswith("sine.csv: velocity: ")
    assert "\n" not in str(err.value)


@pytest.fixture(scope="module")
def ankle_files(tmp_path_factory):
    """The real ankle's files as its export wrote them (uncompressed), no velocity column."""
    root = tmp_path_factory.mktemp("ankle")
    (root / "data").mkdir()
    for name in (*SWEEPS, *HOLDS):
        with gzip.open(ANKLE / f"{name}.csv.gz", "rb") as src:
            (root / "data" / f"{name}.csv").write_bytes(src.read())
    return root


ANKLE_COLUMNS = {"time": "time_s", "angle": "angle_deg", "torque": "torque_Nm"}


def test_the_csv_reader_derives_the_velocity(ankle_files):
    path = ankle_files / "data" / "Pas_Sho2Long.csv"
    trial = read_trial(path, columns=ANKLE_COLUMNS, derive_velocity=True)
    moving = np.abs(np.degrees(trial["velocity"].values)) > 2.0
    # the sweep runs at about 5 deg/s toward plantarflexion (angle increasing)
    assert np.median(np.degrees(trial["velocity"].values[moving])) == pytest.approx(5.0, abs=1.0)
    # without the option the file's missing velocity column is named
    with pytest.raises(InputError, match="velocity"):
        read_trial(path, columns=ANKLE_COLUMNS)


@pytest.mark.parametrize(
    ("kwargs", "expected"),
    [
        ({"derive_velocity": "yes"}, r"options\.derive_velocity: 'yes'; expected true, false"),
        (
            {"derive_velocity": True, "columns": {**ANKLE_COLUMNS, "velocity": "v"}},
            r"columns\.velocity: the velocity is derived from the angle",
        ),
        (
            {"derive_velocity": True, "units": {"velocity": "rad/s"}},
            r"units\.velocity: the velocity is derived",
        ),
        ({"derive_velocity": 0.001}, r"velocity: window 0\.001 s is 1 samples"),
    ],
)
def test_bad_derive_velocity_options_are_one_line(ankle_files, kwargs, expected):
    path = ankle_files / "data" / "Pas_5.csv"
    kwargs = {"columns": ANKLE_COLUMNS, **kwargs}
    with pytest.raises(InputError, match=expected) as err:
        read_trial(path, **kwargs)
    assert str(err.value).startswith(str(path))


# -- the real ankle from the command line ------------------------------------------------------

TUTORIAL = Path(__file__).parents[1] / "docs" / "tutorials" / "living-forearm.md"


def _tutorial_manifest() -> str:
    """The passive-only manifest the tutorial shows (its TOML block naming Tecchio)."""
    text = TUTORIAL.read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```toml\n")[1:]]
    (block,) = [b for b in blocks if "Tecchio" in b]
    return block


def _trial_entry(name, kind):
    return f'\n[[trials]]\nfile = "data/{name}.csv"\nbodies = ["foot"]\nkind = "{kind}"\n'


@pytest.fixture(scope="module")
def ankle_run(ankle_files):
    manifest = ankle_files / "study.toml"
    manifest.write_text(_tutorial_manifest(), encoding="utf-8")
    out = ankle_files / "out"
    said = io.StringIO()
    with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
        assert main(["run", str(manifest), "--out", str(out), "--seed", "2"]) == 0
    return out, said.getvalue()


def test_a_passive_only_study_runs_from_the_command_line(ankle_run):
    out, _ = ankle_run
    for name in ("passive.csv", "static_fit.csv", "passive_parameters.csv", "static-fit.png"):
        assert (out / name).is_file(), name
    trials = pd.read_csv(out / "trials.csv")
    assert list(trials["kind"]) == ["quasi-static"] * 2 + ["rest"] * 6
    assert (trials["status"] == "ok").all()


def test_the_static_curve_is_measured_where_its_split_is_not(ankle_run):
    curve = pd.read_csv(ankle_run[0] / "passive.csv")
    static = curve["static_upper:foot"] - curve["static_lower:foot"]
    passive = curve["upper"] - curve["lower"]
    # one posture: what the dynamometer reads is pinned to a few tenths of a N m over the
    # range, while its split into gravity and passive (the passive band, relative to mid-range)
    # is not: the prior's, several N m wide at the range's ends
    assert static.max() < 0.6
    assert passive.iloc[[0, -1]].min() > 5 * static.max()
    # and the static curve rises with the angle, as the sweeps do: -18 to -8 N m
    assert curve["static:foot"].iloc[0] == pytest.approx(-18.0, abs=1.0)
    assert curve["static:foot"].iloc[-1] == pytest.approx(-8.3, abs=1.0)


def test_each_hold_sits_within_its_band(ankle_run):
    points = pd.read_csv(ankle_run[0] / "static_fit.csv")
    holds = points[points["kind"] == "rest"]
    assert len(holds) == len(HOLDS)
    lo, hi = points.loc[points["kind"] != "rest", "joint_angle"].agg(["min", "max"])
    inside = holds[(holds["joint_angle"] > lo - 0.5) & (holds["joint_angle"] < hi + 0.5)]
    assert len(inside) == 5
    reach = inside["allowed"] + 1.96 * inside["fitted_sd"]
    assert (inside["residual"].abs() <= reach).all()
    # negative control: the curve's band alone, without the hysteresis a hold may sit within
    assert (inside["residual"].abs() > 1.96 * inside["fitted_sd"]).any()


def test_the_sweeps_leave_what_the_checks_flag(ankle_run):
    points = pd.read_csv(ankle_run[0] / "static_fit.csv")
    sweeps = points[points["kind"] == "quasi-static"]
    assert set(sweeps["direction"]) == {-1, 1}
    assert sweeps.groupby("source").size().max() <= 60
    trials = pd.read_csv(ankle_run[0] / "trials.csv").set_index("file")
    worst = sweeps.groupby("source")["residual"].agg(lambda r: r.abs().max())
    flagged = trials["flags"].fillna("").str.contains("static model misfit")
    # the sweep toward dorsiflexion holds the structure (up to ~0.6 N m mid-range); the
    # flag in trials.csv falls on the sweep whose residuals the table shows largest
    assert flagged[worst.idxmax()]


def test_what_is_not_measured_is_said(ankle_run):
    params = pd.read_csv(ankle_run[0] / "passive_parameters.csv").set_index("parameter")
    damping = params.loc["damping"]
    assert damping["pinned_by"].startswith("prior (no fast trials")
    assert (damping["mean"], damping["sd"]) == (damping["prior_mean"], damping["prior_sd"])
    assert not any(p.startswith("rotation:") for p in params.index)  # no postures declared
    ident = pd.read_csv(ankle_run[0] / "identification.csv")
    assert (ident["identified_by"] == "prior").all()
    said = ankle_run[1]
    assert "foot: the data measure none of its parameters" in said
    assert "without fast trials its I is not either" in said
    assert "the data identify m·x and I" not in said


# -- a simulated forearm in two postures, no fast trials -----------------------------------------


@pytest.fixture(scope="module")
def two_postures(tmp_path_factory):
    root = tmp_path_factory.mktemp("passive-only")
    manifest = simulate_living_study(
        root / "study", seed=3, postures="two", trials_per_speed=0, rigid_rotation_sweeps=True
    )
    truth = tomllib.loads((manifest.parent / "truth.toml").read_text(encoding="utf-8"))
    return process_study(load_study(manifest)), truth


def test_two_postures_split_gravity_from_the_passive_curve(two_postures):
    processed, truth = two_postures
    assert not (processed.trials["kind"] == "fast").any()
    statics = processed.living
    fit = statics.gravity_fit("attachment+forearm")
    true = truth["conditions"]["B"]["gravity_moment"]
    assert abs(fit.gravity_moment - true) < 3 * fit.gravity_moment_se
    assert fit.gravity_moment_se / true < 0.01  # the rotation sweep measures r: M_g to < 1 %
    assert statics.pinned_by("attachment+forearm") == "a second posture"
    assert processed.damping is None


def test_the_split_is_refused_its_data_with_one_posture(tmp_path):
    # negative control: the same study in one posture leaves M_g to the prior
    manifest = simulate_living_study(tmp_path / "one", seed=3, trials_per_speed=0)
    processed = process_study(load_study(manifest))
    assert not processed.living.gravity_identified
    assert processed.living.pinned_by("attachment+forearm") == "passive prior"
    assert any("without fast trials its I is not either" in w for w in processed.warnings)


def test_the_fit_table_names_the_files_as_trials_csv_does(ankle_files, tmp_path):
    # the static_fit table names every file as trials.csv does (relative to the manifest)
    root = tmp_path / "copy"
    shutil.copytree(ankle_files / "data", root / "data")
    manifest = tomllib.loads(_tutorial_manifest())
    keep = {"data/Pas_Sho2Long.csv", "data/Pas_10.csv", "data/Pas_Long2Sho.csv"}
    trials = [t for t in manifest["trials"] if t["file"] in keep]
    text = _tutorial_manifest().split("[bodies.foot]", 1)[1]
    head = "".join(_trial_entry(Path(t["file"]).stem, t["kind"]) for t in trials)
    (root / "study.toml").write_text(f"[bodies.foot]{text}{head}", encoding="utf-8")
    processed = process_study(load_study(root / "study.toml"))
    sources = set(processed.living.fit_points["source"])
    assert sources == {"data/Pas_Sho2Long.csv", "data/Pas_10.csv", "data/Pas_Long2Sho.csv"}


# -- the joint fit in posterior.nc, as DataTree groups (issue 32, item 7) -----------------------


def test_the_living_joint_is_a_group_xarray_and_arviz_open(ankle_run):
    import arviz
    import xarray as xr

    out, _ = ankle_run
    with xr.open_datatree(out / "posterior.nc", engine="h5netcdf") as tree:
        living = tree["living"]
        assert set(living.children) == {"parameters", "curve", "static_fit", "fit"}
        fit = living["fit"].to_dataset().load()
        curve = living["curve"].to_dataset().to_dataframe()
    # the fit whole: coefficients with their covariance, each trial's check, the hyper-grid
    names = [str(n) for n in fit["coefficient"].values]
    assert names[:2] == ["A:foot", "B:foot"]
    assert "hysteresis" in names
    cov = fit["covariance"].values
    np.testing.assert_allclose(cov, cov.T, rtol=1e-10)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    assert [str(t) for t in fit["trial"].values] == [f"data/{n}.csv" for n in (*SWEEPS, *HOLDS)]
    flagged = dict(zip(fit["trial"].values, fit["flagged"].values, strict=True))
    assert flagged["data/Pas_Long2Sho.csv"] == 1  # as trials.csv says
    assert float(fit["weight"].sum()) == pytest.approx(1.0)
    assert fit.attrs["gravity_identified"] == 0
    assert fit.attrs["curve"] == "smooth"
    # the tables are the CSV files' numbers (which keep 8 significant digits)
    written = pd.read_csv(out / "passive.csv")
    np.testing.assert_allclose(curve["static:foot"], written["static:foot"], rtol=1e-7)  # 8 digits
    # ArviZ opens the same file with the group in it
    assert "living" in arviz.from_netcdf(out / "posterior.nc").children


def test_a_posterior_written_before_the_group_still_reports(ankle_run, tmp_path):
    # older posterior.nc files kept the tables as JSON in the root attribute "inputs"
    import json

    from inertiafit.posterior import open_posterior
    from inertiafit.processing.living import living_tables_from_tree

    out, _ = ankle_run
    tree = open_posterior(out / "posterior.nc").tree
    now = living_tables_from_tree(tree)
    old = tree.copy()
    del old["living"]
    inputs = json.loads(old.attrs["inputs"])
    inputs["living"] = {k: v.to_dict(orient="list") for k, v in now.items()}
    old.attrs["inputs"] = json.dumps(inputs)
    before = living_tables_from_tree(old)
    for name, table in now.items():
        pd.testing.assert_frame_equal(before[name], table, check_dtype=False)
    # negative control: a rigid tree has no living tables at all
    del inputs["living"]
    old.attrs["inputs"] = json.dumps(inputs)
    assert living_tables_from_tree(old) == {}


def test_a_sweep_s_noise_model_ignores_a_repeated_column():
    # sweep_noise projects out what the design spans; a living sweep's constant and hysteresis
    # columns are the same column there. The span is found from the Gram matrix: the noise
    # model is the one of the design without the repeat, and of an SVD's basis
    from inertiafit.processing.gravity import sweep_noise

    rng = np.random.default_rng(3)
    n = 20_000
    t = np.linspace(0.0, 1.0, n)
    design = np.column_stack([np.ones(n), t, np.sin(np.pi * t), np.cos(np.pi * t)])
    drift = np.convolve(rng.normal(0.0, 0.02, n), np.ones(200) / np.sqrt(200), mode="same")
    torque = design @ [1.0, 2.0, 0.5, -0.3] + rng.normal(0.0, 0.05, n) + drift
    model = design @ np.linalg.lstsq(design, torque, rcond=None)[0]
    repeated = np.column_stack([design, design[:, 0]])
    u = np.linalg.svd(design, full_matrices=False)[0]
    one, two, svd = (sweep_noise(torque, model, x, 1000.0) for x in (design, repeated, u))
    for got in (two, svd):
        assert got.white_sd == pytest.approx(one.white_sd, rel=1e-9)
        assert got.drift_sd == pytest.approx(one.drift_sd, rel=1e-4)
        assert got.drift_time == pytest.approx(one.drift_time, rel=1e-3)
    assert one.white_sd == pytest.approx(0.05, rel=0.1)
    # the drift is found; white noise alone (negative control) leaves a far smaller one
    white = design @ [1.0, 2.0, 0.5, -0.3] + rng.normal(0.0, 0.05, n)
    fit = design @ np.linalg.lstsq(design, white, rcond=None)[0]
    assert sweep_noise(white, fit, repeated, 1000.0).drift_sd < 0.3 * one.drift_sd
