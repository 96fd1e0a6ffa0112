"""Outputs never destroy anything but inertiafit's own earlier outputs (issue 22).

First a catalogue: every case of the issue that lost data or ended in a traceback, through the
command line, must end in one line on stderr and exit status 2 with every input and earlier
output byte-identical (the whole test folder is compared before and after, so no staging
folder or lock is left either). Then the rules behind it, on ``inertiafit.io.outputs``: the
marker's list, the swap under injected failures (and a hypothesis test over the failing step),
the lock, SIGTERM, and ``report`` all-or-nothing.
"""

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from cases import DISK_FIT, as_ordinary_user
from hypothesis import given
from hypothesis import strategies as st

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.io import outputs
from inertiafit.io.outputs import MARKER, check_out, guard_outputs, output_folder

FIT = DISK_FIT
FIT_OUTPUTS = {
    "summary.csv": "body,parameter,mean\ndisk-3kg,mass,2.885\n",
    "trials.csv": "file,condition,kind\n",
    "posterior.nc": "not really netCDF: a pilot that is read would fail",
    "corner.png": "png bytes",
}
MANIFEST = """\
name = "copied demo"
[bodies.attachment]
prior = { mass = 2.91, radius_of_gyration = 0.13, com_distance = 0.225 }
[defaults]
columns = { time = "time", angle = "angle", velocity = "velocity", torque = "torque" }
units = { time = "s", angle = "deg", velocity = "deg/s", torque = "N*m" }
[[trials]]
file = "data/A_quasistatic.csv"
bodies = ["attachment"]
kind = "quasi-static"
[[trials]]
file = "data/A_240_01.csv"
bodies = ["attachment"]
kind = "fast"
speed = 240.0
"""
# Trial files that cannot be read: a run that got as far as reading them would fail on them.
DEMO_OUTPUTS = {
    **FIT_OUTPUTS,
    "study/study.toml": MANIFEST,
    "study/data/A_quasistatic.csv": "not a trial\n",
    "study/data/A_240_01.csv": "not a trial\n",
    "paper-numbers/attachment/summary.csv": "body,parameter\n",
    "information/information.csv": "case,width\n",
}


def snapshot(root: Path) -> dict[str, object]:
    """Every entry under ``root`` (hidden ones too): a file's bytes, a link's target, a folder."""
    seen: dict[str, object] = {}
    for dirpath, dirs, files in os.walk(root):
        for name in dirs + files:
            p = Path(dirpath) / name
            key = str(p.relative_to(root))
            if p.is_symlink():
                seen[key] = ("link", os.readlink(p))
            elif p.is_dir():
                seen[key] = "folder"
            else:
                seen[key] = p.read_bytes()
    return seen


def earlier(folder: Path, files: dict[str, str] = FIT_OUTPUTS) -> Path:
    """An earlier output folder, written as inertiafit writes one (its marker lists the files)."""
    with output_folder(folder) as tmp:
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)
    return folder


# -- the catalogue ---------------------------------------------------------------------------
# Each case: (setup(tmp) -> (argv, cwd), a fragment of the expected one-line error).


def _run_into_the_demo_folder_it_reads(tmp):
    x = earlier(tmp / "X", DEMO_OUTPUTS)  # cp -r demo-output X
    return ["run", str(x / "study" / "study.toml"), "--out", str(x)], None


def _run_into_its_manifests_folder(tmp):
    x = earlier(tmp / "X", DEMO_OUTPUTS)
    return ["run", str(x / "study" / "study.toml"), "--out", str(x / "study")], None


def _run_many_into_the_demo_folder_it_reads(tmp):
    x = earlier(tmp / "X", DEMO_OUTPUTS)
    return ["run-many", str(x / "study" / "study.toml"), "--out", str(x), "--workers", "1"], None


def _plan_from_a_pilot_into_the_pilot(tmp):
    r = earlier(tmp / "R")
    return ["plan", "--pilot", str(r), "--out", str(r)], None


def _plan_into_the_folder_of_its_design(tmp):
    d = tmp / "designs"
    d.mkdir()
    (d / "design.toml").write_text("not even TOML: the design is never read\n")
    return ["plan", str(d / "design.toml"), "--out", str(d)], None


