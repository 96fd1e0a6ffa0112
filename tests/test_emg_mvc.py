"""``kind = "mvc"`` trials: each muscle's MVC level, and the %MVC threshold (issue 20, item 2).

A simulated rigid study (one condition, five fast trials at 240 deg/s, stretch reflexes in two
named ones) gains an MVC trial: a 3 s hold whose EMG rises to a contraction for 1.5 s, scaled
so that the reflexes' peak envelope is 5 % of the MVC's. With ``mvc_fraction = 0.02`` the
threshold (the larger of rest mean + 3 SD and 2 % MVC) still finds the reflexes; with 0.2 it
is above them and they are kept. The MVC trial is listed in ``trials.csv`` with ``status =
"reference"`` and never reaches the evidence or the gravity fit.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import signal

from inertiafit.errors import InputError
from inertiafit.io import load_study
from inertiafit.io.emg import EmgSettings
from inertiafit.processing.activity import study_rest_levels
from inertiafit.processing.emg import emg_activity, emg_envelope, mvc_levels
from inertiafit.processing.study import process_study
from inertiafit.simulate import EmgSimulation, simulate_study

REFLEX = ("A_240_02.csv", "A_240_04.csv")
FAST = [f"A_240_{k:02d}.csv" for k in range(1, 6)]
#: The reflexes' peak envelope as a fraction of the MVC's.
REFLEX_MVC = 0.05

MVC_TRIAL = """
[[trials]]
file = "data/A_mvc.csv"
bodies = ["bar"]
kind = "mvc"
"""


def _band_noise(rng: np.random.Generator, n: int) -> np.ndarray:
    sos = signal.butter(4, [20, 450], btype="bandpass", fs=1000, output="sos")
    x = signal.sosfilt(sos, rng.standard_normal(n + 1000))[1000:]
    return x / np.sqrt(np.mean(x**2))


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    """The simulated study with reflexes and no MVC trial."""
    return simulate_study(
        tmp_path_factory.mktemp("mvc") / "study",
        bodies={"bar": (2.0, 0.15, 0.2)},
        conditions=[("bar",)],
        speeds=(240.0,),
        trials_per_speed=5,
        quasi_static_speed=5.0,
        seed=7,
        emg=EmgSimulation(reflex=REFLEX),
    )


def _reflex_peak(base: Path) -> float:
    """The largest triceps envelope (V) of the reflex trials: their bursts' peak."""
    study = load_study(base)
    peaks = []
    for spec in study.trials:
        if spec.file.name in REFLEX:
            env = emg_envelope(spec.read(), muscles=["triceps"])
            peaks.append(float(env.values.max()))
    return max(peaks)


def _with_mvc(
    base: Path, out: Path, *, emg: str = "", extra: str = "", trial: str = MVC_TRIAL
) -> Path:
    """A copy of ``base`` with an MVC trial (``emg`` lines in its entry, ``extra`` in [emg])."""
    shutil.copytree(base.parent, out)
    data = pd.read_csv(out / "data" / "A_quasistatic.csv").iloc[:3000].copy()
    rng = np.random.default_rng(11)
    t = data["time"].to_numpy()
    hold = ((t >= 0.75) & (t <= 2.25)).astype(float)
    target = _reflex_peak(base) / REFLEX_MVC
    for m in ("biceps", "triceps"):
        data[m] = data[m] + hold * _band_noise(rng, len(t))
    data.to_csv(out / "data" / "A_mvc.csv", index=False)
    # scale the contraction so that its peak envelope is exactly `target` (the envelope is
    # proportional to the signal's scale; the rest noise scales along, which does not matter)
    spec = next(s for s in _load(out, trial, emg).trials if s.kind == "mvc")
    peaks = mvc_levels(spec.read(), muscles=["biceps", "triceps"])
    for m in ("biceps", "triceps"):
        data[m] = data[m] * target / peaks[m]
    data.to_csv(out / "data" / "A_mvc.csv", index=False)
    path = out / "study.toml"
    text = path.read_text(encoding="utf-8").replace('unit = "V"', f'unit = "V"\n{extra}')
    path.write_text(text + trial + emg)
    return path


