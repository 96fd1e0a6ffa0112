"""Issue 36 ("Nothing silent, round two"): the cases it lists that this release answers.

As ``test_issue22_catalogue.py``: each case one test, through the command line where the issue
used it (one line on stderr, exit 2, nothing changed), with a direct assertion on the outcome.
Cases answered in depth elsewhere are named here with the test that holds them:

- a posture's ``gravity_rotation`` declared 0 or 30 deg where it is 46.6, or its sign flipped:
  measured by a rigid sweep in that posture and said, naming the key
  (``test_living_shapes.py::test_a_rigid_sweep_measures_the_rotation_and_the_declared_one_is_checked``);
- a stiffness prior written per degree: refused at reading with the value per radian
  (``test_manifest_living.py``, case "stiffness per degree");
- a manual window over the whole speed-up and slow-down, refused as "a stretch of constant
  speed": taken (``test_plausibility.py::test_a_manual_window_over_the_whole_move_is_taken``);
- inputs told what is wrong with them (time stamps of 1e12 s, a 10 Hz recording, a drifting
  rest angle, the sampler's warnings with two fast trials): ``test_issue36_inputs.py``;
- outputs (export's folder, a killed run's staging folder, SEs of 1e-300, gravity 1e300):
  ``test_issue36_outputs.py``;
- one fast trial written with the other sign, told that flipping "would mix signs": told its
  ``torque_sign`` (``test_diagnostics.py::test_one_file_written_with_the_other_sign_is_told_its_torque_sign``).
"""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_cli_arguments import run_cli
from test_issue22_catalogue import copy_of, refused, run_refused

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.io import load_study, read_trial
from inertiafit.posterior import open_posterior
from inertiafit.processing.plausibility import REST_TRAVEL
from inertiafit.processing.study import process_study
from inertiafit.report.propagate import propagate
from inertiafit.simulate import simulate_living_study


@pytest.fixture(scope="module")
def living(tmp_path_factory):
    """A one-posture living study, two fast trials per speed (processing only)."""
    root = tmp_path_factory.mktemp("issue36") / "study"
    simulate_living_study(root, seed=36, postures="one", trials_per_speed=2)
    return root


def test_a_recording_saved_again_with_crlf_line_ends_is_refused(living, tmp_path):
    # the same samples in other bytes (CRLF, as a spreadsheet re-saves a file): one recording
    manifest = copy_of(living, tmp_path)
    data = manifest.parent / "data"
    text = (data / "A_180_01.csv").read_text(encoding="utf-8")
    (data / "A_180_09.csv").write_bytes(text.replace("\n", "\r\n").encode())
    assert (data / "A_180_09.csv").read_bytes() != (data / "A_180_01.csv").read_bytes()
    with manifest.open("a") as fh:
        fh.write('\n[[trials]]\nfile = "data/A_180_09.csv"\nbodies = ["attachment"]\n')
        fh.write('kind = "fast"\nspeed = 180.0\nposture = "upright"\n')
    run_refused(
        manifest,
        tmp_path,
        r"A_180_09\.csv: the same recording as data/A_180_01\.csv \(the same angle and torque "
        r"samples, saved differently\)",
    )


@pytest.mark.parametrize("moving", ["B_upright_quasistatic_up.csv", "B_upright_180_01.csv"])
def test_a_moving_rest_trial_is_refused(living, tmp_path, moving):
    # a sweep, or a 180 deg/s move, filed as kind = "rest" was read as a quiet hold
    manifest = copy_of(living, tmp_path)
    data = manifest.parent / "data"
    frame = pd.read_csv(data / moving)
    frame["torque"] += 0.001  # not a byte copy of a trial listed already
    frame.to_csv(data / "B_upright_rest_1.csv", index=False)
    run_refused(
        manifest,
        tmp_path,
        r"B_upright_rest_1\.csv: angle: a rest trial must hold still, but its angle travels 9\d",
        r'a slow sweep is kind = "quasi-static"',
    )