def _fit_out_dot_inside_an_earlier_output(tmp):
    r = earlier(tmp / "R")
    return [*FIT, "--out", "."], r


def _fit_out_an_ancestor_of_the_current_folder(tmp):
    r = earlier(tmp / "R", DEMO_OUTPUTS)
    return [*FIT, "--out", str(r)], r / "paper-numbers" / "attachment"


def _demo_out_dot(tmp):
    r = earlier(tmp / "R")
    return ["demo", "--out", "."], r


def _report_on_the_current_folder(tmp):
    r = earlier(tmp / "R")
    return ["report", "."], r


def _a_note_of_the_users_in_an_earlier_output(tmp):
    r = earlier(tmp / "R")
    (r / "note.txt").write_text("subject 3 moved during trial 7")
    return [*FIT, "--out", str(r)], None


def _a_study_subfolder_the_user_put_in_an_earlier_output(tmp):
    r = earlier(tmp / "R")
    (r / "study").mkdir()
    (r / "study" / "study.toml").write_text(MANIFEST)
    return [*FIT, "--out", str(r)], None


def _a_file_the_user_put_in_a_subfolder_of_an_earlier_output(tmp):
    r = earlier(tmp / "R", DEMO_OUTPUTS)
    (r / "study" / "data" / "A_270_01.csv").write_text("time,angle\n")
    return [*FIT, "--out", str(r)], None


def _an_output_the_user_edited(tmp):
    r = earlier(tmp / "R")
    with (r / "summary.csv").open("a") as fh:
        fh.write("my own row\n")
    return [*FIT, "--out", str(r)], None


def _an_output_folder_of_an_older_inertiafit(tmp):
    r = tmp / "R"
    r.mkdir()
    (r / MARKER).write_text("written by inertiafit; the whole folder is replaced on rerun\n")
    (r / "summary.csv").write_text("body\n")
    return [*FIT, "--out", str(r)], None


def _out_is_a_file(tmp):
    (tmp / "results.csv").write_text("a,b\n")
    return [*FIT, "--out", str(tmp / "results.csv")], None


def _out_inside_a_file(tmp):
    (tmp / "results.csv").write_text("a,b\n")
    return [*FIT, "--out", str(tmp / "results.csv" / "out")], None


def _out_a_symlink_loop(tmp):
    (tmp / "a").symlink_to(tmp / "b")
    (tmp / "b").symlink_to(tmp / "a")
    return [*FIT, "--out", str(tmp / "a")], None


def _out_with_a_nul(tmp):
    return [*FIT, "--out", str(tmp / "o\0ut")], None


def _out_named_300_characters(tmp):
    return [*FIT, "--out", str(tmp / ("o" * 300))], None


def _another_run_is_writing_the_folder(tmp):
    r = earlier(tmp / "R")
    # a lock held by a live process of this host (this one)
    (tmp / ".R.lock").write_text(f"{os.getpid()} {socket.gethostname()} 0\n")
    return [*FIT, "--out", str(r)], None


CATALOGUE = [
    (_run_into_the_demo_folder_it_reads, "--out: {tmp}/X holds the input"),
    (_run_into_its_manifests_folder, "--out: {tmp}/X/study holds the input"),
    (_run_many_into_the_demo_folder_it_reads, "--out: {tmp}/X holds the input"),
    (_plan_from_a_pilot_into_the_pilot, "--out: {tmp}/R is the input {tmp}/R of this run"),
    (_plan_into_the_folder_of_its_design, "--out: {tmp}/designs holds the input"),
    (_fit_out_dot_inside_an_earlier_output, "--out: . is the current folder or holds it"),
    (_fit_out_an_ancestor_of_the_current_folder, "is the current folder or holds it"),
    (_demo_out_dot, "--out: . is the current folder or holds it"),
    (_report_on_the_current_folder, "error: . is the current folder or holds it"),
    (_a_note_of_the_users_in_an_earlier_output, "holds note.txt, which inertiafit did not write"),
    (
        _a_study_subfolder_the_user_put_in_an_earlier_output,
        "holds study/, which inertiafit did not write",
    ),
    (
        _a_file_the_user_put_in_a_subfolder_of_an_earlier_output,
        "holds study/data/A_270_01.csv, which inertiafit did not write",
    ),
    (_an_output_the_user_edited, "summary.csv has changed since inertiafit wrote it"),
    (_an_output_folder_of_an_older_inertiafit, "older inertiafit that did not list its files"),
    (_out_is_a_file, "results.csv exists and is not a folder"),
    (_out_inside_a_file, "results.csv is a file, not a folder"),
    (_out_a_symlink_loop, "is a symlink that leads nowhere"),
    (_out_with_a_nul, "--out: the path holds a NUL character"),
    (_out_named_300_characters, "--out: folder name too long (300 bytes"),
    (_another_run_is_writing_the_folder, "is being written by another inertiafit run (process"),
]


