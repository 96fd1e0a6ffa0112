"""Issue 36 ("Nothing silent"): four inputs that were read wrong or told the wrong thing.

Each case asserts the outcome (the one-line message, or the values read) and, where sensible,
a negative control that the good input still passes:

- time stamps offset by 1e12 s, whose float64 spacing quantises the step (a 1 kHz file read as
  1024 Hz): refused, naming the file and the time column (``make_trial``);
- a 10 Hz study, too slow for the fixed 20 Hz filter: told to record faster, not to lower a
  cut-off that no manifest key or command-line option sets (``processing.filtering.design``);
- a condition with two fast trials (a Student-t of one degree of freedom, whose Cauchy proposal
  reaches coordinates of 2e4): fitted without a stray RuntimeWarning (``Model.log_prob``);
- a rest trial whose angle drifts while its velocity reads ~0: told that the velocity does not
  follow the angle, not that its columns are swapped (``make_trial``).
"""

from __future__ import annotations

import math
import shutil
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from inertiafit.errors import InputError, StudyRefused
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import load_prior
from inertiafit.io import read_trial
from inertiafit.io.trial import make_trial
from inertiafit.pipeline.study import analyse_study
from inertiafit.processing.filtering import design
from inertiafit.processing.study import process_study
from inertiafit.simulate import Motion, simulate_living_study, simulate_study, simulate_trial

DEG = math.pi / 180


def one_line(error: pytest.ExceptionInfo) -> str:
    message = str(error.value)
    assert "\n" not in message
    return message


# ----------------------------------------------------------- 1. time stamps offset by 1e12 s


def sweep(rate: float = 1000.0, n: int = 2000) -> tuple[np.ndarray, ...]:
    """Time from 0, and an angle (rad), velocity (rad/s) and torque (N m) that agree."""
    t = np.arange(n) / rate
    angle = math.radians(30.0) * np.sin(np.pi * t)
    return t, angle, math.radians(30.0) * np.pi * np.cos(np.pi * t), 2.0 + np.sin(t)


