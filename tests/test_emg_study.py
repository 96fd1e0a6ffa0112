"""The EMG check in a study and the simulator's EMG (issue 20, items 3 and 5).

A small simulated rigid study (one condition, five fast trials at 240 deg/s, stretch reflexes
in two named trials) through ``process_study``: the reflex trials are excluded with the muscle,
times and ratio, the clean ones kept; ``"flag"`` keeps them, ``"stop"`` refuses the study;
a quasi-static sweep's active stretch is cut out of its fit. The simulator's EMG leaves the
other channels as they were, and its reflex torque is the model's.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from inertiafit.errors import InputError
from inertiafit.processing.activity import REFLEX_WINDOW, motion_onset
from inertiafit.processing.study import (
    EMG_TRACE_COLUMNS,
    EMG_TRIAL_COLUMNS,
    TRIAL_COLUMNS,
    process_study,
)
from inertiafit.simulate import EmgSimulation, Motion, simulate_study
from inertiafit.simulate.emg import EMD, TWITCH_TIME

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import emg_exclusion

REFLEX = ("A_240_02.csv", "A_240_04.csv")
FAST = [f"A_240_{k:02d}.csv" for k in range(1, 6)]


def _study(out: Path, emg: EmgSimulation | None, seed: int = 7) -> Path:
    return simulate_study(
        out,
        bodies={"bar": (2.0, 0.15, 0.2)},
        conditions=[("bar",)],
        speeds=(240.0,),
        trials_per_speed=5,
        quasi_static_speed=5.0,
        seed=seed,
        emg=emg,
    )


@pytest.fixture(scope="module")
def emg_study(tmp_path_factory) -> Path:
    return _study(tmp_path_factory.mktemp("emg"), EmgSimulation(reflex=REFLEX))


@pytest.fixture(scope="module")
def processed(emg_study):
    return process_study(emg_study)


def _with(manifest: Path, tmp_path: Path, extra: str) -> Path:
    """A copy of the study whose ``[emg]`` table has ``extra`` lines."""
    out = tmp_path / "copy"
    shutil.copytree(manifest.parent, out)
    path = out / "study.toml"
    path.write_text(path.read_text(encoding="utf-8").replace('unit = "V"', f'unit = "V"\n{extra}'))
    return path


# --- the simulator -------------------------------------------------------------------------


def test_emg_leaves_the_other_channels_and_the_clean_trials_alone(emg_study, tmp_path):
    plain = _study(tmp_path / "plain", None)
    for name in ["A_quasistatic.csv", *FAST]:
        with_emg = pd.read_csv(emg_study.parent / "data" / name)
        without = pd.read_csv(plain.parent / "data" / name)
        assert list(with_emg.columns) == [*without.columns, "biceps", "triceps"]
        same = np.array_equal(with_emg[without.columns].to_numpy(), without.to_numpy())
        assert same == (name not in REFLEX), name  # a reflex adds its torque, nothing else
        assert np.array_equal(with_emg["angle"], without["angle"])
    # the manifest gains only the [emg] table
    extra = set(emg_study.read_text(encoding="utf-8").splitlines()) - set(
        plain.read_text(encoding="utf-8").splitlines()
    )
    assert extra == {"[emg]", 'columns = ["biceps", "triceps"]', 'unit = "V"'}
    assert "[emg]" not in (plain.parent / "truth.toml").read_text(encoding="utf-8")


def test_the_reflex_torque_and_burst_are_the_models(emg_study, tmp_path):
    plain = _study(tmp_path / "plain", None)
    truth = tomllib.loads((emg_study.parent / "truth.toml").read_text(encoding="utf-8"))["emg"]
    assert truth["reflex_trials"] == list(REFLEX)
    for name in REFLEX:
        reflex = truth["reflexes"][name]
        assert reflex["muscle"] == "triceps"  # the move towards the larger angle stretches it
        assert 0.035 <= reflex["latency"] <= 0.060
        assert 8 <= reflex["ratio"] <= 20
        assert 0.6 <= reflex["torque"] <= 2.0
        data = pd.read_csv(emg_study.parent / "data" / name)
        added = data["torque"] - pd.read_csv(plain.parent / "data" / name)["torque"]
        t = data["time"].to_numpy()
        start = Motion().rest + reflex["latency"] + EMD  # the torque's start
        assert np.all(added[t <= start] == 0)
        peak = int(np.argmax(added))
        assert t[peak] == pytest.approx(start + TWITCH_TIME, abs=1.5e-3)
        assert added[peak] == pytest.approx(reflex["torque"], rel=1e-3)
        # the burst: RMS in its flat part about `ratio` times the rest's (5 uV)
        onset = Motion().rest + reflex["latency"]
        burst = (t > onset + 0.005) & (t < onset + reflex["duration"] - 0.005)
        rms = float(np.sqrt(np.mean(data["triceps"][burst] ** 2)))
        assert rms / 5e-6 == pytest.approx(reflex["ratio"], rel=0.35)
        quiet = float(np.sqrt(np.mean(data["biceps"] ** 2)))
        assert quiet == pytest.approx(5e-6, rel=0.15)


def test_emg_simulation_checks_its_values():
    with pytest.raises(ValueError, match="probability"):
        EmgSimulation(reflex=1.5)
    with pytest.raises(ValueError, match="latency"):
        EmgSimulation(latency=(0.06, 0.03))
    with pytest.raises(ValueError, match="muscles"):
        EmgSimulation(muscles=("a", "a"))


# --- the check in a study ------------------------------------------------------------------


def test_reflex_trials_are_excluded_with_muscle_times_and_ratio(processed):
    trials = processed.all_trials
    assert list(trials.columns) == [*TRIAL_COLUMNS, *EMG_TRIAL_COLUMNS]
    status = dict(zip(trials["file"].str.removeprefix("data/"), trials["status"], strict=True))
    assert {f for f, s in status.items() if s == "excluded"} == set(REFLEX)
    assert {f for f, s in status.items() if s == "ok"} == {"A_quasistatic.csv"} | (
        set(FAST) - set(REFLEX)
    )
    excluded = trials[trials["status"] == "excluded"]
    for flags, ratio in zip(excluded["flags"], excluded["emg_peak_ratio"], strict=True):
        m = re.match(
            r"excluded: EMG active: triceps (\d\.\d+)-(\d\.\d+) s \((\d+\.\d) x rest\)", flags
        )
        assert m, flags
        start, end = float(m[1]), float(m[2])
        # found within the reflex window; the burst is 35-60 ms after the 0.2 s start
        assert 0.2 + REFLEX_WINDOW[0] - 0.03 < start < 0.2 + 0.06 + 0.03 < end
        assert 8 < ratio == pytest.approx(float(m[3]), abs=0.06)
    clean = trials[(trials["status"] == "ok") & (trials["kind"] == "fast")]
    assert clean["emg_peak_ratio"].between(1.0, 2.0).all()
    # excluded rows keep their values for the record: the reflex reads as more inertia
    assert excluded["inertia"].min() > 1.05 * clean["inertia"].max()
    # and nothing of them reaches the evidence
    assert set(processed.trials["file"]) == set(clean["file"]) | {"data/A_quasistatic.csv"}
    assert set(processed.sensitivity.index) == set(clean["file"])
    assert sum("trial excluded: EMG active: triceps" in w for w in processed.warnings) == 2
    assert sum("2 of 5 fast trials with EMG excluded" in w for w in processed.warnings) == 1
    # no rest trials: the rest level is the quasi-static trial's quietest stretch, said once
    said = [w for w in processed.warnings if "quietest" in w]
    assert len(said) == 2
    assert all("data/A_quasistatic.csv" in w for w in said)
    assert [p["status"] for p in processed.provenance].count("excluded") == 2


def test_flag_keeps_the_trials_in_the_evidence(emg_study, tmp_path):
    out = process_study(_with(emg_study, tmp_path, 'on_activity = "flag"'))
    trials = out.all_trials
    assert (trials["status"] == "ok").all()
    flagged = trials[trials["flags"].str.contains("EMG active: triceps", na=False)]
    assert sorted(flagged["file"].str.removeprefix("data/")) == sorted(REFLEX)
    assert len(out.trials) == 6


@pytest.mark.parametrize("skip", [False, True])
def test_stop_refuses_the_study_in_one_line(emg_study, tmp_path, skip):
    extra = 'on_activity = "stop"'
    path = _with(emg_study, tmp_path, extra)
    if skip:  # on_trial_error = "skip" does not turn the refusal into a skip
        path.write_text('on_trial_error = "skip"\n' + path.read_text(encoding="utf-8"))
    with pytest.raises(InputError) as info:
        process_study(path)
    message = str(info.value)
    assert "\n" not in message
    assert "A_240_02.csv: EMG active: triceps" in message
    assert "x rest" in message
    assert 'on_activity = "stop"' in message
    # the refused study's table marks the trial (diagnostics.csv)
    table = info.value.table
    refused = table[table["status"] == "refused"]
    assert list(refused["file"]) == ["data/A_240_02.csv"]
    assert refused["cause"].iloc[0].startswith("EMG active: triceps")


def test_a_condition_left_without_fast_trials_is_one_error(tmp_path):
    path = _study(tmp_path / "all", EmgSimulation(reflex=1.0))
    with pytest.raises(InputError) as info:
        process_study(path)
    message = str(info.value)
    assert "\n" not in message
    assert "condition 'bar': no usable fast trial; left out:" in message
    assert "(EMG active: triceps" in message
    assert "its inertia has no evidence" in message


def test_an_active_stretch_of_a_sweep_is_cut_out_of_its_fit(emg_study, tmp_path):
    """A 0.3 s contraction (15 x rest) with 3 N m in the sweep: cut out, M_g unmoved."""
    path = _with(emg_study, tmp_path, "")
    csv = path.parent / "data" / "A_quasistatic.csv"
    data = pd.read_csv(csv)
    t = data["time"].to_numpy()
    during = (t >= 8.0) & (t < 8.3)
    rng = np.random.default_rng(5)
    data.loc[during, "biceps"] += rng.normal(0.0, 15 * 5e-6, during.sum())
    data.loc[(t >= 8.0) & (t < 8.5), "torque"] += 3.0
    data.to_csv(csv, index=False, float_format="%.10g")
    base = process_study(emg_study).gravity["bar"]
    cut = process_study(path)
    row = cut.all_trials.iloc[0]
    assert row["status"] == "ok"
    assert row["emg_peak_ratio"] > 8
    m = re.search(
        r"EMG active: biceps (\S+)-(\S+) s .*; (\d+) samples cut out of the fit", row["flags"]
    )
    assert m, row["flags"]
    assert float(m[1]) < 8.0 + 0.03
    assert float(m[2]) > 8.3 - 0.03
    assert cut.gravity["bar"].n == base.n - int(m[3])
    kept = process_study(_with(path, tmp_path / "f", 'on_activity = "flag"')).gravity["bar"]
    # the contraction's torque moves the offset when kept; cut out, the fit is the clean one's
    assert abs(cut.gravity["bar"].offset - base.offset) < 0.2 * abs(kept.offset - base.offset)


def test_a_study_without_emg_has_no_emg_column(tmp_path):
    trials = process_study(_study(tmp_path / "plain", None)).all_trials
    assert list(trials.columns) == TRIAL_COLUMNS


def test_motion_onset_is_where_the_speed_rises():
    t = np.arange(1000) / 1000
    v = np.clip((t - 0.2) * 35.0, 0, 3.0)
    assert motion_onset(t, v) == pytest.approx(0.2 + 0.05 * 3.0 / 35.0, abs=1.5e-3)


@pytest.mark.slow
def test_the_benchmark_excludes_the_reflex_and_nothing_else():
    """The benchmark's living study (sweeps at 4 deg/s), without sampling: two seeds."""
    for seed in (20261126, 20261127):
        r = emg_exclusion.one_study(seed, posterior=False, quasi_static_speed=4.0)
        assert r["hits"] == 1, r
        assert r["false_alarms"] == 0, r
        assert min(r["reflex_ratio"]) > 8
        assert max(r["clean_ratio"]) < 2
        assert math.isfinite(r["reflex_inertia"][0])