@pytest.mark.parametrize(
    ("setup", "expected"), CATALOGUE, ids=lambda c: getattr(c, "__name__", "")
)
def test_catalogue_one_line_exit_2_nothing_touched(setup, expected, tmp_path, monkeypatch, capsys):
    argv, cwd = setup(tmp_path)
    if cwd is not None:
        monkeypatch.chdir(cwd)
    before = snapshot(tmp_path)
    capsys.readouterr()
    code = main(argv)
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert code == 2, cap.err
    assert len(lines) == 1, cap.err
    assert lines[0].startswith("inertiafit: error: ")
    assert expected.format(tmp=tmp_path) in lines[0]
    assert cap.out == ""
    assert snapshot(tmp_path) == before


# Real permissions: root ignores them, so where the tests run as root (CI containers) these run
# as `nobody` (cases.as_ordinary_user). The same refusals are also injected, in this process, by
# test_a_parent_that_cannot_be_written_is_one_line and
# test_an_entry_that_cannot_be_removed_is_left_aside_with_a_warning.
@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_unwritable_parent_is_one_line():
    done = as_ordinary_user(
        f"""
import os
from pathlib import Path
from inertiafit.cli import main
ro = Path("ro").resolve()
ro.mkdir()
ro.chmod(0o555)
code = main({[*FIT, "--out", "ro/out"]!r})
print(code, sorted(os.listdir(ro)))
ro.chmod(0o755)
""",
        imports=("inertiafit.pipeline.fit",),
    )
    assert done.stdout == "2 []\n", done.stderr
    err = done.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("inertiafit: error: --out: cannot write in "), err
    assert err.endswith("/ro (Permission denied); choose a folder you can write to"), err


def test_a_parent_that_cannot_be_written_is_one_line(tmp_path, monkeypatch, capsys):
    # what a read-only folder or file system answers (root is never refused by chmod)
    def refuse(*_args, **_kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(outputs.os, "open", refuse)
    assert main([*FIT, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"inertiafit: error: --out: cannot write in {tmp_path} (Permission denied); "
        "choose a folder you can write to"
    )
    assert list(tmp_path.iterdir()) == []


def test_out_is_checked_before_any_work(tmp_path, capsys):
    # the prior file is missing: had anything run before the check, that would be the error
    out = tmp_path / "out"
    out.mkdir()
    (out / "note.txt").write_text("mine")
    argv = ["fit", "--prior", str(tmp_path / "missing.toml"), *FIT[3:], "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"inertiafit: error: --out: folder {out} exists, is not empty and was")
    # and a prior file inside --out is an input it may not hold
    argv = ["fit", "--prior", str(out / "my-prior.toml"), *FIT[3:], "--out", str(out)]
    assert main(argv) == 2
    assert f"--out: {out} holds the input {out / 'my-prior.toml'}" in capsys.readouterr().err


# -- the marker ------------------------------------------------------------------------------


def test_marker_lists_every_file_written_with_its_size(tmp_path):
    out = tmp_path / "out"
    with output_folder(out) as tmp:
        (tmp / "summary.csv").write_text("abc")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "x.csv").write_text("12345")
        (tmp / "empty").mkdir()
    doc = json.loads((out / MARKER).read_text(encoding="utf-8"))
    assert doc["files"] == {"empty/": None, "sub/x.csv": 5, "summary.csv": 3}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging, no lock
    assert oct(out.stat().st_mode & 0o777) != oct(0o700)  # as mkdir makes it, not private


def test_an_earlier_output_is_replaced_whole(tmp_path):
    out = earlier(tmp_path / "out")
    (out / "corner.png").unlink()  # a listed file the user deleted: still ours to replace
    with output_folder(out) as tmp:
        (tmp / "new.csv").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "new.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_folder_holding_only_an_empty_marker_or_nothing_is_replaced(tmp_path):
    (tmp_path / "empty").mkdir()
    with output_folder(tmp_path / "empty") as tmp:
        (tmp / "a").write_text("a")
    assert (tmp_path / "empty" / "a").read_text(encoding="utf-8") == "a"


def test_a_symlinked_out_replaces_its_target_and_keeps_the_link(tmp_path):
    target = earlier(tmp_path / "disk" / "results")
    link = tmp_path / "results"
    link.symlink_to(target)
    with output_folder(link) as tmp:
        (tmp / "new.csv").write_text("new")
    assert link.is_symlink()
    assert os.readlink(link) == str(target)
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "new.csv"]
    assert sorted(p.name for p in (tmp_path / "disk").iterdir()) == ["results"]


def test_a_symlink_inside_an_earlier_output_is_not_followed(tmp_path):
    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / "data.csv").write_text("keep")
    out = tmp_path / "out"
    with output_folder(out) as tmp:
        (tmp / "link").symlink_to(precious)
    assert json.loads((out / MARKER).read_text(encoding="utf-8"))["files"] == {
        "link": (out / "link").lstat().st_size
    }
    with output_folder(out) as tmp:
        (tmp / "a").write_text("a")
    assert (precious / "data.csv").read_text(encoding="utf-8") == "keep"


