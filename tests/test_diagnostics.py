"""Issue 21, item 1: a failed run explains itself.

Every check has a bad input built from a simulated study (:func:`cases.one_condition_study`:
the attachment, a 90-deg quasi-static sweep, three fast trials at 240 deg/s) and corrupted as
the issue saw it happen; each asserts the one-line error in full and the per-trial table
(``diagnostics.csv``: columns, values, the trials at fault marked). Negative controls: the
clean study passes every check without a new message, and an earlier run's outputs are never
replaced by the table of a refused one. Nothing is sampled (the sampler is a sentinel where a
case must get that far).
"""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest
from test_cli_arguments import assert_one_line, run_cli
from test_io_formats import CALIBRATION, vicon_style_c3d
from test_issue22_catalogue import (
    FAST,
    Sampled,
    base,  # noqa: F401 (a fixture)
    copy_of,
    edit_csv,
    reaches_the_sampler,  # noqa: F401 (a fixture)
    set_in_trial,
)
from test_outputs_safety import earlier, snapshot

from inertiafit.cli import main
from inertiafit.errors import InputError, StudyRefused
from inertiafit.inference.evidence import check_trials_in_priors, study_priors
from inertiafit.io import load_study, read_trial
from inertiafit.io.outputs import MARKER
from inertiafit.pipeline.batch import run_many
from inertiafit.pipeline.study import DIAGNOSTICS, analyse_study
from inertiafit.processing.inertia import InertiaEstimate
from inertiafit.processing.plausibility import inertia_sign_checks
from inertiafit.processing.study import TRIAL_COLUMNS, process_study
from inertiafit.report.text import diagnostics_text

QS = "data/A_quasistatic.csv"
FASTS = ["data/A_240_01.csv", "data/A_240_02.csv", "data/A_240_03.csv"]
COLUMNS = [*TRIAL_COLUMNS, "cause"]
#: What the attachment's prior box (nominal x (1 +- 0.5)) allows.
I_RANGE = r"the 0\.0246 to 0\.663 kg m\^2 that the priors of 'attachment' allow"
MG_RANGE = r"the 1\.61 to 14\.5 N m that the priors of 'attachment' allow"


def refused_run(manifest: Path, out: Path, pattern: str) -> tuple[str, pd.DataFrame]:
    """``inertiafit run``: exit 2, the error line matching ``pattern`` whole; stderr and table."""
    code, err = run_cli(["run", str(manifest), "--out", str(out)])
    assert code == 2, err
    assert_one_line(err)
    line = err.splitlines()[-1].removeprefix("inertiafit: error: ")
    assert re.fullmatch(pattern, line), (pattern, line)
    # the table was printed before the error, and written beside nothing else
    assert "per-trial table of the refused study (diagnostics.csv):" in err
    assert f"per-trial table written to {out / DIAGNOSTICS}" in err
    assert sorted(p.name for p in out.iterdir()) == [MARKER, DIAGNOSTICS]
    table = pd.read_csv(out / DIAGNOSTICS)
    assert list(table.columns) == COLUMNS
    assert list(table.file) == [QS, *FASTS]
    return err, table.set_index("file")


def cut_sweep(manifest: Path, degrees: float = 2.5) -> None:
    """The quasi-static trial cut to ``degrees`` of its 90-deg sweep."""
    path = manifest.parent / QS
    frame = pd.read_csv(path)
    low = frame.angle.min() + 40
    frame[(frame.angle >= low) & (frame.angle <= low + degrees)].to_csv(path, index=False)


def scale_torque(manifest: Path, files: list[str], factor: float) -> None:
    for file in files:
        edit_csv(manifest.parent / file, lambda f: f.__setitem__("torque", f.torque * factor))


# -- a quasi-static trial that sweeps less than its fit needs --------------------------------