def test_emg_traces_hold_each_fast_trial_around_its_windows(processed):
    traces = processed.emg_traces
    assert list(traces.columns) == EMG_TRACE_COLUMNS
    assert traces["trial"].nunique() == 5
    status = traces.groupby("trial")["status"].first()
    assert sorted(status[status == "excluded"].index.str.removeprefix("data/")) == list(REFLEX)
    active = traces[traces["active"] == 1]
    assert set(active["trial"].str.removeprefix("data/")) == set(REFLEX)
    assert set(active["muscle"]) == {"triceps"}
    # the bursts start 35-60 ms after the stretch: active within the reflex window, ± half a window
    assert active["time"].between(0.0, REFLEX_WINDOW[1] + 0.03).all()
    thresholds = traces.groupby("muscle")["threshold"].agg(["min", "max"])
    assert (thresholds["min"] == thresholds["max"]).all()
    assert thresholds["min"].between(1.1, 1.6).all()  # rest mean + 3 SD over the mean


def test_the_emg_figure_shades_the_excluded_trials_active_stretches(processed):
    from inertiafit.report.plots import plot_emg_envelopes

    fig = plot_emg_envelopes(processed.emg_traces, title="bar")
    biceps, triceps = fig.axes
    assert biceps.get_ylabel().startswith("biceps")
    assert len(biceps.patches) == 0
    assert len(triceps.patches) == 2  # one shaded stretch per excluded trial
    assert len(triceps.lines) == 5 + 2  # five trials, the threshold and the rest level


def test_the_text_report_and_the_jupyter_display_count_the_excluded_trials(processed):
    # the trials table analyse_study keeps in the posterior's inputs, on a small fitted posterior
    from inertiafit.inference.fit import fit_body
    from inertiafit.posterior import Posterior

    post = fit_body("disk-3kg", inertia=[0.594], inertia_se=0.0105, gravity_moment=[12.8],
                    gravity_moment_se=0.05, seed=1)  # fmt: skip
    assert "trials" not in post.report()  # fitted from numbers: no trials, no line
    tree = post.tree.copy()
    trials = processed.all_trials.to_dict(orient="list")
    tree.attrs["inputs"] = json.dumps({"trials": trials}, default=str)
    study = Posterior(tree)
    n = len(trials["status"])
    line = f"{n} trials: {n - 2} in the evidence; 2 excluded for muscle activity (EMG)"
    assert study.report().splitlines()[-1].startswith(line)
    assert line in study._repr_html_()