# -- the swap under injected failures --------------------------------------------------------

OLD = {"summary.csv": "old", "sub/x.csv": "old x"}
NEW = {"summary.csv": "new!", "report.html": "<html>"}


def _contents(folder: Path) -> dict[str, str] | None:
    if not folder.is_dir():
        return None
    return {
        p.relative_to(folder).as_posix(): p.read_text(encoding="utf-8")
        for p in folder.rglob("*")
        if p.is_file() and p.name != MARKER
    }


class _Failures:
    """``os.rename`` and ``shutil.rmtree`` of outputs failing at chosen calls."""

    def __init__(self, monkeypatch, renames=(), rmtree_aside=False):
        self.renames, self.count, self.rmtree_aside = set(renames), 0, rmtree_aside
        real_rename, real_rmtree = os.rename, shutil.rmtree

        def rename(src, dst, *a, **k):
            self.count += 1
            if self.count in self.renames:
                raise PermissionError(13, "Permission denied", str(src))
            return real_rename(src, dst, *a, **k)

        def rmtree(path, *a, **k):
            if self.rmtree_aside and ".old-" in str(path):
                raise PermissionError(13, "Permission denied", str(path))
            return real_rmtree(path, *a, **k)

        monkeypatch.setattr(outputs.os, "rename", rename)
        monkeypatch.setattr(outputs.shutil, "rmtree", rmtree)


def _write(out: Path, files: dict[str, str]) -> None:
    with output_folder(out) as tmp:
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)


def _swap_outcome(parent: Path, renames: set[int], rmtree_aside: bool, monkeypatch, capsys):
    out = parent / "out"
    _write(out, OLD)
    capsys.readouterr()
    with monkeypatch.context() as m:
        _Failures(m, renames, rmtree_aside)
        try:
            _write(out, NEW)
            error = None
        except InputError as exc:
            error = str(exc)
    return out, error, capsys.readouterr().err


