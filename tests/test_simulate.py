"""Simulated trials and studies: the physics, the imperfections, the files on disk."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from inertiafit.simulate import (
    FT_LBF,
    PAPER_PRIORS,
    PAPER_TRUTH,
    Motion,
    Noise,
    paper_study,
    simulate_study,
    simulate_trial,
)

DEG = math.pi / 180


def exact(**kwargs):
    """A trial without any noise, ripple or quantisation."""
    kwargs.setdefault("noise", Noise.none())
    return simulate_trial(inertia=0.2052, gravity_moment=6.71, **kwargs)


def test_trial_layout_matches_the_reader_contract():
    trial = simulate_trial(inertia=0.2, gravity_moment=6.7, rng=0, source="x.csv")
    assert list(trial.data_vars) == ["angle", "velocity", "torque"]
    assert trial["time"].dtype == np.float64
    assert np.all(np.diff(trial["time"].values) > 0)
    assert {k: trial[k].attrs["units"] for k in ("time", "angle", "velocity", "torque")} == {
        "time": "s",
        "angle": "rad",
        "velocity": "rad/s",
        "torque": "N m",
    }
    assert all(trial[k].dtype == np.float64 for k in trial.data_vars)
    assert trial.attrs["source"] == "x.csv"
    assert trial.attrs["sampling_rate"] == 1000.0
    assert isinstance(trial.attrs["format"], str)


def test_noise_free_torque_is_the_rigid_body_equation():
    trial = exact(speed_deg_s=270, phi=0.2, offset=1.5)
    t = trial["time"].values
    theta = trial["angle"].values
    # Acceleration of the trapezoid: +a in the ramp, 0 at speed, -a in the braking.
    a = 2000 * DEG
    alpha = np.zeros_like(t)
    r0, r1 = trial.attrs["ramp_start"], trial.attrs["ramp_end"]
    alpha[(t >= r0) & (t < r1)] = a
    t_flat = (math.pi / 2 - 270 * DEG * (r1 - r0)) / (270 * DEG)
    alpha[(t >= r1 + t_flat) & (t < r1 + t_flat + (r1 - r0))] = -a
    expected = 0.2052 * alpha + 6.71 * np.sin(theta + 0.2) + 1.5
    # Samples at the corners of the trapezoid are assigned by their exact time.
    assert np.mean(np.isclose(trial["torque"].values, expected, atol=1e-9)) > 0.995
    assert r1 - r0 == pytest.approx(270 / 2000)
    assert trial["velocity"].max() == pytest.approx(270 * DEG)
    assert theta[0] == 0.0
    assert theta[-1] == pytest.approx(math.pi / 2, abs=1e-6)


@pytest.mark.parametrize("speed", [120, 180, 210, 240, 300])
def test_a_ramp_corner_on_a_sample_puts_no_extra_inertia_in_the_torque(speed):
    """The ramps' corners fall on samples (0.2 s + 60, 90, ... ms at 1 kHz).

    Their acceleration was the ramp's or zero by the rounding of the times; the velocity's
    central difference shows half of it, so at 180, 210 and 300 deg/s the torque held half a
    sample of ``I alpha`` more than the motion and the inertia read +0.3 to +0.5 % high.
    """
    from inertiafit.processing.gravity import fit_gravity
    from inertiafit.processing.inertia import estimate_inertia

    static = exact(kind="quasi-static", speed_deg_s=4, phi=0.2)
    fast = exact(speed_deg_s=speed, phi=0.2)
    t = fast["time"].values
    on_corner = np.isclose(t, fast.attrs["ramp_end"], rtol=0, atol=1e-9).any()
    assert on_corner  # the case under test
    estimate = estimate_inertia(fast, fit_gravity(static), lag=0.0)
    # the filter's rounding of the corners alone: -0.025 % at 120 deg/s, less above
    assert estimate.inertia / 0.2052 - 1 == pytest.approx(0.0, abs=3e-4)


def test_quasi_static_trial_is_90_s_at_1_khz():
    trial = simulate_trial(inertia=0.2, gravity_moment=6.7, kind="quasi-static", rng=1)
    assert trial.sizes["time"] >= 90_000
    assert trial.attrs["speed"] == 1.0
    assert np.median(np.abs(trial["velocity"].values)) == pytest.approx(1 * DEG, rel=0.1)


def test_angle_is_quantised_and_noise_has_the_requested_size():
    noise = Noise(torque_sd=0.4, velocity_sd=0.01, ripple=0, drift_sd=0, angle_step=0.1 * DEG)
    trial = simulate_trial(inertia=0.2, gravity_moment=0.0, noise=noise, rng=3)
    steps = trial["angle"].values / (0.1 * DEG)
    assert np.allclose(steps, np.round(steps), atol=1e-9)
    quiet = trial["time"].values < 0.19  # at rest before the move: torque = noise only
    assert np.std(trial["torque"].values[quiet]) == pytest.approx(0.4, rel=0.15)
    assert np.std(trial["velocity"].values[quiet]) == pytest.approx(0.01, rel=0.15)


@pytest.mark.reproducibility
def test_same_seed_same_trial_different_seed_different_trial():
    a = simulate_trial(inertia=0.2, gravity_moment=6.7, rng=7)
    b = simulate_trial(inertia=0.2, gravity_moment=6.7, rng=7)
    c = simulate_trial(inertia=0.2, gravity_moment=6.7, rng=8)
    assert a.identical(b)
    assert not np.array_equal(a["torque"].values, c["torque"].values)


def test_overshoot_and_reverse_direction():
    motion = Motion(start=90 * DEG, end=0.0, overshoot=0.1)
    trial = exact(speed_deg_s=300, motion=motion)
    v = trial["velocity"].values
    assert v.min() == pytest.approx(-330 * DEG, rel=1e-3)
    assert trial["angle"].values[-1] == pytest.approx(0.0, abs=1e-4)


def test_short_range_gives_a_triangular_profile():
    trial = exact(speed_deg_s=300, motion=Motion(end=10 * DEG))
    peak = math.sqrt(2000 * DEG * 10 * DEG)
    # The corner falls between samples: within one sample's change of velocity.
    assert trial["velocity"].max() == pytest.approx(peak, abs=2000 * DEG * 1e-3)
    assert trial["angle"].values[-1] == pytest.approx(10 * DEG, abs=1e-4)


def test_paper_noise_gives_the_paper_scatter():
    rng = np.random.default_rng(0)
    shifts = [
        simulate_trial(inertia=0.2, gravity_moment=0, noise=Noise.paper(), rng=rng).attrs[
            "true_offset"
        ]
        for _ in range(200)
    ]
    # The per-trial shift over the ramp's acceleration is the paper's 0.017 kg m^2 SD.
    assert np.std(shifts) / (2000 * DEG) == pytest.approx(0.017, rel=0.15)


def test_bad_arguments():
    with pytest.raises(ValueError, match="kind"):
        simulate_trial(inertia=0.2, gravity_moment=6.7, kind="slow")
    with pytest.raises(ValueError, match="positive"):
        simulate_trial(inertia=0.2, gravity_moment=6.7, speed_deg_s=0)


def read_csv(path, units):
    """Tiny reader for the simulator's CSV (the project's readers live in inertiafit.io)."""
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    header = path.read_text(encoding="utf-8").splitlines()[0]
    assert header == "time,angle,velocity,torque"
    factors = {"s": 1, "ms": 1e-3, "deg": DEG, "rad": 1, "N*m": 1, "ft*lbf": FT_LBF}
    time_ = data[:, 0] * factors[units["time"]]
    ang = factors[units["angle"]]
    return time_, data[:, 1] * ang, data[:, 2] * ang, data[:, 3] * factors[units["torque"]]


@pytest.mark.parametrize(
    ("angle_unit", "torque_unit", "time_unit"), [("deg", "N*m", "s"), ("rad", "ft*lbf", "ms")]
)
def test_study_files_and_manifest(tmp_path, angle_unit, torque_unit, time_unit):
    bodies = {"arm": (1.5, 0.08, 0.15), "disk": (1.0, 0.03, 0.3)}
    manifest = simulate_study(
        tmp_path / "study",
        bodies=bodies,
        conditions=[("arm",), ("arm", "disk")],
        speeds=(240, 300),
        trials_per_speed=2,
        seed=4,
        angle_unit=angle_unit,
        torque_unit=torque_unit,
        time_unit=time_unit,
        phi=0.1,
        offset=0.5,
        priors={"disk": "disk-3kg"},
    )
    doc = tomllib.loads(manifest.read_text(encoding="utf-8"))
    assert doc["bodies"]["arm"]["prior"] == {
        "mass": 1.5,
        "radius_of_gyration": 0.08,
        "com_distance": 0.15,
    }
    assert doc["bodies"]["disk"]["prior"] == "disk-3kg"
    units = doc["defaults"]["units"]
    assert units == {
        "time": time_unit,
        "angle": angle_unit,
        "velocity": f"{angle_unit}/s",
        "torque": torque_unit,
    }
    trials = doc["trials"]
    assert len(trials) == 2 * (1 + 2 * 2)
    assert [t["kind"] for t in trials].count("quasi-static") == 2
    assert {t.get("speed") for t in trials} == {None, 240.0, 300.0}
    assert trials[-1]["bodies"] == ["arm", "disk"]
    for entry in trials:
        assert (manifest.parent / entry["file"]).is_file()

    # Values in the file, converted back to SI, are the simulated trial's.
    fast = next(t for t in trials if t.get("speed") == 300.0)
    time_, angle, velocity, torque = read_csv(manifest.parent / fast["file"], units)
    assert np.all(np.diff(time_) > 0)
    assert time_[1] - time_[0] == pytest.approx(1e-3)
    assert angle.max() == pytest.approx(math.pi / 2, abs=0.2 * DEG)
    assert velocity.max() == pytest.approx(300 * DEG, rel=0.03)
    truth = tomllib.loads((manifest.parent / "truth.toml").read_text(encoding="utf-8"))
    assert truth["conditions"]["B"]["inertia"] == pytest.approx(
        1.5 * (0.08**2 + 0.15**2) + 1.0 * (0.03**2 + 0.3**2)
    )
    assert truth["conditions"]["A"]["gravity_moment"] == pytest.approx(1.5 * 9.81 * 0.15)
    # The peak torque during the ramp is I alpha + gravity: ft*lbf files hold smaller numbers.
    assert np.abs(torque).max() < 20


def test_study_rejects_unknown_units_and_bodies(tmp_path):
    with pytest.raises(ValueError, match="unit"):
        simulate_study(
            tmp_path, bodies={"a": (1, 0.1, 0.1)}, conditions=[("a",)], angle_unit="grad"
        )
    with pytest.raises(ValueError, match="unknown body"):
        simulate_study(tmp_path, bodies={"a": (1, 0.1, 0.1)}, conditions=[("a", "b")])


def test_paper_study_is_62_trials_with_the_paper_priors(tmp_path):
    # How long writing it takes is for benchmarks/processing.py, not for a unit test.
    manifest = paper_study(tmp_path / "paper", seed=1)
    doc = tomllib.loads(manifest.read_text(encoding="utf-8"))
    assert len(doc["trials"]) == 62
    assert len(list((tmp_path / "paper" / "data").glob("*.csv"))) == 62
    assert doc["bodies"]["attachment"]["prior"]["mass"] == 2.91
    assert doc["bodies"]["attachment"]["prior"]["com_distance"] == 0.225
    assert doc["bodies"]["weight"]["prior"] == PAPER_PRIORS["weight"]
    speeds = [t.get("speed") for t in doc["trials"]]
    assert speeds.count(240.0) == speeds.count(270.0) == speeds.count(300.0) == 20
    truth = tomllib.loads((tmp_path / "paper" / "truth.toml").read_text(encoding="utf-8"))
    assert truth["bodies"]["attachment"]["inertia"] == pytest.approx(
        PAPER_TRUTH["attachment"].inertia
    )
    assert truth["bodies"]["attachment"]["inertia"] == pytest.approx(2.85 * (0.12**2 + 0.24**2))


def test_paper_study_reads_with_the_project_reader(tmp_path):
    io = pytest.importorskip("inertiafit.io")
    study = io.load_study(paper_study(tmp_path, seed=2))
    trial = study.read(1)
    assert trial["torque"].attrs["units"] == "N m"
    assert trial.attrs["speed"] == 240.0


def test_quasi_static_trials_can_have_their_own_noise(tmp_path):
    # a servo ripple sized for the fast ramps would shake a 1 deg/s move at several deg/s
    ripple = Noise(servo_ripple=0.3, lag=0.002, torque_gain=1.01)
    quiet = Noise.none()
    manifest = simulate_study(
        tmp_path,
        bodies={"b": (2.0, 0.1, 0.2)},
        conditions=[("b",)],
        speeds=(240.0,),
        trials_per_speed=1,
        noise=ripple,
        quasi_static_noise=quiet,
    )
    import pandas as pd

    data = manifest.parent / "data"
    qs = pd.read_csv(data / "A_quasistatic.csv")
    fast = pd.read_csv(data / "A_240_01.csv")
    moving = qs["velocity"].iloc[len(qs) // 4 : 3 * len(qs) // 4]
    assert moving.max() - moving.min() < 1e-9  # exactly 1 deg/s: no ripple, no noise
    assert np.ptp(np.diff(fast["velocity"].to_numpy())) > 1.0  # the fast trial ripples


def test_a_trial_file_holds_the_bytes_numpy_savetxt_writes(tmp_path):
    # write_trial_csv formats the whole table at once; the file must be what np.savetxt with
    # "%.10g" writes (the format the readers and the demo's trial files were checked against)
    from inertiafit.simulate.files import write_trial_csv

    trial = simulate_trial(inertia=0.25, gravity_moment=7.0, speed_deg_s=240.0, phi=0.1, rng=3)
    rng = np.random.default_rng(5)
    emg = {
        "biceps": rng.normal(0.0, 1e-5, trial.sizes["time"]),
        "triceps": np.zeros(trial.sizes["time"]),
    }
    path = tmp_path / "t.csv"
    write_trial_csv(path, trial, angle_unit="deg", torque_unit="N*m", time_unit="s", emg=emg)
    columns = np.column_stack(
        [
            trial["time"].values,
            np.degrees(trial["angle"].values),
            np.degrees(trial["velocity"].values),
            trial["torque"].values,
            *emg.values(),
        ]
    )
    expected = tmp_path / "expected.csv"
    header = "time,angle,velocity,torque,biceps,triceps"
    np.savetxt(expected, columns, fmt="%.10g", delimiter=",", header=header, comments="")
    assert path.read_bytes() == expected.read_bytes()
