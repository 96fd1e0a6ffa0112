"""A rest trial whose muscle contracts during the "quiet" hold (issue 20, item 3).

The rest level every trial is checked against comes from the ``kind = "rest"`` trials; a
contraction in one of them would raise it (and its SD, and the threshold) until reflexes pass
unseen. A simulated living study (three rest trials, a triceps reflex in one fast trial of
five) gets a 1 s triceps contraction at 30 x rest in its second rest trial: the rest level and
threshold stay those of the clean study (the contraction is found against the quietest 2 s of
the rest trials and left out), the reflex trial is still excluded, and the rest trial keeps
its row with the stretch in ``flags`` and its active samples cut out of the static fit.
"""

from __future__ import annotations

import math
import re
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
from inertiafit.processing.study import process_study
from inertiafit.simulate import EmgSimulation, simulate_living_study

REFLEX = "B_upright_180_02.csv"
REST = "B_upright_rest_2.csv"
#: The contraction added to the rest trial: seconds of its time, and its RMS over the rest's.
CONTRACTION = (1.5, 2.5)
RATIO = 30.0


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> Path:
    return simulate_living_study(
        tmp_path_factory.mktemp("rest") / "clean",
        seed=3,
        postures="one",
        trials_per_speed=5,
        quasi_static_speed=5.0,
        emg=EmgSimulation(reflex=[REFLEX]),
    )


@pytest.fixture(scope="module")
def contracted(clean, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rest") / "contracted"
    shutil.copytree(clean.parent, out)
    _contract(out / "data" / REST, CONTRACTION)
    return out / "study.toml"


def _contract(path: Path, span: tuple[float, float]) -> None:
    """Add a triceps contraction at ``RATIO`` x the rest RMS over ``span`` (s) of a trial."""
    data = pd.read_csv(path)
    t = data["time"].to_numpy()
    sos = signal.butter(4, [20, 450], btype="bandpass", fs=1000, output="sos")
    noise = signal.sosfilt(sos, np.random.default_rng(5).standard_normal(len(t) + 1000))[1000:]
    noise /= np.sqrt(np.mean(noise**2))
    hold = (t >= span[0]) & (t <= span[1])
    data.loc[hold, "triceps"] += RATIO * 5e-6 * noise[hold]
    data.to_csv(path, index=False)


@pytest.fixture(scope="module")
def both(clean, contracted):
    return process_study(clean), process_study(contracted)


def _levels(manifest: Path) -> dict[str, tuple[float, float]]:
    study = load_study(manifest)
    rest = [t.read() for t in study.trials if t.kind == "rest"]
    sweeps = [t.read() for t in study.trials if t.kind == "quasi-static" and t.emg]
    return study_rest_levels(rest, sweeps, EmgSettings())[0].levels


def test_a_contraction_in_a_rest_trial_leaves_the_rest_level_alone(clean, contracted):
    before, after = _levels(clean), _levels(contracted)
    assert after["biceps"] == before["biceps"]  # the biceps stayed quiet: the same numbers
    mean, sd = after["triceps"]
    # a second of 30 x rest in one of three 5 s holds would put the mean near 2.9 x rest and
    # the SD near 8 x the rest's; left out, the level is the clean one within the noise
    assert mean == pytest.approx(before["triceps"][0], rel=0.03)
    assert sd == pytest.approx(before["triceps"][1], rel=0.15)


def test_the_reflex_is_still_found_and_the_rest_trial_flagged(both):
    clean, contracted = both
    for processed in (clean, contracted):
        trials = processed.all_trials
        status = dict(zip(trials["file"].str.removeprefix("data/"), trials["status"], strict=True))
        assert {f for f, s in status.items() if s != "ok"} == {REFLEX}
    # the thresholds the fast trials were checked against: the clean study's
    a, b = (p.emg_traces.groupby("muscle")["threshold"].first() for p in both)
    assert b["triceps"] == pytest.approx(a["triceps"], rel=0.05)
    trials = contracted.all_trials
    row = trials[trials["file"] == f"data/{REST}"].iloc[0]
    m = re.match(
        r"EMG active: triceps (\d+\.\d+)-(\d+\.\d+) s \((\d+\.\d) x rest\); (\d+) samples "
        r"cut out of the fit",
        row["flags"],
    )
    assert m, row["flags"]
    start, end, ratio, cut = float(m[1]), float(m[2]), float(m[3]), int(m[4])
    assert CONTRACTION[0] - 0.05 < start < CONTRACTION[0] + 0.05
    assert CONTRACTION[1] - 0.05 < end < CONTRACTION[1] + 0.05
    assert 20 < ratio < 45
    assert cut == pytest.approx(1000 * (end - start + 0.3), abs=2)
    assert row["emg_peak_ratio"] == pytest.approx(ratio, abs=0.06)
    said = [w for w in contracted.warnings if f"rest trial data/{REST}: EMG active" in w]
    assert len(said) == 1
    assert "left out of the rest level" in said[0]
    # the clean study's rest trials carry no flag
    rest = clean.all_trials[clean.all_trials["kind"] == "rest"]
    assert not rest["flags"].fillna("").str.contains("EMG active").any()
    assert rest["emg_peak_ratio"].between(1.0, 2.0).all()


def test_a_rest_trial_active_throughout_is_excluded(clean, tmp_path):
    out = tmp_path / "whole"
    shutil.copytree(clean.parent, out)
    _contract(out / "data" / REST, (-1.0, 99.0))
    processed = process_study(out / "study.toml")
    trials = processed.all_trials
    row = trials[trials["file"] == f"data/{REST}"].iloc[0]
    assert row["status"] == "excluded"
    assert row["flags"].startswith("excluded: EMG active: triceps 0.000-")
    assert math.isfinite(row["offset"])  # its values kept for the record
    assert f"data/{REST}" not in set(processed.trials["file"])
    # the other two rest trials still give the level: the reflex is found
    status = dict(zip(trials["file"].str.removeprefix("data/"), trials["status"], strict=True))
    assert {f for f, s in status.items() if s != "ok"} == {REFLEX, REST}


def test_stop_refuses_a_study_whose_rest_trial_contracts(contracted, tmp_path):
    out = tmp_path / "stop"
    shutil.copytree(contracted.parent, out)
    path = out / "study.toml"
    path.write_text(
        path.read_text(encoding="utf-8").replace('unit = "V"', 'unit = "V"\non_activity = "stop"')
    )
    with pytest.raises(InputError) as info:
        process_study(path)
    message = str(info.value)
    assert "\n" not in message
    assert f"{REST}: EMG active: triceps" in message