def _load(out: Path, trial: str, emg: str):
    path = out / "probe.toml"
    path.write_text((out / "study.toml").read_text(encoding="utf-8") + trial + emg)
    return load_study(path)


def _status(processed) -> dict[str, str]:
    trials = processed.all_trials
    return dict(zip(trials["file"].str.removeprefix("data/"), trials["status"], strict=True))


@pytest.fixture(scope="module")
def at_2_percent(base, tmp_path_factory):
    return process_study(_with_mvc(base, tmp_path_factory.mktemp("two") / "s", extra=""))


def test_a_reflex_at_5_percent_mvc_is_excluded_at_2_percent(base, at_2_percent):
    status = _status(at_2_percent)
    assert {f for f, s in status.items() if s == "excluded"} == set(REFLEX)
    assert {f for f, s in status.items() if s == "ok"} == {"A_quasistatic.csv"} | (
        set(FAST) - set(REFLEX)
    )
    assert status["A_mvc.csv"] == "reference"
    # the threshold the check used: the larger of rest + 3 SD and 2 % of the MVC level
    study = load_study(base)
    sweep = next(s for s in study.trials if s.kind == "quasi-static").read()
    rest = study_rest_levels([], [sweep], EmgSettings())[0].levels["triceps"]
    target = _reflex_peak(base) / REFLEX_MVC
    assert 0.02 * target > rest[0] + 3 * rest[1]  # the MVC's part decides
    traces = at_2_percent.emg_traces
    used = traces[(traces["trial"] == "data/A_240_02.csv") & (traces["muscle"] == "triceps")]
    assert used["threshold"].to_numpy() == pytest.approx(0.02 * target / rest[0], rel=1e-9)


def test_a_reflex_at_5_percent_mvc_is_kept_at_20_percent(base, tmp_path):
    out = process_study(_with_mvc(base, tmp_path / "s", extra="mvc_fraction = 0.2"))
    status = _status(out)
    assert {f for f, s in status.items() if s == "ok"} == {"A_quasistatic.csv", *FAST}
    assert status["A_mvc.csv"] == "reference"
    assert len(out.trials) == 6  # every fast trial and the sweep are evidence


def test_the_mvc_trial_is_listed_and_never_evidence(base, at_2_percent):
    plain = process_study(base)
    trials = at_2_percent.all_trials
    row = trials[trials["kind"] == "mvc"]
    assert list(row["file"]) == ["data/A_mvc.csv"]
    assert row["status"].iloc[0] == "reference"
    flags = row["flags"].iloc[0]
    assert flags.startswith("MVC reference (not evidence): peak envelope biceps ")
    # the MVC's peak over the rest level: the reflexes (8-20 x rest) are 5 % of it
    ratio = float(row["emg_peak_ratio"].iloc[0])
    reflex = trials[trials["status"] == "excluded"]["emg_peak_ratio"].max()
    assert ratio == pytest.approx(reflex / REFLEX_MVC, rel=0.05)
    assert np.isnan(row["inertia"].iloc[0])
    assert np.isnan(row["gravity_moment"].iloc[0])
    assert "data/A_mvc.csv" not in set(at_2_percent.trials["file"])
    # the gravity fit is that of the study without the MVC trial
    for cond, fit in plain.gravity.items():
        assert at_2_percent.gravity[cond].gravity_moment == fit.gravity_moment
    prov = {p["file"]: p["status"] for p in at_2_percent.provenance}
    assert prov["data/A_mvc.csv"] == "reference"