def test_a_still_rest_trial_with_a_noisy_angle_is_kept(living, tmp_path):
    # the check reads the angle's running median: a hold whose channel jitters by half a
    # degree, with a glitch at its first sample, is still a hold
    manifest = copy_of(living, tmp_path)
    path = manifest.parent / "data" / "B_upright_rest_2.csv"
    frame = pd.read_csv(path)
    jitter = np.random.default_rng(0).normal(0.0, 0.5, len(frame))
    frame["angle"] = frame["angle"] + jitter
    frame.loc[0, "angle"] += 6.0
    frame.to_csv(path, index=False)
    processed = process_study(manifest)
    rest = processed.trials[processed.trials["kind"] == "rest"]
    assert len(rest) == 3
    assert REST_TRAVEL < 6.0


def test_distinct_recordings_with_the_same_rate_are_not_taken_for_copies(living):
    # the content check compares the samples themselves: every trial of a real (noisy) study
    # passes it
    processed = process_study(Path(living) / "study.toml")
    assert len(processed.trials) == len(processed.provenance)


# -- propagate checks meaning, not only shapes ---------------------------------------------------

RATE = 120.0


def _swing(seconds: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """A forearm swing at 120 Hz: 1 rad of travel, time in s and angle in rad."""
    time = np.arange(0.0, seconds, 1.0 / RATE)
    return time, 0.5 * np.sin(2 * np.pi * 0.5 * time)


DRAWS = {"mass": [1.5, 1.6], "com_distance": [0.15, 0.16], "radius_of_gyration": [0.08, 0.09]}


@pytest.mark.parametrize(
    ("motion", "draws", "pattern"),
    [
        (lambda t, a: (t, np.degrees(a)), DRAWS, r"^motion: angle: travels 57\.\d+ rad .* deg\)"),
        (lambda t, a: (1000 * t, a), DRAWS, r"^motion: time: a step of 8\.333 s .*is it in ms"),
        (
            lambda t, a: (np.round(t, 3), a),
            DRAWS,
            r"^motion: time: steps from 0\.008 to 0\.009 s .*rounded time stamps",
        ),
        (
            lambda t, a: (t, a, np.full_like(t, 1e6)),
            DRAWS,
            r"^motion: acceleration reaches 1e\+06 rad/s\^2, beyond any limb's",
        ),
        (lambda t, a: ("a", "b"), DRAWS, r"^motion: time: expected numbers, got 'a'"),
        (lambda t, a: (t, a), DRAWS | {"mass": [1.5, -1.0]}, r"^posterior: mass: every draw"),
        (
            lambda t, a: (t, a),
            DRAWS | {"mass": [1.5, float("nan")]},
            r"^posterior: mass: every draw must be a positive number, got nan",
        ),
        (lambda t, a: (t, a), DRAWS | {"mass": ["x", 1]}, r"^posterior: mass: expected numbers"),
    ],
    ids=[
        "degrees",
        "milliseconds",
        "rounded stamps",
        "acceleration",
        "not numbers",
        "negative mass",
        "nan mass",
        "text mass",
    ],
)
def test_propagate_refuses_what_its_units_cannot_mean(motion, draws, pattern):
    with pytest.raises(InputError, match=pattern) as err:
        propagate(draws, motion(*_swing()))
    assert "\n" not in str(err.value)


def test_propagate_of_a_long_motion_is_one_line_not_a_memory_error():
    time = np.arange(1_000_000) / 1000.0
    angle = 0.5 * np.sin(2 * np.pi * 0.5 * time)
    big = {p: np.full(4000, v[0]) for p, v in DRAWS.items()}
    with pytest.raises(InputError, match=r"1000000 samples x 4000 draws .* GiB"):
        propagate(big, (time, angle, np.zeros_like(time)))
    # fewer draws go through, every value right: I alpha + M_g sin(theta) with alpha 0
    fine = propagate(big, (time, angle, np.zeros_like(time)), draws=100)
    assert fine.moments.shape == (100, time.size)


def test_propagate_of_a_right_motion_gives_the_physics():
    from inertiafit.physics import gravity_moment

    time, angle = _swing()
    out = propagate(DRAWS, (time, angle, np.zeros_like(time)))
    expected = gravity_moment(1.5, 0.15, 9.81) * np.sin(angle)
    np.testing.assert_allclose(out.moments[0], expected, rtol=1e-12)


# -- no traceback: a public function's bad argument is one InputError line -----------------------


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda post, tmp: read_trial(None), r"^path: expected a file path .*got None$"),
        (lambda post, tmp: load_study(None), r"^path: expected a file path .*got None$"),
        (lambda post, tmp: post.save(tmp), r"^path: .* is a folder; give a file name"),
        (lambda post, tmp: post.corner("nobody"), r"^body: 'nobody' is not in this posterior"),
        (lambda post, tmp: post.draws("disk-3kg", "massx"), r"^parameter: 'massx' is not in"),
        (
            lambda post, tmp: propagate(post, ("a", "b")),
            r"^motion: time: expected numbers, got 'a'$",
        ),
    ],
    ids=["read_trial", "load_study", "save", "corner", "draws", "propagate"],
)
def test_a_bad_argument_is_one_line(disk_fit, tmp_path, call, pattern):
    post = open_posterior(disk_fit / "posterior.nc")
    with pytest.raises(InputError, match=pattern) as err:
        call(post, tmp_path)
    assert "\n" not in str(err.value)