def test_a_sweep_that_does_not_determine_m_g_is_refused_naming_it(base, tmp_path):  # noqa: F811
    # the living ankle of the issue: M_g = 1518 +- 3428 N m from a trial that barely moved
    manifest = copy_of(base, tmp_path)
    cut_sweep(manifest)
    err, table = refused_run(
        manifest,
        tmp_path / "out",
        r"\S+/data/A_quasistatic\.csv: angle: a quasi-static sweep of 2\.5 deg gives "
        r"M_g = 184\.6 ± 703\.4 N m, which it does not determine \(the interval reaches 0\); "
        r"record the quasi-static trial over 30 deg or more \(the fast trials' range\)",
    )
    assert table.loc[QS, "status"] == "refused"
    assert table.loc[QS, "gravity_moment"] == pytest.approx(184.6, abs=0.05)
    assert table.loc[QS, "gravity_moment_se"] == pytest.approx(703.4, abs=0.05)
    assert table.loc[QS, "cause"].startswith("angle: a quasi-static sweep of 2.5 deg")
    assert "small angle range: 2.5 deg < 30 deg" in table.loc[QS, "flags"]
    assert list(table.loc[FASTS, "status"]) == ["not reached"] * 3
    assert table.loc[FASTS, "cause"].isna().all()
    # the terminal shows the same rows
    row = next(x for x in err.splitlines() if x.startswith(QS))
    assert re.search(r"184\.6 ± 703 +refused +angle: a quasi-static sweep", row), row