def test_emg_activity_takes_mvc_levels_per_muscle(base):
    study = load_study(base)
    trial = next(s for s in study.trials if s.file.name == REFLEX[0]).read()
    peak = _reflex_peak(base)
    rest = (0.0, 0.15)  # before the move
    found = emg_activity(trial, rest=rest, mvc={"biceps": 1.0, "triceps": peak / 0.05})
    assert list(found["muscle"]) == ["triceps"]
    assert found.attrs["mvc_level"] == {"biceps": 1.0, "triceps": peak / 0.05}
    assert found.attrs["threshold"]["triceps"] >= 0.02 * peak / 0.05
    assert emg_activity(
        trial, rest=rest, mvc={"biceps": 1.0, "triceps": peak / 0.05}, mvc_fraction=0.2
    ).empty
    assert emg_activity(trial, rest=rest).attrs["mvc_level"] is None
    with pytest.raises(InputError, match=r"^mvc: no level for muscle 'triceps'"):
        emg_activity(trial, rest=rest, mvc={"biceps": 1.0})
    with pytest.raises(InputError, match=r"^mvc.triceps: expected the MVC's peak envelope"):
        emg_activity(trial, rest=rest, mvc={"biceps": 1.0, "triceps": -1.0})


# --- bad input -----------------------------------------------------------------------------


def _manifest_error(base: Path, out: Path, trial: str, extra: str = "") -> str:
    shutil.copytree(base.parent, out)
    shutil.copy(out / "data" / "A_240_01.csv", out / "data" / "A_mvc.csv")
    path = out / "study.toml"
    text = path.read_text(encoding="utf-8").replace('unit = "V"', f'unit = "V"\n{extra}')
    path.write_text(text + trial)
    with pytest.raises(InputError) as info:
        load_study(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(str(path))
    return message


def test_an_mvc_trial_without_emg_is_one_error(base, tmp_path):
    message = _manifest_error(base, tmp_path / "s", MVC_TRIAL + "emg = []\n")
    assert ": trials[6].emg: no EMG channels; an mvc trial is read for its EMG" in message


def test_an_mvc_trial_lacking_a_muscle_is_one_error(base, tmp_path):
    message = _manifest_error(base, tmp_path / "s", MVC_TRIAL + 'emg = ["biceps"]\n')
    assert ": trials[6].emg: no mvc trial (trials[6]) records EMG channel 'triceps'" in message
    assert "which trials[0] records" in message


def test_mvc_fraction_without_an_mvc_trial_is_one_error(base, tmp_path):
    message = _manifest_error(base, tmp_path / "s", "", extra="mvc_fraction = 0.05")
    assert ': emg.mvc_fraction: set, but no trial has kind = "mvc"' in message


@pytest.mark.parametrize("value", ["0", "1.5", "-0.02"])
def test_mvc_fraction_outside_0_1_is_one_error(base, tmp_path, value):
    message = _manifest_error(base, tmp_path / "s", MVC_TRIAL, extra=f"mvc_fraction = {value}")
    assert ": emg.mvc_fraction: expected a number in (0, 1] of the MVC" in message


def test_an_mvc_trial_with_a_speed_or_its_own_mounting_is_one_error(base, tmp_path):
    message = _manifest_error(base, tmp_path / "a", MVC_TRIAL + "speed = 240\n")
    assert ": trials[6].speed: an mvc trial is a contraction" in message
    alone = MVC_TRIAL.replace('bodies = ["bar"]', 'bodies = ["bar"]\noffset = { bar = 0.05 }')
    message = _manifest_error(base, tmp_path / "b", alone)
    assert ": trials[6].bodies: an mvc trial is recorded in a mounting the study measures" in (
        message
    )


def test_an_mvc_trial_that_cannot_be_read_with_skip_is_one_error(base, tmp_path):
    path = _with_mvc(base, tmp_path / "s")
    (path.parent / "data" / "A_mvc.csv").write_text("time,angle\n0,0\n")
    path.write_text('on_trial_error = "skip"\n' + path.read_text(encoding="utf-8"))
    with pytest.raises(InputError) as info:
        process_study(path)
    message = str(info.value)
    assert "\n" not in message
    assert "no mvc trial could be read (data/A_mvc.csv, skipped)" in message