# -- nothing overwritten without the marker -------------------------------------------------------


def test_report_in_an_unmarked_folder_overwrites_nothing(disk_fit, tmp_path):
    # a posterior.nc copied into a paper folder with the user's own summary.md, methods.md
    # and report.html: report refuses, naming them, and changes nothing; with only the data
    # files there it draws everything
    from inertiafit.io.outputs import MARKER

    paper = tmp_path / "paper"
    shutil.copytree(disk_fit, paper)
    (paper / MARKER).unlink()
    for name in ("summary.md", "methods.md", "report.html"):
        (paper / name).write_text(f"my own {name}\n")
    refused(["report", str(paper)], tmp_path, r"summary\.md", r"would be overwritten", MARKER)
    assert (paper / "summary.md").read_text(encoding="utf-8") == "my own summary.md\n"
    clean = tmp_path / "clean"
    clean.mkdir()
    shutil.copyfile(disk_fit / "posterior.nc", clean / "posterior.nc")
    assert main(["report", str(clean)]) == 0
    assert (clean / "report.html").is_file()


# -- the data check the manifest ------------------------------------------------------------------


def test_joint_angle_at_zero_120_for_30_is_answered_or_said(tmp_path):
    # The issue's slip: the elbow's angle at the device's 0 written as 120 deg where it is 30.
    # The smooth passive curve follows the joint wherever its angles sit: the forearm's I and
    # M_g stay right. The fixed curve cannot, and its posterior pulls the attachment away from
    # its own rigid condition: that is said, naming the key (24 SEs here); the right manifest
    # (negative control) says nothing of the kind.
    from inertiafit.pipeline.study import analyse_study

    manifest = simulate_living_study(tmp_path, seed=8, postures="two", trials_per_speed=3)
    truth = tomllib.loads((tmp_path / "truth.toml").read_text(encoding="utf-8"))["bodies"][
        "forearm"
    ]
    text = manifest.read_text(encoding="utf-8")

    def run(angle: float, curve: str):
        edited = text.replace("joint_angle_at_zero = 30.0", f"joint_angle_at_zero = {angle}")
        if curve == "fixed":
            edited = edited.replace("[passive]\n", '[passive]\ncurve = "fixed"\n', 1)
        manifest.write_text(edited)
        result = analyse_study(manifest, seed=1)
        said = [w for w in result.warnings if "do not describe the same bodies" in w]
        return result.posterior, said

    for curve in ("smooth", "fixed"):
        _, said = run(30.0, curve)
        assert not said
    post, said = run(120.0, "smooth")
    assert not said
    for quantity in ("inertia", "gravity_moment"):
        draws = post.draws("forearm", quantity).ravel()
        lo, hi = np.quantile(draws, [0.005, 0.995])
        assert lo < truth[quantity] < hi, quantity
    _, said = run(120.0, "fixed")
    assert len(said) >= 1
    assert "condition attachment: its own trials give I" in said[0]
    assert "joint_angle_at_zero" in said[0]