def test_a_sweep_of_thirty_degrees_is_not_refused(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    cut_sweep(manifest, 30.0)
    processed = process_study(manifest)  # 5.34 +- 0.53 N m: short, but determined
    assert processed.gravity["attachment"].gravity_moment == pytest.approx(5.34, abs=0.01)


# -- each trial's I and M_g against what the priors allow --------------------------------------


def test_fast_trials_outside_the_priors_are_refused_naming_them(base, tmp_path):  # noqa: F811
    # per-trial inertias of 4-27 kg m^2 were answered "mass upper bound 2.219 kg is below
    # (M_g/g)^2/I = 5076 kg", naming neither the trials nor their values
    manifest = copy_of(base, tmp_path)
    scale_torque(manifest, FASTS, 20.0)
    _, table = refused_run(
        manifest,
        tmp_path / "out",
        r"\S+/study\.toml: condition 'attachment': its fast trials give I = 5\.99 to 6\.03 "
        r"kg m\^2 \(data/A_240_01\.csv 6\.03, data/A_240_02\.csv 6, data/A_240_03\.csv 5\.99\), "
        rf"outside {I_RANGE}: check those trials \(a wrongly scaled torque or velocity, a "
        r"wrong window\?\) before the priors",
    )
    assert list(table.status) == ["ok", "refused", "refused", "refused"]
    assert table.loc[QS, "gravity_moment"] == pytest.approx(6.732, abs=5e-4)
    assert list(table.loc[FASTS, "inertia"].round(2)) == [6.03, 6.0, 5.99]
    assert table.loc[FASTS[1], "cause"] == (
        "I = 6 kg m^2, outside the 0.0246 to 0.663 kg m^2 that the priors of 'attachment' allow"
    )


def test_a_quasi_static_m_g_outside_the_priors_is_refused_before_the_fast_trials(
    base,  # noqa: F811
    tmp_path,
):
    # a torque 10x too large in the quasi-static trial made every fast inertia negative, and
    # the advice was to flip the fast trials' torque sign
    manifest = copy_of(base, tmp_path)
    scale_torque(manifest, [QS], 10.0)
    _, table = refused_run(
        manifest,
        tmp_path / "out",
        r"\S+/study\.toml: condition 'attachment': its quasi-static trials give M_g = 67\.3 N m "
        rf"\(data/A_quasistatic\.csv 67\.3\), outside {MG_RANGE}: check those trials \(a "
        r"flat, clipped or wrongly scaled torque, too short a sweep\?\) before the priors",
    )
    assert list(table.status) == ["refused", "not reached", "not reached", "not reached"]
    assert table.loc[QS, "gravity_moment"] == pytest.approx(67.28, abs=0.01)


def test_one_trial_outside_the_priors_is_flagged_and_the_study_goes_on(
    base,  # noqa: F811
    tmp_path,
    reaches_the_sampler,  # noqa: F811
):
    manifest = copy_of(base, tmp_path)
    scale_torque(manifest, [FASTS[1]], 20.0)
    study = load_study(manifest)
    processed = process_study(study)
    notes = check_trials_in_priors(study, processed.trials, processed.gravity, study_priors(study))
    flag = (
        "I = 6 kg m^2 is outside the 0.0246 to 0.663 kg m^2 that the priors of 'attachment' "
        "allow, unlike its condition's 0.205 kg m^2: an outlier? check this trial (a wrongly "
        "scaled torque or velocity, a wrong window?)"
    )
    assert notes == [f"{manifest.parent / FASTS[1]}: {flag}"]
    flags = processed.trials.set_index("file")["flags"]
    assert flags[FASTS[1]].endswith(flag)
    assert not any("outside" in str(flags[f]) for f in (QS, FASTS[0], FASTS[2]))
    with pytest.raises(Sampled):
        main(["run", str(manifest), "--out", str(tmp_path / "o")])
    assert not (tmp_path / "o").exists()


def test_a_prior_box_without_a_solution_marks_its_conditions_trials(
    base,  # noqa: F811
    tmp_path,
    reaches_the_sampler,  # noqa: F811
):
    # each value inside what the box allows, the pair not: m >= (M_g/g)^2/I = 2.3 kg > 0.8 kg
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8")
    start = text.index("prior = {")
    end = text.index("}", start) + 1
    box = "prior = { mass = 0.5, radius_of_gyration = 0.2, com_distance = 1.0, spread = 0.6 }"
    manifest.write_text(text[:start] + box + text[end:])
    _, table = refused_run(
        manifest,
        tmp_path / "out",
        r"prior '\S+': the prior box contains no solution for condition 'attachment': mass "
        r"upper bound 0\.8 kg is below \(M_g/g\)\^2/I = 2\.3\d* kg",
    )
    assert list(table.status) == ["refused"] * 4
    assert table.loc[FASTS[0], "cause"].startswith("prior '")


# -- a condition's M_g scattered far beyond its SEs --------------------------------------------


def second_quasi_static(manifest: Path, factor: float) -> None:
    frame = pd.read_csv(manifest.parent / QS)
    frame["torque"] = frame.torque * factor
    frame.to_csv(manifest.parent / "data/A_quasistatic_2.csv", index=False)
    with manifest.open("a", encoding="utf-8") as fh:
        fh.write('\n[[trials]]\nfile = "data/A_quasistatic_2.csv"\nbodies = ["attachment"]\n')
        fh.write('kind = "quasi-static"\n')


def test_quasi_static_m_g_scattered_beyond_their_errors_are_refused(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    second_quasi_static(manifest, 1.3)  # a body moved between them: M_g 30 % apart
    with pytest.raises(StudyRefused) as info:
        process_study(manifest)
    message = str(info.value)
    assert re.fullmatch(
        r"\S+/study\.toml: condition 'attachment': its quasi-static trials give M_g = 6\.732 "
        r"± 0\.038 N m \(\S+/data/A_quasistatic\.csv\), 8\.751 ± 0\.05 N m "
        r"\(\S+/data/A_quasistatic_2\.csv\): 32 standard errors apart, where one condition has "
        r"one M_g; check for a body moved between them, a trial of another mounting or a "
        r"torque zero that drifted, and give such a trial its own condition \(or remove it\)",
        message,
    ), message
    table = info.value.table.set_index("file")
    assert list(info.value.refused) == [QS, "data/A_quasistatic_2.csv"]
    assert list(table.status) == ["refused", *["not reached"] * 3, "refused"]
    assert table.loc["data/A_quasistatic_2.csv", "gravity_moment"] == pytest.approx(8.751, 1e-3)


def test_quasi_static_m_g_within_their_errors_are_combined(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    second_quasi_static(manifest, 1.001)  # 0.1 % apart: 0.2 of their errors
    processed = process_study(manifest)
    assert processed.gravity["attachment"].gravity_moment == pytest.approx(6.735, abs=1e-3)


# -- advice (a torque sign) only where the data support it -------------------------------------


def flip(manifest: Path, files: list[str]) -> None:
    for file in files:
        edit_csv(manifest.parent / file, lambda f: f.__setitem__("torque", -f.torque))


NEGATIVE = (
    r"\S+/data/A_240_01\.csv: torque: inertia -0\.39\d* kg m\^2 is negative \(the torque "
    r"opposes the acceleration in the window 0\.199 to 0\.321 s\); "
)


def test_every_fast_trial_negative_is_told_its_torque_sign(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    flip(manifest, FASTS)
    _, table = refused_run(
        manifest,
        tmp_path / "out",
        NEGATIVE + r"all 3 fast trials of condition 'attachment' are negative: torque sign: "
        r"set torque_sign = -1 for this trial in the manifest",
    )
    assert list(table.status) == ["ok", "refused", "refused", "refused"]
    assert (table.loc[FASTS, "inertia"] < -0.38).all()


def test_one_file_written_with_the_other_sign_is_told_its_torque_sign(base, tmp_path):  # noqa: F811
    # issue 36: it was told that flipping "would mix signs", though its own torque_sign = -1
    # is the fix: its cruise follows the gravity model negated (slope -1), its siblings are
    # positive
    manifest = copy_of(base, tmp_path)
    flip(manifest, [FASTS[0]])
    _, table = refused_run(
        manifest,
        tmp_path / "out",
        NEGATIVE + r"its torque at constant speed follows the condition's gravity model negated "
        r"\(slope -1\.?\d*\) where its other fast trials are positive: this file's torque is "
        r"written with the other sign; torque sign: set torque_sign = -1 for this trial in the "
        r"manifest",
    )
    assert list(table.status) == ["ok", "refused", "ok", "ok"]
    assert list(table.loc[FASTS, "inertia"].round(2)) == [-0.4, 0.2, 0.2]
    # following the advice gives the trial its siblings' inertia
    text = manifest.read_text(encoding="utf-8")
    start = text.index(f'file = "{FASTS[0]}"')
    manifest.write_text(text[:start] + text[start:].replace("\n", "\ntorque_sign = -1\n", 1))
    processed = process_study(manifest)
    assert processed.trials.set_index("file").loc[FASTS[0], "inertia"] == pytest.approx(
        0.204, abs=0.003
    )


def test_a_negative_trial_without_a_cruise_is_not_told_to_flip():
    # no cruise compared with the gravity model (slope unknown): "mix signs", not a flip
    trials = [(1, estimate(-0.39), None), (1, estimate(0.20), 0.99), (1, estimate(0.21), 1.0)]
    verdict = inertia_sign_checks(trials, "attachment")[0]
    assert verdict is not None
    assert "flipping its sign would mix signs within the condition" in verdict.error


def estimate(inertia: float, se: float = 0.01) -> InertiaEstimate:
    return InertiaEstimate(inertia, se, inertia, 0.2, 0.32, 120, 1.0, source="t.csv")


def test_a_gravity_model_that_misses_the_fast_trials_is_blamed_not_their_sign():
    # a quasi-static torque 10x too large made every fast inertia negative (-0.70 kg m^2) and
    # drew "set torque_sign = -1"; its cruise torque follows the model with a slope of 0.1
    trials = [(1, estimate(-0.70), 0.1), (1, estimate(-0.69), 0.1)]
    verdicts = inertia_sign_checks(trials, "attachment")
    assert verdicts[0] is not None
    assert verdicts[0].error == (
        "t.csv: torque: inertia -0.7 kg m^2 is negative (the torque opposes the acceleration in "
        "the window 0.2 to 0.32 s); its torque at constant speed follows the condition's gravity "
        "model with a slope of 0.1 where ±1 is expected: the gravity model (its quasi-static "
        "trials' scale, sweep or sign) is wrong, not this torque's sign"
    )


@pytest.mark.parametrize(
    ("slope", "advice"),
    [
        # quasi-static and fast trials agree (slope +1): the whole condition is flipped
        (
            1.0,
            (
                "all 2 fast trials of condition 'a' are negative and agree with its quasi-static "
                "trials: the whole condition is signed opposite; torque sign: set torque_sign = "
                "-1 for this trial in the manifest, and for its quasi-static trials"
            ),
        ),
        # the fast trials run against the quasi-static one (slope -1): flip them
        (
            -1.0,
            (
                "all 2 fast trials of condition 'a' are negative: torque sign: set torque_sign = "
                "-1 for this trial in the manifest"
            ),
        ),
    ],
)
def test_every_negative_trial_is_told_which_sign_to_flip(slope, advice):
    trials = [(1, estimate(-0.2, 0.1), slope), (1, estimate(-0.21), slope)]
    first, second = inertia_sign_checks(trials, "a")
    assert first is not None
    assert first.flag == f"negative inertia -0.2 ± 0.1 kg m^2; {advice}"  # within 3 SE
    assert second is not None
    assert second.error.endswith(advice)


def test_a_trial_flipped_alone_is_told_to_match_its_siblings():
    trials = [(-1, estimate(-0.2), -1.0), (1, estimate(0.2), 1.0), (1, estimate(0.21), 1.0)]
    verdicts = inertia_sign_checks(trials, "a")
    assert verdicts[1:] == [None, None]
    assert verdicts[0] is not None
    assert verdicts[0].error.endswith(
        "its torque_sign differs from that of the condition's positive fast trials: torque "
        "sign: the torque is already flipped (torque_sign = -1); set torque_sign = 1"
    )


def test_a_gravity_model_of_the_wrong_scale_is_flagged(base, tmp_path):  # noqa: F811
    # the quasi-static torque 2x (M_g 13.5 N m, inside the priors): every inertia came out
    # half its value (0.104 for 0.205 kg m^2) without a word
    manifest = copy_of(base, tmp_path)
    scale_torque(manifest, [QS], 2.0)
    flags = process_study(manifest).trials.set_index("file")["flags"]
    for file in FASTS:
        assert re.search(
            r"torque: at constant speed it follows the condition's gravity model with a slope "
            r"of 0\.5\d? where 1 is expected: the quasi-static trials and this one disagree in scale",
            flags[file],
        ), flags[file]


# -- the output folder: checked first, and an earlier run's outputs kept -----------------------


def test_an_earlier_run_is_never_replaced_by_a_refused_ones_table(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    cut_sweep(manifest)
    out = earlier(tmp_path / "out")
    before = snapshot(out)
    code, err = run_cli(["run", str(manifest), "--out", str(out)])
    assert code == 2
    assert_one_line(err, r"A_quasistatic\.csv: angle: a quasi-static sweep of 2\.5 deg")
    assert f"{DIAGNOSTICS} not written: {out} holds an earlier run's outputs, kept" in err
    assert snapshot(out) == before


def test_a_refused_runs_table_is_replaced_by_the_next_ones(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    cut_sweep(manifest)
    out = tmp_path / "out"
    refused_run(manifest, out, r".*a quasi-static sweep of 2\.5 deg.*")
    copy_of(base, tmp_path / "again")
    second = tmp_path / "again" / "study" / "study.toml"
    scale_torque(second, FASTS, 20.0)
    _, table = refused_run(second, out, r".*its fast trials give I = .*")
    assert list(table.status) == ["ok", "refused", "refused", "refused"]


def test_run_many_leaves_a_refused_studys_table_in_its_folder(base, tmp_path):  # noqa: F811
    refused = copy_of(base, tmp_path / "bad")
    cut_sweep(refused)
    lines: list[str] = []
    out = tmp_path / "batch"
    result = run_many([refused], out, formats=("png",), echo=lines.append, workers=1)
    assert result.failed == [str(refused)]
    row = result.table.iloc[0]
    assert row["status"] == "failed"
    assert re.fullmatch(
        r".*A_quasistatic\.csv: angle: a quasi-static sweep of 2\.5 deg.*", row["error"]
    )
    # the row names the folder that holds the table, and a line says where it is
    assert row["folder"] == "study"
    assert "[1/1] study: per-trial table in study/diagnostics.csv" in lines
    assert sorted(p.name for p in (out / "study").iterdir()) == [MARKER, DIAGNOSTICS]
    table = pd.read_csv(out / "study" / DIAGNOSTICS).set_index("file")
    assert list(table.columns) == COLUMNS[1:]
    assert table.loc[QS, "status"] == "refused"
    assert "a quasi-static sweep of 2.5 deg" in table.loc[QS, "cause"]
    assert (table.loc[FASTS, "status"] == "not reached").all()


def test_out_is_checked_before_the_manifest_is_read(tmp_path):
    manifest = tmp_path / "study.toml"
    manifest.write_text("this is [not toml\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "note.txt").write_text("mine")
    code, err = run_cli(["run", str(manifest), "--out", str(out)])
    assert code == 2
    assert_one_line(err, rf"--out: folder {out} exists, is not empty and was not written")


def test_fit_checks_out_before_its_prior(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "note.txt").write_text("mine")
    argv = ["fit", "--prior", "no-such-prior", "--inertia", "0.2", "--inertia-se", "0.01"]
    code, err = run_cli(
        [*argv, "--gravity-moment", "7", "--gravity-moment-se", "0.1", "--out", str(out)]
    )
    assert code == 2
    assert_one_line(err, rf"--out: folder {out} exists, is not empty and was not written")


# -- negative control: a good study passes without a new message -----------------------------


def test_a_clean_study_passes_every_check_silently(
    base,  # noqa: F811
    tmp_path,
    reaches_the_sampler,  # noqa: F811
):
    study = load_study(base / "study.toml")
    processed = process_study(study)
    before = processed.trials.copy()
    notes = check_trials_in_priors(study, processed.trials, processed.gravity, study_priors(study))
    assert notes == []
    pd.testing.assert_frame_equal(processed.trials, before)  # no flag added
    words = ("outside", "negative", "sweep", "standard errors apart", "torque_sign", "slope")
    assert not [w for w in processed.warnings if any(x in w for x in words)]
    with pytest.raises(Sampled):
        analyse_study(study)
    out = tmp_path / "out"
    with pytest.raises(Sampled):  # the sentinel ends it, not a refusal
        main(["run", str(base / "study.toml"), "--out", str(out)])
    assert not out.exists()


def test_the_library_error_carries_the_table(base, tmp_path):  # noqa: F811
    manifest = copy_of(base, tmp_path)
    scale_torque(manifest, FASTS, 20.0)
    with pytest.raises(StudyRefused) as info:
        analyse_study(manifest)
    assert isinstance(info.value, InputError)
    assert sorted(info.value.refused) == FASTS
    assert list(info.value.table.columns) == COLUMNS
    text = diagnostics_text(info.value.table)
    lines = text.splitlines()
    assert lines[0].split() == [
        "file", "condition", "kind", "speed", "I", "(kg", "m^2)", "M_g", "(N", "m)", "status",
        "note",
    ]  # fmt: skip
    assert re.match(
        r"data/A_240_01\.csv +attachment +fast +240 +6\.0\d* ± 0\.\d+ +refused +I = 6\.03",
        lines[2],
    )


# -- readers' defaults, said --------------------------------------------------------------------


def test_a_c3d_file_needs_no_format(tmp_path):
    path = vicon_style_c3d(tmp_path / "trial.dat")  # not even named .c3d
    assert read_trial(path, calibration=CALIBRATION).attrs["format"] == "c3d"
    manifest = tmp_path / "study.toml"
    manifest.write_text(
        "[bodies.a]\nprior = { mass = 1, radius_of_gyration = 0.1, com_distance = 0.1 }\n"
        "[defaults.calibration]\n"
        'angle = { scale = 90.0, offset = 10.0, unit = "deg" }\n'
        'velocity = { scale = 100.0, unit = "deg/s" }\n'
        'torque = { scale = -1.44e5, unit = "N*m" }\n'
        '[[trials]]\nfile = "trial.dat"\nbodies = ["a"]\nkind = "quasi-static"\n'
    )
    assert load_study(manifest).trials[0].format == "c3d"


def test_a_text_file_without_format_is_csv(base):  # noqa: F811
    assert {t.format for t in load_study(base / "study.toml").trials} == {"csv"}


def test_a_calibration_without_unit_is_refused(tmp_path):
    path = vicon_style_c3d(tmp_path / "trial.c3d")
    no_unit = {**CALIBRATION, "torque": {"scale": -1.44e5}}
    with pytest.raises(InputError) as info:
        read_trial(path, calibration=no_unit)
    assert str(info.value) == (
        f"{path}: calibration.torque.unit: missing; give the unit of scale x volts + offset "
        "(e.g. 'N*m'; or units.torque)"
    )
    # the unit said once, in units, is enough
    trial = read_trial(path, calibration=no_unit, units={"torque": "N*m"})
    assert trial.attrs["format"] == "c3d"


def test_a_window_on_a_quasi_static_trial_is_refused(base, tmp_path):  # noqa: F811
    manifest = set_in_trial(copy_of(base, tmp_path), "window = [0.1, 0.2]", file=QS)
    with pytest.raises(InputError) as info:
        load_study(manifest)
    assert re.fullmatch(
        r"\S+/study\.toml: trials\[0\]\.window: a quasi-static trial has no acceleration window \(its gravity "
        r'fit uses the whole sweep\); remove it, or set kind = "fast" if this trial is one',
        str(info.value),
    ), str(info.value)
    assert FAST  # the fast trials keep theirs: tested in test_window.py