def write_csv(path: Path, time: np.ndarray, *, time_unit_scale: float = 1.0, fmt=repr) -> Path:
    """A csv trial (time, angle deg, velocity deg/s, torque N m) with the time written by ``fmt``."""
    _, angle, velocity, torque = sweep(n=time.size)
    rows = ["stamp,angle,velocity,torque"]
    rows += [
        f"{fmt(float(s) * time_unit_scale)},{float(a / DEG)!r},{float(v / DEG)!r},{float(m)!r}"
        for s, a, v, m in zip(time, angle, velocity, torque, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_time_stamps_too_large_to_resolve_their_step_are_refused(tmp_path):
    t, *_ = sweep()
    path = write_csv(tmp_path / "epoch.csv", t + 1e12)
    with pytest.raises(InputError) as error:
        read_trial(path, columns={"time": "stamp"})
    message = one_line(error)
    assert message.startswith(
        f"{path}: column 'stamp' reaches 1e+12 s, where float64 resolves only 0.000122 s, 0.12 "
        "of the 0.001 s step (expected under 0.001 of it): the sampling rate cannot be resolved"
    )
    assert message.endswith("subtract the first time stamp before saving the file)")
    # the same samples from 0 are read at their rate
    path = write_csv(tmp_path / "zero.csv", t)
    assert read_trial(path, columns={"time": "stamp"}).attrs["sampling_rate"] == 1000.0


def test_ten_khz_at_1e12_is_told_the_resolution_not_a_time_that_does_not_increase():
    # at 1e12 s a 0.1 ms step is 0 or 2**-13 s: the rounding, not the file, stops the time
    t, angle, velocity, torque = sweep(rate=10_000.0)
    with pytest.raises(InputError, match=r"^x\.csv: column 'time' reaches 1e\+12 s, .* step"):
        make_trial(t + 1e12, angle, velocity, torque, source="x.csv")


@pytest.mark.parametrize(
    ("name", "offset", "scale", "fmt", "rate"),
    [
        ("from 0 s", 0.0, 1.0, repr, 1000.0),
        ("from an hour", 3600.0, 1.0, repr, 1000.0),
        ("an epoch in s at 1 kHz", 1.7e9, 1.0, repr, 1000.0),
        ("ms", 0.0, 1000.0, repr, 1000.0),
        ("1500 Hz to 0.1 ms", 0.0, 1.0, "{:.4f}".format, 1500.0),
    ],
)
def test_ordinary_time_columns_are_read_at_their_rate(tmp_path, name, offset, scale, fmt, rate):
    t = offset + np.arange(2000) / rate
    path = write_csv(tmp_path / "t.csv", t, time_unit_scale=scale, fmt=fmt)
    units = {"time": "ms"} if scale == 1000.0 else None
    trial = read_trial(path, columns={"time": "stamp"}, units=units)
    # 1500 Hz written to 0.1 ms reads as 1/0.7 ms (its median step); an epoch loses 1e-4
    assert trial.attrs["sampling_rate"] == pytest.approx(
        rate, rel=0.1 if fmt is not repr else 1e-4
    )


# ----------------------------------------------------------------- 2. a 10 Hz study's filter


def rigid_study(root: Path, rate: float) -> Path:
    return simulate_study(
        root,
        bodies={"attachment": (2.0, 0.1, 0.1)},
        conditions=[("attachment",)],
        speeds=(240.0,),
        trials_per_speed=2,
        rate=rate,
        seed=1,
    )


def test_a_ten_hz_study_is_told_to_record_faster_not_to_lower_a_cutoff(tmp_path):
    manifest = rigid_study(tmp_path / "slow", rate=10.0)
    with pytest.raises(StudyRefused) as error:
        process_study(manifest)
    message = one_line(error)
    assert message.endswith(
        "A_240_01.csv: sampling rate: 10 Hz is too low for the 20 Hz low-pass filter (its "
        "Nyquist frequency 5 Hz must lie above the cut-off): record at more than 40 Hz; the "
        "cut-off is fixed for manifests and the command line (from Python, process_study's "
        "cutoff argument sets it)"
    )
    assert "choose a cut-off" not in message
    # negative control: the same study at 100 Hz is processed
    processed = process_study(rigid_study(tmp_path / "fast", rate=100.0))
    assert len(processed.trials) == 3


def test_a_cutoff_the_caller_chose_is_still_named():
    with pytest.raises(InputError, match=r"^a\.csv: filter cutoff: 500 Hz .* choose a cut-off"):
        design(1000.0, cutoff=500.0, source="a.csv")
    assert design(100.0).shape == (1, 6)  # the default filter at 100 Hz


# ------------------------------------------------------ 3. two fast trials, no RuntimeWarning


def two_trial_model() -> Model:
    """The attachment measured by two fast trials: a Student-t of one degree of freedom."""
    return Model(
        {"att": load_prior("biodex-elbow-attachment")},
        [
            Condition(
                ("att",),
                Observation.from_values([0.21, 0.22]),
                Observation.from_mean_se(7.415, 0.05),
            )
        ],
    )


def test_a_proposal_far_out_has_no_density_and_says_nothing():
    model = two_trial_model()
    inside = np.log([7.415 / 9.81, 0.215])
    rows = np.array([inside, [inside[0], 2e4], [inside[0], -2e4], [np.nan, inside[1]]])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        values = model.log_prob(rows)
    assert np.isneginf(values[1:]).all()
    # negative control: the row inside has its density, the same alone as among the others
    assert np.isfinite(values[0])
    assert values[0] == model.log_prob(inside[None])[0]


@pytest.fixture(scope="module")
def living(tmp_path_factory):
    """A one-posture living study with two fast trials per condition."""
    root = tmp_path_factory.mktemp("issue36_inputs") / "study"
    simulate_living_study(root, seed=36, postures="one", trials_per_speed=2)
    return root


def test_conditions_of_two_fast_trials_are_fitted_without_a_runtime_warning(living):
    # the Cauchy proposal reached log I = 2e4: "overflow encountered in exp", "divide by zero
    # encountered in log" from every such study
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = analyse_study(living / "study.toml", seed=0)
    fast = result.trials[result.trials["kind"] == "fast"]
    assert fast.groupby("condition").size().to_dict() == {"attachment": 2, "attachment+forearm": 2}
    # and right: each body's inertia near its truth, within its HDI's reach
    truth = tomllib.loads((living / "truth.toml").read_text(encoding="utf-8"))["bodies"]
    summary = result.summary().query("parameter == 'inertia'").set_index("body")
    for body, values in truth.items():
        assert summary.loc[body, "median"] == pytest.approx(values["inertia"], rel=0.1)


# ------------------------------------------------- 4. a drifting rest angle, a still velocity


def rest_hold(seconds: float = 10.0) -> tuple[np.ndarray, ...]:
    """A simulated quiet hold at 40 deg: time, angle, velocity (noise about 0), torque."""
    trial = simulate_trial(
        kind="rest",
        inertia=0.2,
        gravity_moment=6.7,
        phi=0.2,
        offset=1.5,
        rng=5,
        motion=Motion(hold=seconds, start=40 * DEG),
    )
    return tuple(trial[k].values for k in ("time", "angle", "velocity", "torque"))


COLUMNS = {"angle": "Pos", "velocity": "Vel", "torque": "Tq"}


def test_a_drifting_rest_angle_is_told_the_velocity_does_not_follow_it():
    t, angle, velocity, torque = rest_hold()
    drifting = angle + 0.5 * DEG * t  # 0.5 deg/s over 10 s
    with pytest.raises(InputError) as error:
        make_trial(t, drifting, velocity, torque, source="rest.csv", columns=COLUMNS)
    message = one_line(error)
    assert message == (
        "rest.csv: column 'Pos' drifts 0.5 deg/s (5 deg in 10 s) while column 'Vel' says the "
        "shaft is still (median speed 0.33 deg/s, mean -0.0014 deg/s): the velocity does not "
        "follow the angle; check the angle channel for a drifting zero, or the velocity channel "
        "for a dead one"
    )
    assert "swapped" not in message
    # negative controls: the hold itself, and the same drift with a velocity that records it
    for a, v in ((angle, velocity), (drifting, velocity + 0.5 * DEG)):
        trial = make_trial(t, a, v, torque, source="rest.csv", columns=COLUMNS)
        assert trial.attrs["flags"] == ()
    # and a hold whose angle jitters (0.5 deg SD) with a 6-deg glitch at its first sample: the
    # drift is read from the medians of its ends, which neither moves
    jittery = angle + 0.5 * DEG * np.random.default_rng(0).normal(size=angle.size)
    jittery[0] += 6 * DEG
    trial = make_trial(t, jittery, velocity, torque, source="rest.csv", columns=COLUMNS)
    np.testing.assert_array_equal(trial.angle.values, jittery)


def test_a_drifting_rest_trial_of_a_study_is_named(living, tmp_path):
    folder = tmp_path / "study"
    shutil.copytree(living, folder)
    path = folder / "data" / "B_upright_rest_1.csv"
    frame = pd.read_csv(path)
    frame["angle"] = frame["angle"] + 1.0 * frame["time"]  # deg, over the hold's 5 s
    frame.to_csv(path, index=False)
    with pytest.raises(InputError) as error:
        process_study(folder / "study.toml")
    message = one_line(error)
    assert "B_upright_rest_1.csv: column 'angle' drifts 1 deg/s (5 deg in 5 s) while " in message
    assert "the velocity does not follow the angle" in message
    assert "swapped" not in message


def test_real_swaps_and_unit_mixups_of_a_slow_sweep_are_still_named():
    sweep4 = simulate_trial(
        kind="quasi-static", speed_deg_s=4, rng=4, inertia=0.2, gravity_moment=6.7, phi=0.2
    )
    t, angle, velocity, torque = (
        sweep4[k].values for k in ("time", "angle", "velocity", "torque")
    )
    with pytest.raises(InputError, match=r"^A\.csv: velocity and torque columns swapped\? "):
        make_trial(t, angle, torque, velocity, source="A.csv")
    # a velocity in rad/s read as deg/s looks still too (0.07 deg/s), but a unit explains it
    with pytest.raises(InputError, match=r"velocity in rad/s read as deg/s"):
        make_trial(t, angle, velocity * DEG, torque, source="A.csv")