@pytest.mark.parametrize(
    ("renames", "rmtree_aside", "expected"),
    [
        ((), False, NEW),
        ({1}, False, OLD),  # old folder cannot be moved aside
        ({2}, False, OLD),  # new folder cannot be moved in: the old one is moved back
        ((), True, NEW),  # the old folder cannot be removed: left aside, with a warning
    ],
)
def test_a_failure_at_any_step_leaves_one_whole_folder(
    tmp_path, monkeypatch, capsys, renames, rmtree_aside, expected
):
    out, error, err = _swap_outcome(tmp_path, set(renames), rmtree_aside, monkeypatch, capsys)
    assert _contents(out) == expected
    staged = [p.name for p in tmp_path.iterdir() if p.name != "out"]
    if rmtree_aside:
        assert error is None
        assert len(staged) == 1
        assert staged[0].startswith(".out.old-")
        assert _contents(tmp_path / staged[0]) == OLD
        lines = err.strip().splitlines()
        assert len(lines) == 1
        assert lines[0].startswith(f"inertiafit: warning: the new outputs are in {out}")
        assert str(tmp_path / staged[0]) in lines[0]
    else:
        assert staged == []  # no staging folder, no aside folder, no lock
        assert (error is None) == (expected is NEW)
        assert err == ""
    if error is not None:
        assert "is unchanged and the new outputs were discarded" in error


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_a_read_only_subfolder_of_the_old_outputs_is_left_aside_with_a_warning():
    done = as_ordinary_user(
        f"""
import json
from pathlib import Path
from inertiafit.io.outputs import output_folder

def write(out, files):
    with output_folder(out) as tmp:
        for name, text in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)

def contents(folder):
    return {{p.relative_to(folder).as_posix(): p.read_text(encoding="utf-8") for p in folder.rglob("*")
            if p.is_file() and p.name != {MARKER!r}}}

out = Path("out").resolve()
write(out, {OLD!r})
(out / "sub").chmod(0o555)
write(out, {NEW!r})
aside = [p for p in out.parent.iterdir() if p.name.startswith(".out.old-")]
print(json.dumps({{"aside": [str(p) for p in aside], "kept": [(p / "sub" / "x.csv").exists()
                  for p in aside], "out": contents(out)}}))
for p in aside:
    (p / "sub").chmod(0o755)
"""
    )
    got = json.loads(done.stdout)
    assert len(got["aside"]) == 1, done.stderr
    assert got["kept"] == [True]
    assert got["out"] == NEW
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert f"moved aside to {got['aside'][0]} could not all be removed" in lines[0]


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc to name a dir_fd")
def test_an_entry_that_cannot_be_removed_is_left_aside_with_a_warning(
    tmp_path, monkeypatch, capsys
):
    # the read-only subfolder above for every user, root included: the kernel refuses to
    # unlink the entries of sub/ (as it does in a read-only folder, or for an open file on
    # Windows), and the real shutil.rmtree meets that refusal part-way through the old folder
    out = tmp_path / "out"
    _write(out, OLD)
    capsys.readouterr()
    real_unlink = os.unlink

    def unlink(path, *args, dir_fd=None, **kwargs):
        folder = Path(os.readlink(f"/proc/self/fd/{dir_fd}")) if dir_fd else Path(path).parent
        if folder.name == "sub" and folder.parent.name.startswith(".out.old-"):
            raise PermissionError(13, "Permission denied", str(path))
        return real_unlink(path, *args, dir_fd=dir_fd, **kwargs)

    monkeypatch.setattr(os, "unlink", unlink)
    _write(out, NEW)
    monkeypatch.undo()
    assert _contents(out) == NEW
    aside = [p for p in tmp_path.iterdir() if p.name.startswith(".out.old-")]
    assert len(aside) == 1
    assert _contents(aside[0]) == {"sub/x.csv": "old x"}  # what could be removed was
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0] == (
        f"inertiafit: warning: the new outputs are in {out}, but the old ones moved aside to "
        f"{aside[0]} could not all be removed (Permission denied); delete that folder yourself"
    )


def test_new_folder_and_its_way_back_both_failing_names_where_the_old_one_is(
    tmp_path, monkeypatch, capsys
):
    out, error, _ = _swap_outcome(tmp_path, {2, 3}, False, monkeypatch, capsys)
    aside = [p for p in tmp_path.iterdir() if p.name.startswith(".out.old-")]
    assert len(aside) == 1
    assert error is not None
    assert error.endswith(f"the old outputs are whole in {aside[0]}")
    assert _contents(aside[0]) == OLD
    assert _contents(out) is None


