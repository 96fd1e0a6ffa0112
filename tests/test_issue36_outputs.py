"""Issue 36 ("Nothing silent"): output folders and reported numbers, each case one test.

As ``test_issue22_catalogue.py`` (whose helpers these reuse): through the command line where the
issue used it, a refusal is one line on stderr, exit status 2 and nothing changed; each case
has a negative control that shows the check still refuses what it must, or keeps what it must.

- ``export`` into a results folder made the next ``run`` into it refuse ``exp/``: an output
  folder inside another, whole by its own marker, is inertiafit's;
- a run killed by SIGKILL left its staging folder for good: the next run into the same folder
  removes it, naming it, and nothing that only looks like one;
- ``--inertia-se 1e-300`` ended in "no finite posterior density" after a RuntimeWarning: an SE
  below 1e-9 of its value is refused, naming the option;
- a manifest's ``gravity = 1e300`` was blamed on the trials: it is refused at reading, naming
  the manifest, the key and the range.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from cases import DISK_FIT, one_condition_study
from test_cli_arguments import run_cli
from test_issue22_catalogue import (
    Sampled,
    copy_of,
    reaches_the_sampler,  # noqa: F401 (a fixture)
    refused,
    run_refused,
)
from test_outputs_safety import WRITER, _env, earlier

import inertiafit.inference.fit as fitting
from inertiafit.cli import main
from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.io import load_study
from inertiafit.io.outputs import MARKER, check_out, output_folder


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """One condition (:func:`cases.one_condition_study`)."""
    return one_condition_study(tmp_path_factory.mktemp("issue36-outputs") / "study")


#: A few hundred steps of the sampler: enough for ``run`` to write every output.
SHORT = SamplerSettings(chunk=100, max_steps=200, ess_min=1.0)


def shorten(mp: pytest.MonkeyPatch) -> None:
    real = fitting.sample
    mp.setattr(fitting, "sample", lambda model, **kw: real(model, **{**kw, "settings": SHORT}))


@pytest.fixture(scope="module")
def results(base, tmp_path_factory):
    """A results folder of ``run`` holding ``exp/``, written by ``export --out results/exp``."""
    out = tmp_path_factory.mktemp("results") / "results"
    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        shorten(mp)
        warnings.simplefilter("ignore", ConvergenceWarning)  # what the few steps give
        assert run_cli(["run", str(base / "study.toml"), "--out", str(out)])[0] == 0
    argv = ["export", str(out), "--format", "json", "--radii", "attachment=0.1,0.1"]
    code, err = run_cli([*argv, "--out", str(out / "exp")])
    assert code == 0, err
    assert (out / "exp" / "model.json").is_file()
    assert (out / "exp" / MARKER).is_file()
    return out


def results_copy(results: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "results"
    shutil.copytree(results, folder, symlinks=True)
    return folder


# == export into a results folder, then run into it again ======================================


def test_a_run_into_results_holding_their_export_replaces_them(
    base, results, tmp_path, monkeypatch
):
    # "--out: folder results holds exp/, which inertiafit did not write"
    out = results_copy(results, tmp_path)
    shorten(monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        code, err = run_cli(["run", str(base / "study.toml"), "--out", str(out)])
    assert code == 0, err
    assert (out / "summary.csv").is_file()
    assert not (out / "exp").exists()  # inertiafit's, replaced whole with the rest


def test_an_export_holding_a_note_of_the_users_is_still_refused(base, results, tmp_path):
    out = results_copy(results, tmp_path)
    (out / "exp" / "note.txt").write_text("model for subject 3")
    argv = ["run", str(base / "study.toml"), "--out", str(out)]
    refused(
        argv,
        tmp_path,
        rf"--out: folder {re.escape(str(out / 'exp'))} holds note\.txt, which inertiafit did",
    )


def test_an_edited_export_is_still_refused(base, results, tmp_path):
    out = results_copy(results, tmp_path)
    with (out / "exp" / "model.json").open("a") as fh:
        fh.write("\n")
    argv = ["run", str(base / "study.toml"), "--out", str(out)]
    refused(
        argv, tmp_path, rf"--out: {re.escape(str(out / 'exp' / 'model.json'))} has changed since"
    )


def test_a_subfolder_without_a_marker_is_still_refused(base, results, tmp_path):
    out = results_copy(results, tmp_path)
    shutil.copytree(out / "exp", out / "mine")
    (out / "mine" / MARKER).unlink()
    argv = ["run", str(base / "study.toml"), "--out", str(out)]
    refused(
        argv,
        tmp_path,
        rf"--out: folder {re.escape(str(out))} holds mine/, which inertiafit did not write",
    )


def test_what_a_killed_export_left_in_results_is_named_as_such(base, results, tmp_path):
    # an export into results/exp killed outright leaves .exp.new-XXXXXXXX/ in results: it was
    # named "not written by inertiafit"; it is named as what it is, with what to do
    out = results_copy(results, tmp_path)
    (out / ".exp.new-abcd1234").mkdir()
    (out / ".exp.new-abcd1234" / "model.json").write_text("{}")
    argv = ["run", str(base / "study.toml"), "--out", str(out)]
    refused(
        argv,
        tmp_path,
        rf"--out: folder {re.escape(str(out))} holds \.exp\.new-abcd1234/, left by a run into "
        rf"{re.escape(str(out / 'exp'))} that was killed; run that command again",
    )
    # negative control: a hidden folder of the user's is still not inertiafit's
    shutil.rmtree(out / ".exp.new-abcd1234")
    (out / ".mine").mkdir()
    (out / ".mine" / "x.txt").write_text("x")
    refused(argv, tmp_path, r"holds \.mine/, which inertiafit did not write")


# == a run killed by SIGKILL ===================================================================


@pytest.mark.skipif(os.name != "posix", reason="SIGKILL from another process")
def test_the_staging_folder_of_a_killed_run_is_removed_by_the_next_run(tmp_path, capsys):
    out = earlier(tmp_path / "out", {"summary.csv": "old"})
    with subprocess.Popen(
        [sys.executable, "-c", WRITER, str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        encoding="utf-8",
        env=_env(),
    ) as proc:
        assert proc.stdout is not None
        assert proc.stdout.readline() == "writing\n"
        (staging,) = tmp_path.glob(".out.new-*")
        # control: a staging folder of a live run is never touched; its run's lock is held
        with pytest.raises(InputError, match="is being written by another inertiafit run"):
            check_out(out)
        assert (staging / "big.csv").is_file()
        proc.send_signal(signal.SIGKILL)
        assert proc.wait(timeout=20) == -signal.SIGKILL
    assert (staging / "big.csv").is_file()  # what SIGKILL leaves
    # controls: what only looks like a staging folder of out is kept
    kept = [
        tmp_path / ".out.new-mine",  # not a name mkdtemp gives
        tmp_path / ".out.old-0123abcd",  # an old folder moved aside: maybe the only copy
        tmp_path / ".other.new-abcd1234",  # another output's
    ]
    for folder in kept:
        folder.mkdir()
        (folder / "keep.txt").write_text("keep")
    (tmp_path / ".out.draw-abcd1234").write_text("a file, not a folder")
    (tmp_path / ".out.new-zzzz9999").symlink_to(kept[0], target_is_directory=True)
    capsys.readouterr()

    with output_folder(out) as folder:
        (folder / "summary.csv").write_text("new")

    assert (out / "summary.csv").read_text(encoding="utf-8") == "new"
    assert not staging.exists()
    assert not (tmp_path / ".out.lock").exists()
    for folder in kept:
        assert (folder / "keep.txt").read_text(encoding="utf-8") == "keep"
    assert (tmp_path / ".out.draw-abcd1234").read_text(encoding="utf-8") == "a file, not a folder"
    assert (tmp_path / ".out.new-zzzz9999").is_symlink()
    warning = f"removed {staging}, left unfinished by a run into {out} that was killed"
    assert capsys.readouterr().err.splitlines() == [f"inertiafit: warning: {warning}"]


# == standard errors too small for a density ===================================================


def fit_argv(*more: str, without: tuple[str, ...] = ()) -> list[str]:
    """``DISK_FIT`` without the options ``without`` (and their values), then ``more``."""
    argv = list(DISK_FIT)
    for option in without:
        del argv[argv.index(option) : argv.index(option) + 2]
    return [*argv, *more]


@pytest.mark.parametrize(
    ("option", "more", "without", "floor"),
    [
        ("--inertia-se", (), ("--inertia-se",), "5.94e-10"),
        ("--gravity-moment-se", (), ("--gravity-moment-se",), "1.28e-08"),
        ("--inertia-sd", ("--inertia-n", "3"), ("--inertia-se",), "5.94e-10"),
        ("--mass-sd", ("--mass", "2.9"), (), "2.9e-09"),
    ],
)
def test_a_standard_error_too_small_for_a_density_is_one_line(
    tmp_path, option, more, without, floor
):
    argv = fit_argv(option, "1e-300", *more, "--out", str(tmp_path / "o"), without=without)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # the overflow it ended in before
        refused(
            argv,
            tmp_path,
            rf"^inertiafit: error: {option}: expected at least {floor} \(1e-09 of the value ",
            r"got 1e-300: no measurement is that precise",
        )


@pytest.mark.usefixtures("reaches_the_sampler")
def test_a_standard_error_of_1e_9_of_the_value_reaches_the_sampler(tmp_path):
    # control: the least SE accepted, 1e-9 of the value 0.594
    argv = fit_argv("--inertia-se", "5.94e-10", without=("--inertia-se",))
    with pytest.raises(Sampled):
        main([*argv, "--out", str(tmp_path / "o")])


# == the manifest's gravity ====================================================================


@pytest.mark.parametrize("gravity", ["1e300", "98.1", "32.2", "9.18"])
def test_a_gravity_outside_earths_is_refused_at_reading(base, tmp_path, gravity):
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8")
    assert "\ngravity = 9.81\n" in text
    manifest.write_text(text.replace("\ngravity = 9.81\n", f"\ngravity = {gravity}\n"))
    run_refused(
        manifest,
        tmp_path,
        rf"^inertiafit: error: {re.escape(str(manifest))}: gravity: expected Earth's surface "
        rf"gravity, 9\.7 to 9\.9 m/s\^2, got {re.escape(repr(float(gravity)))}$",
    )


def test_a_local_gravity_is_kept(base, tmp_path):
    manifest = copy_of(base, tmp_path)
    text = manifest.read_text(encoding="utf-8").replace(
        "\ngravity = 9.81\n", "\ngravity = 9.7803\n"
    )
    manifest.write_text(text)
    assert load_study(manifest).gravity == 9.7803


def test_fit_gravity_outside_earths_is_one_line(tmp_path):
    argv = [*DISK_FIT, "--gravity", "1e300", "--out", str(tmp_path / "o")]
    refused(argv, tmp_path, r"^inertiafit: error: --gravity: expected Earth's surface gravity")
