"""Issue 22 ("Nothing lost, nothing silent"), every case it lists, each run once.

The issue found five kinds of failure: data lost, valid input refused, silently wrong numbers,
tracebacks and misleading messages. Each case it names is one test here, in the issue's order,
with a direct assertion on the outcome: through the command line where the issue used it (one
line on stderr, exit status 2, every input and earlier output byte-identical), through the
Python API where only the API takes the input. Where a case is tested in depth elsewhere, the
test's comment names the file. Nothing is sampled: a case that must get as far as the sampler
proves it with the sampler replaced by a sentinel (``reaches_the_sampler``), and the one output
folder that ``report`` reads is sampled with a few hundred steps.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import warnings
from pathlib import Path

import pandas as pd
import pytest
from cases import DISK_FIT, ONE_CONDITION_FAST, one_condition_study
from test_cli_arguments import _api_cases, assert_one_line, run_cli
from test_outputs_safety import (
    DEMO_OUTPUTS,
    WRITER,
    _env,
    earlier,
    fake_redraw,  # noqa: F401 (a fixture)
    snapshot,
)

import inertiafit.inference.fit as fitting
from inertiafit.cli import main
from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.io import load_study, outputs, read_trial
from inertiafit.io.outputs import check_out, output_folder, write_csv
from inertiafit.processing.study import process_study

FAST = ONE_CONDITION_FAST
DATA = Path(__file__).parent / "data"


# -- the study every case edits, and how a case runs --------------------------------------------


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """One condition (:func:`cases.one_condition_study`)."""
    return one_condition_study(tmp_path_factory.mktemp("issue22") / "study")


def copy_of(base: Path, tmp_path: Path, name: str = "study") -> Path:
    """A copy of the study; its manifest."""
    folder = tmp_path / name
    shutil.copytree(base, folder)
    return folder / "study.toml"


def set_in_trial(manifest: Path, line: str, file: str = FAST) -> Path:
    """``line`` set in the ``[[trials]]`` entry of ``file`` (replacing a key already there)."""
    text = manifest.read_text(encoding="utf-8")
    start = text.index(f'file = "{file}"\n')
    end = text.find("[[trials]]", start)
    end = len(text) if end < 0 else end
    key = line.split("=", maxsplit=1)[0].strip()
    entry = re.sub(rf"^{key} = .*\n", "", text[start:end], flags=re.MULTILINE)
    manifest.write_text(
        text[:start] + entry.rstrip("\n") + f"\n{line}\n\n" + text[end:], encoding="utf-8"
    )
    return manifest


def edit_csv(path: Path, edit) -> None:
    frame = pd.read_csv(path)
    edit(frame)
    frame.to_csv(path, index=False)


def refused(argv: list[str], root: Path, *patterns: str) -> str:
    """``inertiafit ARGV``: exit 2, one line matching ``patterns``, nothing under ``root`` changed.

    But for a new output folder holding only a refused study's ``diagnostics.csv`` (issue 21).
    """
    before = snapshot(root)
    code, err = run_cli(argv)
    assert code == 2, err
    assert_one_line(err, *patterns)
    assert without_new_diagnostics(snapshot(root), before) == before
    return err.splitlines()[-1]


def without_new_diagnostics(after: dict[str, object], before: dict[str, object]) -> dict:
    """``after`` without a folder that is new and holds only ``diagnostics.csv`` and the marker."""
    new = [k for k in after if k not in before]
    for top in {k.split("/")[0] for k in new}:
        entries = {k for k in new if k.split("/")[0] == top}
        table = {top, f"{top}/{outputs.MARKER}", f"{top}/diagnostics.csv"}
        if top not in before and entries == table:
            for k in table:
                after.pop(k)
    return after


def run_refused(manifest: Path, tmp_path: Path, *patterns: str) -> str:
    return refused(["run", str(manifest), "--out", str(tmp_path / "out")], tmp_path, *patterns)


class Sampled(Exception):
    """The sampler was reached: every check before it passed."""


@pytest.fixture
def reaches_the_sampler(monkeypatch):
    def sample(*_args, **_kwargs):
        raise Sampled

    monkeypatch.setattr(fitting, "sample", sample)


@pytest.fixture(scope="module")
def sampled(base, tmp_path_factory):
    """An output folder of the study as ``run`` writes its data files (a short chain)."""
    from inertiafit.inference.sampler import SamplerSettings
    from inertiafit.pipeline.study import analyse_study

    real = fitting.sample
    short = SamplerSettings(chunk=100, max_steps=200, ess_min=1.0)
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)  # what the few steps give
        mp.setattr(fitting, "sample", lambda model, **kw: real(model, **{**kw, "settings": short}))
        result = analyse_study(base / "study.toml", seed=1)
    out = tmp_path_factory.mktemp("sampled") / "out"
    with output_folder(out) as folder:
        result.posterior.save(folder / "posterior.nc")
        write_csv(result.trials, folder / "trials.csv")
        write_csv(result.traces, folder / "traces.csv")
    return out


# == Data lost (depth: test_outputs_safety.py) ===================================================


def test_run_into_the_copied_demo_folder_it_reads_is_refused(tmp_path):
    # cp -r demo-output X && inertiafit run X/study/study.toml --out X deleted the manifest and
    # the trials it had just read
    x = earlier(tmp_path / "X", DEMO_OUTPUTS)
    argv = ["run", str(x / "study" / "study.toml"), "--out", str(x)]
    refused(argv, tmp_path, rf"--out: {x} holds the input")


def test_an_earlier_output_holding_a_note_of_the_users_is_refused(tmp_path):
    # any folder inertiafit once wrote counted as replaceable, whatever was in it now
    r = earlier(tmp_path / "R")
    (r / "note.txt").write_text("subject 3 moved during trial 7")
    refused([*DISK_FIT, "--out", str(r)], tmp_path, "holds note.txt, which inertiafit did not")


def test_plan_from_a_pilot_into_the_pilot_is_refused(tmp_path):
    r = earlier(tmp_path / "R")
    refused(["plan", "--pilot", str(r), "--out", str(r)], tmp_path, rf"--out: {r} is the input")


def test_out_dot_inside_an_earlier_output_is_refused(tmp_path, monkeypatch):
    # cd R && inertiafit fit ... --out . ended in a traceback with the folder empty
    r = earlier(tmp_path / "R")
    monkeypatch.chdir(r)
    refused([*DISK_FIT, "--out", "."], tmp_path, r"--out: \. is the current folder or holds it")


def test_an_old_entry_that_cannot_be_removed_leaves_the_new_folder_and_a_warning(
    tmp_path, monkeypatch, capsys
):
    # a read-only subfolder (an open PDF on Windows): old outputs gone, new discarded, traceback
    out = earlier(tmp_path / "out", {"summary.csv": "old"})
    real = shutil.rmtree

    def rmtree(path, *args, **kwargs):
        if ".out.old-" in str(path):
            raise PermissionError(13, "Permission denied", str(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(outputs.shutil, "rmtree", rmtree)
    with output_folder(out) as folder:
        (folder / "summary.csv").write_text("new")
    assert (out / "summary.csv").read_text(encoding="utf-8") == "new"
    (aside,) = tmp_path.glob(".out.old-*")
    assert (aside / "summary.csv").read_text(encoding="utf-8") == "old"
    warning = capsys.readouterr().err.strip()
    assert warning.startswith(f"inertiafit: warning: the new outputs are in {out}, but the old")
    assert "\n" not in warning


@pytest.mark.usefixtures("fake_redraw")  # report's reading and drawing: two tables at 90 %
def test_report_failing_half_way_leaves_the_old_set_whole(tmp_path, monkeypatch):
    # report --hdi-prob 0.9 failing half-way left 90 % and 95 % tables mixed in one folder
    r = earlier(tmp_path / "R", {"summary.csv": "hdi_prob\n0.95\n", "comparison.csv": "0.95\n"})
    real = os.replace
    calls = []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise PermissionError(13, "Permission denied", str(src))
        return real(src, dst)

    monkeypatch.setattr(outputs.os, "replace", replace)
    refused(["report", str(r), "--hdi-prob", "0.9"], tmp_path, r"\(Permission denied\); nothing")


def test_a_second_run_into_a_folder_being_written_is_refused(tmp_path):
    # two runs into one --out both exited 0 and the last silently won
    r = earlier(tmp_path / "R")
    (tmp_path / ".R.lock").write_text(f"{os.getpid()} {socket.gethostname()} 0\n")
    refused([*DISK_FIT, "--out", str(r)], tmp_path, "is being written by another inertiafit run")


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM from another process")
def test_sigterm_leaves_no_staging_folder(tmp_path):
    out = earlier(tmp_path / "out")
    before = snapshot(tmp_path)
    with subprocess.Popen(
        [sys.executable, "-c", WRITER, str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        encoding="utf-8",
        env=_env(),
    ) as proc:
        assert proc.stdout is not None
        assert proc.stdout.readline() == "writing\n"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 128 + signal.SIGTERM
    assert snapshot(tmp_path) == before


def test_out_is_checked_before_any_work(base, tmp_path):
    # --out was checked only after the whole analysis; here a trial cannot be read too, and
    # the error is the one about --out
    manifest = copy_of(base, tmp_path)
    (manifest.parent / FAST).write_text("time,angle\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "note.txt").write_text("mine")
    refused(["run", str(manifest), "--out", str(out)], tmp_path, rf"--out: folder {out} exists")


# == Valid input refused (depth: test_model.py, box_meets) =======================================


def test_two_trial_values_reach_the_sampler(tmp_path, reaches_the_sampler):
    # "prior box contains no solution", though m 2.78, x 0.246, rho 0.098 is inside the box
    argv = ["fit", "--prior", "biodex-elbow-attachment", "--inertia", "0.21", "0.22"]
    argv += ["--gravity-moment", "7.415", "--gravity-moment-se", "0.05"]
    with pytest.raises(Sampled):
        main([*argv, "--out", str(tmp_path / "o")])


def test_a_condition_left_with_two_fast_trials_reaches_the_sampler(
    base, tmp_path, reaches_the_sampler
):
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8")
    last = text.index('[[trials]]\nfile = "data/A_240_03.csv"')
    manifest.write_text(text[:last])
    assert len(load_study(manifest).trials) == 3
    with pytest.raises(Sampled):
        main(["run", str(manifest), "--out", str(tmp_path / "o")])


# == Silently wrong numbers (depth: test_plausibility.py, test_io_consistency.py) ================


@pytest.mark.parametrize(
    ("angle", "cause"),
    [
        (lambda a: a * 3.141592653589793 / 180, r"angle in rad read as deg\?"),
        (lambda a: a * 0.0, r"a dead or unplugged angle channel\?"),
    ],
    ids=["rad-as-deg", "dead"],
)
def test_an_angle_that_barely_moves_is_refused(base, tmp_path, angle, cause):
    # the inertia came out 8 % high with no flag
    manifest = copy_of(base, tmp_path)
    edit_csv(manifest.parent / FAST, lambda f: f.__setitem__("angle", angle(f["angle"])))
    run_refused(manifest, tmp_path, r"A_240_01\.csv: column 'angle' moves .* deg in all", cause)


@pytest.mark.parametrize("how", ["hard link", "copy"])
def test_one_recording_listed_twice_is_refused(base, tmp_path, how):
    manifest = copy_of(base, tmp_path)
    data = manifest.parent / "data"
    if how == "copy":
        shutil.copyfile(data / "A_240_02.csv", data / "A_240_09.csv")
    else:
        (data / "A_240_09.csv").hardlink_to(data / "A_240_02.csv")
    with manifest.open("a") as fh:
        fh.write('\n[[trials]]\nfile = "data/A_240_09.csv"\nbodies = ["attachment"]\n')
        fh.write('kind = "fast"\nspeed = 240.0\n')
    run_refused(manifest, tmp_path, r"A_240_09\.csv: the same recording as data/A_240_02\.csv")


def test_a_design_with_a_body_listed_twice_is_refused(tmp_path):
    # plan predicted a mass interval 10x too narrow and recommended 1 trial per speed
    design = tmp_path / "design.toml"
    design.write_text(
        "[bodies.a]\nmass = 1\ncom_distance = 0.1\nradius_of_gyration = 0.05\n"
        '[[designs]]\nconditions = [["a", "a"]]\n'
    )
    argv = ["plan", str(design), "--out", str(tmp_path / "o")]
    refused(argv, tmp_path, r"condition 'a\+a': bodies: a body is listed twice: a")


def test_a_manual_window_at_constant_speed_is_refused(base, tmp_path):
    # inertia 2x
    manifest = set_in_trial(copy_of(base, tmp_path), "window = [0.40, 0.52]")
    run_refused(manifest, tmp_path, r"A_240_01\.csv: window: .* a stretch of constant speed")


def test_a_lag_longer_than_the_window_is_refused(base, tmp_path):
    # lag = 0.5 for 0.005: inertia -13 %
    manifest = set_in_trial(copy_of(base, tmp_path), "lag = 0.5")
    run_refused(manifest, tmp_path, r"A_240_01\.csv: lag: 0\.5 s is longer than the trial's")


def test_plausible_slips_are_flagged_naming_the_trial(base, tmp_path):
    # speed = 30 on a 240 deg/s trial; a velocity channel 1.4x too large (inertia -29 %)
    manifest = set_in_trial(copy_of(base, tmp_path), "speed = 30.0")
    edit_csv(
        manifest.parent / "data/A_240_02.csv",
        lambda f: f.__setitem__("velocity", f.velocity * 1.4),
    )
    flags = process_study(manifest).trials.set_index("file")["flags"]
    assert "from its nominal speed 30 deg/s" in flags[FAST]
    assert "% from its nominal speed 240 deg/s" in flags["data/A_240_02.csv"]
    assert "nominal speed" not in flags["data/A_240_03.csv"]


def test_a_quasi_static_torque_signed_opposite_is_flagged(base, tmp_path):
    # +10 to +23 % on the inertia
    manifest = copy_of(base, tmp_path)
    qs = manifest.parent / "data/A_quasistatic.csv"
    edit_csv(qs, lambda f: f.__setitem__("torque", -f.torque))
    flags = process_study(manifest).trials.set_index("file")["flags"]
    assert "runs against the condition's gravity model" in flags[FAST]


def test_a_truncated_traces_table_is_not_redrawn(sampled, tmp_path):
    copy = tmp_path / "out"
    shutil.copytree(sampled, copy)
    lines = (copy / "traces.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    (copy / "traces.csv").write_text("".join(lines[: len(lines) // 2]))
    refused(["report", str(copy)], tmp_path, r"traces\.csv: \d+ bytes where inertiafit wrote")


# == Tracebacks (depth: test_cli_arguments.py, test_io_readers.py, test_io_manifest.py) ==========


@pytest.mark.parametrize("seed", ["-1", "4294967296"])
def test_a_seed_out_of_range_is_one_line(tmp_path, seed):
    for command in (DISK_FIT, ["run", "study.toml"], ["plan", "design.toml"], ["demo"]):
        argv = [*command, f"--seed={seed}", "--out", str(tmp_path / "o")]
        refused(argv, tmp_path, r"--seed: expected a whole number from 0 to 4294967295")


def test_gravity_inf_is_one_line(tmp_path):
    refused([*DISK_FIT, "--gravity=inf", "--out", str(tmp_path / "o")], tmp_path, r"--gravity: ")


@pytest.mark.parametrize(
    "option", ["delimiter = 5", 'delimiter = ""', 'delimiter = ",,"', 'decimal = ""']
)
def test_reader_options_are_one_line(base, tmp_path, option):
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8").replace(
        "[defaults]\n", f"[defaults]\noptions = {{ {option} }}\n"
    )
    manifest.write_text(text)
    run_refused(manifest, tmp_path, r"options\.(delimiter|decimal): expected one character")


def test_biodex_set_empty_list_is_one_line():
    with pytest.raises(InputError, match=r"options\.set: expected a whole number"):
        read_trial(DATA / "biodex_6line.txt", format="biodex", set=[])


@pytest.mark.parametrize(
    "name", ["a/b", "x" * 300, "a\\u0000b"], ids=["slash", "300-characters", "nul"]
)
def test_a_body_name_that_cannot_name_a_file_is_one_line(base, tmp_path, name):
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8").replace(
        "[bodies.attachment]", f'[bodies."{name}"]'
    )
    manifest.write_text(text.replace('bodies = ["attachment"]', f'bodies = ["{name}"]'))
    run_refused(manifest, tmp_path, r"study\.toml: bodies: body .*: expected ")


def test_nul_in_a_trial_path_is_one_line(base, tmp_path):
    manifest = copy_of(base, tmp_path)
    manifest.write_text(manifest.read_text(encoding="utf-8").replace(FAST, "data/A\\u0000240.csv"))
    run_refused(manifest, tmp_path, r"trials\[1\]\.file: a path cannot hold a NUL character")


def test_an_unwritable_out_is_one_line(tmp_path, monkeypatch):
    # what a read-only folder answers, for every user (root is never refused by chmod)
    def refuse(*_args, **_kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(outputs.os, "open", refuse)
    refused([*DISK_FIT, "--out", str(tmp_path / "o")], tmp_path, r"--out: cannot write in ")


def test_a_symlinked_out_is_followed_and_kept(tmp_path):
    target = earlier(tmp_path / "target")
    link = tmp_path / "link"
    link.symlink_to(target)
    check_out(link)
    with output_folder(link) as folder:
        (folder / "summary.csv").write_text("new")
    assert link.is_symlink()
    assert (target / "summary.csv").read_text(encoding="utf-8") == "new"


def test_report_on_text_in_trials_csv_is_one_line(sampled, tmp_path):
    # a number overwritten by text of its length (the marker's size holds)
    copy = tmp_path / "out"
    shutil.copytree(sampled, copy)
    lines = (copy / "trials.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    cells = lines[2].split(",")
    column = lines[0].split(",").index("inertia")
    cells[column] = "x" * len(cells[column])
    lines[2] = ",".join(cells)
    (copy / "trials.csv").write_text("".join(lines))
    pattern = r"trials\.csv: line 3, column 'inertia': 'x+' is not a number"
    refused(["report", str(copy)], tmp_path, pattern)


def test_a_scheduler_that_is_not_an_address_is_one_line(base, tmp_path):
    argv = ["run-many", str(base / "study.toml"), "--scheduler", "not a url"]
    refused([*argv, "--out", str(tmp_path / "b")], tmp_path, r"--scheduler: not a url: cannot")


def test_bad_api_arguments_are_one_line_naming_the_argument():
    for case, (call, match) in _api_cases().items():
        with pytest.raises(InputError, match=match) as info:
            call()
        assert "\n" not in str(info.value), case


# == Misleading messages (depth: test_cli_arguments.py, test_model.py) ===========================


def test_a_path_holding_an_option_name_is_shown_as_it_is(base, tmp_path):
    manifest = copy_of(base, tmp_path, "gravity_moment")
    missing = manifest.parent / "data/A_240_02.csv"
    missing.unlink()
    err = run_refused(manifest, tmp_path, rf"file not found: {missing}")
    assert "--gravity-moment" not in err


def test_a_manifest_key_holding_an_option_name_is_shown_as_it_is(base, tmp_path):
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8").replace(
        "[bodies.attachment]\n", "[bodies.attachment]\ncom_distance = { value = 0.2, sd = -1 }\n"
    )
    manifest.write_text(text)
    err = run_refused(manifest, tmp_path, r"bodies\.attachment\.com_distance\.sd: must be")
    assert "--com-distance" not in err


def test_torque_sign_minus_one_is_not_told_to_set_it(base, tmp_path):
    manifest = set_in_trial(copy_of(base, tmp_path), "torque_sign = -1.0")
    err = run_refused(manifest, tmp_path, r"A_240_01\.csv: torque: inertia -0\.\d+ kg m\^2")
    assert "set torque_sign = -1" not in err


@pytest.mark.parametrize(
    ("columns", "swapped"),
    [
        ('angle = "torque", velocity = "velocity", torque = "angle"', "angle and torque"),
        ('angle = "angle", velocity = "torque", torque = "velocity"', "velocity and torque"),
    ],
)
def test_swapped_columns_are_named_not_sent_to_torque_sign(base, tmp_path, columns, swapped):
    # advised torque_sign = "motion", which then took the trial with its inertia 88 % low
    manifest = copy_of(base, tmp_path)
    set_in_trial(manifest, f'columns = {{ time = "time", {columns} }}\ntorque_sign = "motion"')
    err = run_refused(
        manifest,
        tmp_path,
        rf"A_240_01\.csv: {swapped} columns swapped\? ",
        r'map columns = \{ angle = "angle", velocity = "velocity", torque = "torque" \}',
    )
    assert "torque_sign" not in err


@pytest.mark.parametrize(
    ("slip", "message"),
    [
        (
            "torque of 1e308",
            r"A_quasistatic\.csv: column 'torque' holds 1e\+308 N m at line \d+, beyond",
        ),
        (
            "flat quasi-static torque",
            r"its quasi-static trials give M_g = .* check those trials \(a flat",
        ),
        (
            "2.5-deg sweep",
            # issue 21: the quasi-static trial itself is named, before any fast trial
            r"A_quasistatic\.csv: angle: a quasi-static sweep of 2\.5 deg gives M_g = ",
        ),
        ("grams as kg", r"the weighed mass 2850 kg lies outside .* \(grams entered as kg\?\)"),
    ],
)
def test_data_problems_are_reported_as_data_problems(
    base, tmp_path, reaches_the_sampler, slip, message
):
    manifest = copy_of(base, tmp_path)
    qs = manifest.parent / "data/A_quasistatic.csv"
    if slip == "torque of 1e308":
        edit_csv(qs, lambda f: f.__setitem__("torque", f.torque.where(f.index != 500, 1e308)))
    elif slip == "flat quasi-static torque":
        edit_csv(qs, lambda f: f.__setitem__("torque", 1.5))
    elif slip == "2.5-deg sweep":
        frame = pd.read_csv(qs)
        low = frame.angle.min() + 40
        frame[(frame.angle >= low) & (frame.angle <= low + 2.5)].to_csv(qs, index=False)
    else:
        text = manifest.read_text(encoding="utf-8")
        manifest.write_text(
            text.replace(
                "[bodies.attachment]\n", "[bodies.attachment]\nmass = { value = 2850, sd = 5 }\n"
            )
        )
    err = run_refused(manifest, tmp_path, message)
    assert "prior box contains no solution" not in err


def test_a_manifest_with_a_byte_order_mark_is_read(base, tmp_path, reaches_the_sampler):
    # "Invalid statement (line 1, col 1)"
    manifest = copy_of(base, tmp_path)
    manifest.write_bytes(b"\xef\xbb\xbf" + manifest.read_bytes())
    with pytest.raises(Sampled):
        main(["run", str(manifest), "--out", str(tmp_path / "o")])


def test_a_file_that_is_not_a_trial_is_never_echoed(base, tmp_path):
    manifest = copy_of(base, tmp_path)
    secret = tmp_path / "elsewhere" / "notes.txt"
    secret.parent.mkdir()
    secret.write_text("SECRET root:x:0:0:root:/root\nsecond line\n")
    manifest.write_text(manifest.read_text(encoding="utf-8").replace(FAST, secret.as_posix()))
    err = run_refused(manifest, tmp_path, "is it a trial file")
    assert "SECRET" not in err