@given(
    failing=st.sets(st.integers(1, 3), max_size=1),
    rmtree_aside=st.booleans(),
    existed=st.booleans(),
    raise_in_writer=st.booleans(),
)
def test_any_single_failure_leaves_old_or_new_whole(
    failing, rmtree_aside, existed, raise_in_writer
):
    with tempfile.TemporaryDirectory() as tmp, pytest.MonkeyPatch.context() as mp:
        parent = Path(tmp)
        out = parent / "out"
        if existed:
            _write(out, OLD)
        _Failures(mp, failing, rmtree_aside)
        try:
            with output_folder(out) as staging:
                for name, text in NEW.items():
                    (staging / name).write_text(text)
                if raise_in_writer:
                    raise RuntimeError("a figure failed")
        except (InputError, RuntimeError):
            pass
        old = OLD if existed else None
        assert _contents(out) in (old, NEW)
        if raise_in_writer:
            assert _contents(out) == old
        leftovers = {p.name.split("-")[0] for p in parent.iterdir() if p.name != "out"}
        assert leftovers <= {".out.old"}  # never a staging folder or a lock
        if leftovers:
            assert rmtree_aside
            assert _contents(out) == NEW


# -- the lock --------------------------------------------------------------------------------


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_stale_lock_is_taken_over_and_every_claim_released(tmp_path):
    lock = tmp_path / ".out.lock"
    lock.write_text(f"{_dead_pid()} {socket.gethostname()} 0\n")
    _write(tmp_path / "out", NEW)
    assert _contents(tmp_path / "out") == NEW
    assert not lock.exists()