def test_a_declared_posture_without_trials_is_said_not_reported(tmp_path):
    # it was listed in passive_parameters.csv as "rotation 45 +- 0", as if measured
    root = tmp_path / "study"
    manifest = simulate_living_study(root, seed=36, postures="one", trials_per_speed=2)
    text = manifest.read_text(encoding="utf-8")
    manifest.write_text(
        text.replace("[defaults]", "[postures.lying]\ngravity_rotation = 45\n\n[defaults]", 1)
    )
    processed = process_study(load_study(manifest))
    assert any("postures.lying: declared, but no trial is in it" in w for w in processed.warnings)
    from inertiafit.processing.living import living_tables

    table = living_tables(processed.living, processed.damping)["passive_parameters"]
    assert "rotation:lying" not in set(table["parameter"])
    assert "rotation:upright" in set(table["parameter"])  # the posture with trials stays


def test_a_contradiction_far_past_the_evidence_is_measured_in_its_ses():
    # One body in two conditions whose inertias differ by 0.1 kg m^2 at SEs of 0.001: the
    # joint posterior sits between, each condition ~50 of its SEs away (past the refusal
    # limit); 0.002 apart (negative control) is within the warning limit.
    from inertiafit.inference.fit import fit
    from inertiafit.inference.model import Condition, Model
    from inertiafit.inference.observations import Observation
    from inertiafit.inference.priors import load_prior
    from inertiafit.pipeline.study import CONFLICT_REFUSE_SD, CONFLICT_SD, evidence_conflicts

    def conflicts(second: float):
        model = Model(
            {"d": load_prior("disk-3kg")},
            [
                Condition(
                    ("d",),
                    Observation.from_mean_se(i, 0.001),
                    Observation.from_mean_se(12.8, 0.05),
                    label=label,
                )
                for label, i in (("one", 0.594), ("two", second))
            ],
        )
        return evidence_conflicts(model, fit(model, seed=0), where="study.toml")

    far = conflicts(0.694)
    assert {c.condition for c in far} == {"one", "two"}
    assert all(CONFLICT_REFUSE_SD < c.apart < 60 for c in far)
    assert far[0].line.startswith("study.toml: condition one: its own trials give I = 0.594")
    assert all(c.apart < CONFLICT_SD for c in conflicts(0.596)) or not conflicts(0.596)


def test_a_contradiction_past_the_limit_refuses_the_study_with_its_table(tmp_path, monkeypatch):
    # the refusal's wiring: the worst conflict's condition marked in diagnostics.csv
    from cases import one_condition_study

    from inertiafit.pipeline import study as pipeline_study

    manifest = one_condition_study(tmp_path / "s") / "study.toml"
    line = "study.toml: condition attachment: its own trials give I = 0.3 (41 of its SEs apart): "
    monkeypatch.setattr(
        pipeline_study,
        "evidence_conflicts",
        lambda *a, **k: [
            pipeline_study.Conflict(line + pipeline_study.CONFLICT_ADVICE, "attachment", 41.0)
        ],
    )
    code, err = run_cli(["run", str(manifest), "--out", str(tmp_path / "out")])
    assert code == 2
    assert err.splitlines()[-1] == (
        "inertiafit: error: " + line + "refused: past 30 SEs no interval of this posterior "
        "holds; check the keys that link the conditions (joint_angle_at_zero, "
        "gravity_rotation, the passive priors' units, torque_sign)"
    )
    table = pd.read_csv(tmp_path / "out" / "diagnostics.csv")
    fast = table[table["kind"] == "fast"]
    assert (fast["status"] == "refused").all()


def test_a_long_condition_label_names_its_figures_within_the_limit():
    # four bodies of 64-character names made a 270-byte file name and crashed after sampling
    from inertiafit.report.figures import MAX_STEM_BYTES, FigureRecord, safe_stem

    label = "+".join(f"{k}" * 64 for k in "abcd")
    record = FigureRecord(f"fast-trials-{label}", lambda: None, "Trials", "caption")
    assert len(record.stem.encode()) <= MAX_STEM_BYTES
    assert record.stem.startswith("fast-trials-aaaa")
    other = FigureRecord(f"fast-trials-{label[:-1]}e", lambda: None, "Trials", "caption")
    assert other.stem != record.stem  # the hash keeps two long labels apart
    assert safe_stem(record.stem) == record.stem  # stable
    emoji = safe_stem("corner-" + "\U0001f600" * 64)  # cut on a whole character
    assert len(emoji.encode()) <= MAX_STEM_BYTES
    assert set(emoji.removeprefix("corner-").rsplit("-", 1)[0]) == {"\U0001f600"}
    assert safe_stem("corner-attachment") == "corner-attachment"  # short ones as they were


def test_a_full_disk_is_one_line_and_loses_nothing(tmp_path, monkeypatch):
    # it was an OSError traceback; the earlier outputs stay as they were
    import errno

    from cases import one_condition_study
    from test_outputs_safety import snapshot

    from inertiafit.report import outputs as outputs_module

    manifest = one_condition_study(tmp_path / "s") / "study.toml"
    out = tmp_path / "out"
    assert main(["run", str(manifest), "--out", str(out)]) == 0
    before = snapshot(tmp_path)

    def full(folder, *_a, **_k):
        raise OSError(errno.ENOSPC, "No space left on device", str(folder / "summary.csv"))

    monkeypatch.setattr(outputs_module, "write_tables", full)
    code, err = run_cli(["run", str(manifest), "--out", str(out)])
    assert code == 1
    assert err.splitlines()[-1].startswith("inertiafit: error: ")
    assert err.splitlines()[-1].endswith(
        "summary.csv: No space left on device; nothing was replaced (an output folder is "
        "swapped in only once complete); free some space and run again"
    )
    assert "Traceback" not in err
    assert snapshot(tmp_path) == before  # the staging folder gone, the outputs as they were


@pytest.fixture(scope="module")
def with_emg(tmp_path_factory):
    """A one-posture living study whose trials record biceps and triceps EMG."""
    from inertiafit.simulate.emg import EmgSimulation

    root = tmp_path_factory.mktemp("emg36") / "study"
    simulate_living_study(root, seed=3, postures="one", trials_per_speed=2, emg=EmgSimulation())
    return root


def _scale_channel(manifest: Path, factor: float) -> None:
    for path in sorted((manifest.parent / "data").glob("*.csv")):
        frame = pd.read_csv(path)
        if "biceps" in frame:
            frame["biceps"] *= factor
            frame.to_csv(path, index=False)


def test_a_dead_emg_channel_is_named_with_its_file(with_emg, tmp_path):
    # it was "rest.biceps: expected a level > 0 V and an SD >= 0 V, got (0.0, 0.0)"
    manifest = copy_of(with_emg, tmp_path)
    _scale_channel(manifest, 0.0)
    run_refused(
        manifest,
        tmp_path,
        r"data/B_upright_rest_1\.csv: EMG channel 'biceps' is flat \(0 V over ",
        r"a dead or unplugged electrode",
    )


def test_emg_in_microvolts_among_volts_is_said(with_emg, tmp_path):
    # one channel written in uV where the manifest says V: its verdicts stand (each channel
    # against its own rest level), and the units are said; the study as written says nothing
    manifest = copy_of(with_emg, tmp_path)
    clean = process_study(load_study(manifest))
    assert not any("EMG channels" in w for w in clean.warnings)
    _scale_channel(manifest, 1e6)
    processed = process_study(load_study(manifest))
    said = [w for w in processed.warnings if "EMG channels 'biceps' and 'triceps'" in w]
    assert len(said) == 1
    assert "1e+06 times apart" in said[0]
    assert "uV read as V?" in said[0]
    pd.testing.assert_series_equal(processed.trials["status"], clean.trials["status"])