def test_a_lock_of_another_host_or_just_created_is_held(tmp_path):
    lock = tmp_path / ".out.lock"
    lock.write_text(f"{_dead_pid()} some-other-host 0\n")
    with pytest.raises(InputError, match=r"process \d+ on some-other-host"):
        check_out(tmp_path / "out")
    lock.write_text("")  # created, its pid not written yet
    with pytest.raises(InputError, match="another inertiafit run"):
        check_out(tmp_path / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.lock"]


def test_a_command_that_fails_after_its_check_releases_the_claim(tmp_path):
    @guard_outputs
    def command(out):
        check_out(out)
        assert (tmp_path / "new" / ".out.lock").is_file()
        raise InputError("trial 3: no acceleration window")

    with pytest.raises(InputError, match="trial 3"):
        command(tmp_path / "new" / "out")
    assert list(tmp_path.iterdir()) == []  # the lock and the parent made for it are gone
    _write(tmp_path / "new" / "out", NEW)  # and the folder can be written at once
    assert _contents(tmp_path / "new" / "out") == NEW


def test_one_process_cannot_write_one_folder_twice_at_once(tmp_path):
    out = tmp_path / "out"
    with (
        output_folder(out),
        pytest.raises(InputError, match="by this process already"),
        output_folder(out),
    ):
        pass
    # the outer one went on: its folder written, no staging folder or lock left
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# -- SIGTERM ---------------------------------------------------------------------------------

WRITER = """
import sys, time
from pathlib import Path
from inertiafit.io.outputs import output_folder

with output_folder(sys.argv[1]) as tmp:
    (Path(tmp) / "big.csv").write_text("x" * 1_000_000)
    print("writing", flush=True)
    time.sleep(60)
"""


def _env():
    src = str(Path(outputs.__file__).resolve().parents[2])
    return {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM from another process")
def test_sigterm_mid_write_removes_the_staging_folder_and_the_lock(tmp_path):
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
        assert proc.stdout.readline() == "writing\n"
        assert any(p.name.startswith(".out.new-") for p in tmp_path.iterdir())
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 128 + signal.SIGTERM
        assert proc.stderr.read() == ""
    assert snapshot(tmp_path) == before  # the earlier outputs whole, nothing else


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM from another process")
def test_sigterm_during_a_command_releases_its_lock(tmp_path):
    out = tmp_path / "out"
    lock = tmp_path / ".out.lock"
    with subprocess.Popen(
        [sys.executable, "-m", "inertiafit.cli", *FIT, "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        encoding="utf-8",
        env=_env(),
    ) as proc:
        deadline = time.monotonic() + 30
        while not lock.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert lock.exists()  # claimed: the command is at work (importing, sampling)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 128 + signal.SIGTERM
        assert proc.stderr.read() == ""
    assert list(tmp_path.iterdir()) == []


# -- a stop is never lost, nor reported as an error (inertiafit.io.stops) --------------------


class _TermsWhenCollected:
    """An object whose finaliser receives SIGTERM: Python swallows what the handler raises."""

    def __del__(self):
        signal.raise_signal(signal.SIGTERM)
        sum(range(100))  # the handler runs at a bytecode boundary in here


class _FailsWhenCollected:
    def __del__(self):
        raise RuntimeError("a real bug in a finaliser")


@pytest.fixture
def unraisable(monkeypatch):
    """What reaches ``sys.unraisablehook`` (Python's "Exception ignored in" notices)."""
    seen: list[BaseException] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(u.exc_value))
    return seen


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM")
def test_a_sigterm_swallowed_by_a_finaliser_still_ends_the_command(tmp_path, capfd, unraisable):
    out = tmp_path / "out"
    went_on = []

    @guard_outputs
    def command():
        check_out(out)
        with output_folder(out) as tmp:
            (tmp / "summary.csv").write_text("half")
            _TermsWhenCollected()  # collected at once: the SystemExit is swallowed
            went_on.append(True)
            (tmp / "report.html").write_text("half")

    with pytest.raises(SystemExit) as stop:
        command()
    assert stop.value.code == 128 + signal.SIGTERM
    assert went_on == [True]  # the exception was swallowed: the command went on ...
    assert list(tmp_path.iterdir()) == []  # ... but nothing was swapped in, nor left
    assert unraisable == []  # Python's "Exception ignored" notice not printed
    assert capfd.readouterr().err == ""
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    # the next command starts afresh: the stop was forgotten when the guard ended
    _write(out, NEW)
    assert _contents(out) == NEW


def test_other_errors_in_finalisers_are_still_reported(unraisable):
    # the negative control of the quiet hook: it silences the stop, not what else goes wrong
    @guard_outputs
    def command():
        _FailsWhenCollected()
        return 0

    assert command() == 0
    assert [str(e) for e in unraisable] == ["a real bug in a finaliser"]


def _sampler(stop_at: int, signum: int):
    import emcee

    calls = [0]

    def log_prob(x):
        calls[0] += 1
        if calls[0] == stop_at:
            signal.raise_signal(signum)
        return -0.5 * np.sum(x**2, axis=1)

    sampler = emcee.EnsembleSampler(8, 2, log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(1).get_state()
    start = np.random.default_rng(1).standard_normal((8, 2))
    return sampler, start


@pytest.mark.skipif(os.name != "posix", reason="SIGTERM")
@pytest.mark.parametrize(
    ("signum", "ends"),
    [(signal.SIGTERM, SystemExit), (signal.SIGINT, KeyboardInterrupt)],
)
def test_a_stop_while_sampling_ends_after_the_step_without_a_traceback(signum, ends, capfd):
    from inertiafit.inference.moves import run_steps
    from inertiafit.io.stops import sigterm_ends

    # emcee calls log_prob once for the start, then twice a step: call 6 is in step 3
    sampler, start = _sampler(stop_at=6, signum=signum)
    with pytest.raises(ends), sigterm_ends():
        run_steps(sampler, start, 100)
    assert sampler.iteration == 3  # the step under way was finished, and no other begun
    assert capfd.readouterr() == ("", "")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
    # negative control: emcee's own loop reports the stop as a failing likelihood
    sampler, start = _sampler(stop_at=6, signum=signum)
    with pytest.raises(ends), sigterm_ends():
        sampler.run_mcmc(start, 100)
    assert "emcee: Exception while calling your likelihood function" in capfd.readouterr().out


def test_without_a_guard_sampling_leaves_sigterm_alone():
    from inertiafit.inference.moves import run_steps
    from inertiafit.io.stops import stop_point

    sampler, start = _sampler(stop_at=-1, signum=signal.SIGTERM)
    before = signal.getsignal(signal.SIGTERM)
    run_steps(sampler, start, 5)
    stop_point()  # nothing recorded: nothing happens
    assert sampler.iteration == 5
    assert signal.getsignal(signal.SIGTERM) is before


# -- report: all or nothing ------------------------------------------------------------------


@pytest.fixture
def fake_redraw(monkeypatch):
    """``report`` with its reading and drawing replaced by a writer of two tables at 90 %."""
    from inertiafit.pipeline import redraw

    def write(tmp, _result, **_kw):
        (tmp / "summary.csv").write_text("hdi_prob\n0.9\n")
        (tmp / "comparison.csv").write_text("hdi_prob\n0.9\n")
        return ["summary.csv", "comparison.csv", "report.html"]

    monkeypatch.setattr(redraw, "load_result", lambda *_a, **_k: None)
    monkeypatch.setattr(redraw, "write_outputs", write)
    return redraw


def test_report_failing_half_way_leaves_the_old_complete_set(
    tmp_path, fake_redraw, monkeypatch, capsys
):
    r = earlier(tmp_path / "R", {**FIT_OUTPUTS, "comparison.csv": "hdi_prob\n0.95\n"})
    before = snapshot(tmp_path)
    real = os.replace
    calls = []

    def replace(src, dst):  # the second redrawn file cannot be put in place
        calls.append(dst)
        if len(calls) == 2:
            raise PermissionError(13, "Permission denied", str(src))
        return real(src, dst)

    monkeypatch.setattr(outputs.os, "replace", replace)
    assert main(["report", str(r), "--hdi-prob", "0.9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].endswith("(Permission denied); nothing changed")
    assert snapshot(tmp_path) == before


def test_report_failing_at_the_swap_leaves_the_old_complete_set(
    tmp_path, fake_redraw, monkeypatch, capsys
):
    r = earlier(tmp_path / "R", {**FIT_OUTPUTS, "comparison.csv": "hdi_prob\n0.95\n"})
    before = snapshot(tmp_path)
    _Failures(monkeypatch, renames={2})
    assert main(["report", str(r), "--hdi-prob", "0.9"]) == 2
    assert "is unchanged and the new outputs were discarded" in capsys.readouterr().err
    assert snapshot(tmp_path) == before


def test_report_replaces_the_set_whole_and_keeps_what_is_not_its_own(
    tmp_path, fake_redraw, capsys
):
    r = earlier(tmp_path / "R", {**FIT_OUTPUTS, "comparison.csv": "hdi_prob\n0.95\n"})
    (r / "note.txt").write_text("mine")
    assert main(["report", str(r), "--hdi-prob", "0.9"]) == 0
    assert (r / "summary.csv").read_text(encoding="utf-8") == (r / "comparison.csv").read_text(
        encoding="utf-8"
    )
    assert (r / "note.txt").read_text(encoding="utf-8") == "mine"
    listed = json.loads((r / MARKER).read_text(encoding="utf-8"))["files"]
    assert listed["summary.csv"] == len("hdi_prob\n0.9\n")
    assert "note.txt" not in listed  # still the user's: a later run into R is refused
    assert sorted(p.name for p in tmp_path.iterdir()) == ["R"]
    capsys.readouterr()
    assert main([*FIT, "--out", str(r)]) == 2
    assert "holds note.txt" in capsys.readouterr().err


def test_report_does_not_overwrite_a_file_of_yours_of_the_same_name(tmp_path, fake_redraw, capsys):
    r = earlier(tmp_path / "R", {**FIT_OUTPUTS, "comparison.csv": "hdi_prob\n0.95\n"})
    (r / "summary.csv").write_text("my own summary, edited")
    before = snapshot(tmp_path)
    assert main(["report", str(r), "--hdi-prob", "0.9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0] == (
        f"inertiafit: error: {r}: summary.csv was not written by inertiafit, or has changed "
        "since, and would be overwritten; move it out of the folder"
    )
    assert snapshot(tmp_path) == before


NON_ASCII_OUT = """
import sys
from inertiafit.errors import InputError
from inertiafit.io.outputs import check_out
try:
    check_out(sys.argv[1] + "/r\\u00e9sultats")
    print("accepted")
except InputError as exc:
    print(exc)
"""


def test_an_out_the_file_system_cannot_name_is_one_line_from_python(tmp_path):
    """From Python (the command line's argv is already surrogate-escaped), in CI's locale
    (``LC_ALL=C``, UTF-8 mode off: an ASCII file-system encoding) a non-ASCII ``out`` raised
    UnicodeEncodeError where it is resolved. Negative control: a UTF-8 child accepts it."""
    from conftest import in_ascii_and_utf8_locales

    said = in_ascii_and_utf8_locales(NON_ASCII_OUT, str(tmp_path))
    assert said["C"] == (
        f"out: '{tmp_path}/résultats': this machine's file names cannot hold 'é' (file-system "
        "encoding ascii); choose another name or run in a UTF-8 locale"
    )
    assert said["C.UTF-8"] == "accepted"
