"""``[[trials]] files = "<glob>"``: one entry, a trial per matched file (issue 34, item 5).

Each matched file is a trial with the entry's other keys, exactly as if it had its own entry
with ``file = ...``; the matches are sorted; a pattern that matches nothing, and an entry with
both ``file`` and ``files``, are one line naming the manifest, the entry and the pattern.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import hashlib
import string
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_io_formats import vicon_style_c3d
from test_io_manifest import BODIES, trial_csv

from inertiafit.errors import InputError
from inertiafit.io import load_study
from inertiafit.io.sections.trials import match_files
from inertiafit.processing.study import process_study
from inertiafit.simulate import simulate_study

HEAD = (
    BODIES
    + """\
[defaults]
columns = { time = "t", torque = "moment" }
units = { time = "ms", torque = "N*m" }
"""
)
QS = """\
[[trials]]
file = "data/A_qs.csv"
bodies = ["attachment"]
kind = "quasi-static"
"""


def _files(folder: Path, *names: str) -> None:
    for name in names:
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(trial_csv())


def _manifest(folder: Path, trials: str, name: str = "study.toml") -> Path:
    path = folder / name
    path.write_text(HEAD + trials, encoding="utf-8")
    return path


def _error(manifest: Path) -> str:
    with pytest.raises(InputError) as info:
        load_study(manifest)
    message = str(info.value)
    assert "\n" not in message, message
    return message


def _entries(names: list[str], keys: str) -> str:
    return "".join(f'[[trials]]\nfile = "{n}"\n{keys}' for n in names)


def _as_given(spec):
    """A TrialSpec without what says how the manifest listed it."""
    return dataclasses.replace(spec, entry=0, pattern="")


def test_a_pattern_is_a_trial_per_file_in_sorted_order(tmp_path):
    # written out of order, with neighbours the pattern must not take
    _files(tmp_path, "data/A_qs.csv", "data/B_qs.csv", "data/B_270_01.csv")
    _files(tmp_path, *(f"data/B_240_{k:02d}.csv" for k in (3, 10, 1, 2)))
    study = load_study(
        _manifest(
            tmp_path,
            QS + '[[trials]]\nfiles = "data/B_240_*.csv"\nbodies = ["attachment", "weight"]\n'
            'kind = "fast"\nspeed = 240\n'
            '[[trials]]\nfile = "data/B_qs.csv"\nbodies = ["attachment", "weight"]\n'
            'kind = "quasi-static"\n',
        )
    )
    names = [t.file.name for t in study.trials]
    assert names == [
        "A_qs.csv",
        "B_240_01.csv",
        "B_240_02.csv",
        "B_240_03.csv",
        "B_240_10.csv",
        "B_qs.csv",
    ]
    assert [t.index for t in study.trials] == list(range(6))  # unique keys, in order
    assert [t.entry for t in study.trials] == [0, 1, 1, 1, 1, 2]
    assert [t.key for t in study.trials] == ["trials[0].file"] + ["trials[1].files"] * 4 + [
        "trials[2].file"
    ]
    assert {t.pattern for t in study.trials[1:5]} == {"data/B_240_*.csv"}
    assert all(t.file.is_absolute() and t.file.parent == (tmp_path / "data").resolve()
               for t in study.trials)  # fmt: skip


def test_the_entry_s_keys_are_every_matched_file_s(tmp_path):
    # the same trials as one entry per file, key for key (defaults merged the same way)
    names = [f"data/B_240_{k:02d}.csv" for k in (1, 2, 3)]
    _files(tmp_path, "data/A_qs.csv", "data/B_qs.csv", *names)
    keys = (
        'bodies = ["weight", "attachment"]\nkind = "fast"\nspeed = 240\nwindow = [0.05, 0.15]\n'
        'torque_sign = -1\nlag = 0.002\nunits = { torque = "ft*lbf" }\n'
        'columns = { angle = "theta" }\noptions = { delimiter = "," }\n'
    )
    qs_b = '[[trials]]\nfile = "data/B_qs.csv"\nbodies = ["attachment", "weight"]\nkind = "quasi-static"\n'
    globbed = load_study(
        _manifest(
            tmp_path, QS + qs_b + f'[[trials]]\nfiles = "data/B_240_*.csv"\n{keys}', "g.toml"
        )
    )
    listed = load_study(_manifest(tmp_path, QS + qs_b + _entries(names, keys), "l.toml"))
    assert len(globbed.trials) == len(listed.trials) == 5
    for g, s in zip(globbed.trials[2:], listed.trials[2:], strict=True):
        assert g.entry == 2
        assert s.entry == g.index
        assert dataclasses.replace(_as_given(g), index=0) == dataclasses.replace(
            _as_given(s), index=0
        )
    fast = globbed.trials[2]
    assert (fast.kind, fast.speed, fast.window, fast.torque_sign, fast.lag) == (
        "fast", 240.0, (0.05, 0.15), -1, 0.002
    )  # fmt: skip
    assert fast.units == {"time": "ms", "torque": "ft*lbf"}  # merged with [defaults]
    assert fast.columns == {"time": "t", "torque": "moment", "angle": "theta"}
    assert fast.condition == "attachment+weight"
    assert globbed.conditions == listed.conditions


def test_a_pattern_that_matches_nothing_is_one_line(tmp_path):
    _files(tmp_path, "data/A_qs.csv", "data/B_240_01.csv")
    manifest = _manifest(
        tmp_path,
        QS + '[[trials]]\nfiles = "data/A_240_*.csv"\nbodies = ["attachment"]\nkind = "fast"\n'
        "speed = 240\n",
    )
    assert _error(manifest) == (
        f"{manifest}: trials[1].files: no file matches 'data/A_240_*.csv' "
        f"(relative to {tmp_path.resolve()})"
    )
    # a folder is not a trial file
    (tmp_path / "data" / "A_240_x.csv").mkdir()
    assert _error(manifest).endswith("(1 folders do)")


def test_both_file_and_files_is_one_line(tmp_path):
    _files(tmp_path, "data/A_qs.csv", "data/A_240_01.csv")
    manifest = _manifest(
        tmp_path,
        QS + '[[trials]]\nfile = "data/A_240_01.csv"\nfiles = "data/A_240_*.csv"\n'
        'bodies = ["attachment"]\nkind = "fast"\nspeed = 240\n',
    )
    message = _error(manifest)
    assert message.startswith(
        f"{manifest}: trials[1]: both file = 'data/A_240_01.csv' and files = 'data/A_240_*.csv';"
    )
    assert "expected one" in message


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ('["data/A_*.csv"]', "expected a glob pattern (a string such as"),
        ('""', "expected a glob pattern"),
        ('"data/A_\\u0000*.csv"', "a pattern cannot hold a NUL character"),
    ],
)
def test_a_pattern_that_is_not_one_is_one_line(tmp_path, value, expected):
    _files(tmp_path, "data/A_qs.csv")
    manifest = _manifest(
        tmp_path,
        QS + f'[[trials]]\nfiles = {value}\nbodies = ["attachment"]\nkind = "quasi-static"\n',
    )
    message = _error(manifest)
    assert message.startswith(f"{manifest}: trials[1].files: {expected}"), message


def test_a_file_matched_and_listed_is_listed_twice(tmp_path):
    _files(tmp_path, "data/A_qs.csv", "data/A_240_01.csv", "data/A_240_02.csv")
    fast = 'bodies = ["attachment"]\nkind = "fast"\nspeed = 240\n'
    manifest = _manifest(
        tmp_path,
        QS
        + f'[[trials]]\nfile = "data/A_240_02.csv"\n{fast}[[trials]]\nfiles = "data/A_*_0?.csv"\n{fast}',
    )
    twice = (tmp_path / "data" / "A_240_02.csv").resolve()
    assert _error(manifest) == (
        f"{manifest}: trials[2].files: {twice} is already trials[1]; each recording counts once"
    )
    manifest = _manifest(
        tmp_path,
        QS
        + f'[[trials]]\nfiles = "data/A_240_*.csv"\n{fast}[[trials]]\nfile = "data/A_240_01.csv"\n{fast}',
    )
    once = (tmp_path / "data" / "A_240_01.csv").resolve()
    assert _error(manifest) == (
        f"{manifest}: trials[2].file: {once} is already trials[1] (files = 'data/A_240_*.csv'); "
        "each recording counts once"
    )


def test_a_condition_s_messages_name_the_entry_once(tmp_path):
    _files(tmp_path, "data/A_qs.csv", *(f"data/B_240_{k:02d}.csv" for k in range(1, 6)))
    manifest = _manifest(
        tmp_path,
        QS + '[[trials]]\nfiles = "data/B_*.csv"\nbodies = ["attachment", "weight"]\n'
        'kind = "fast"\nspeed = 240\n',
    )
    assert _error(manifest).startswith(
        f"{manifest}: trials: condition 'attachment+weight' has fast trials (trials[1]) but no "
        "quasi-static trial;"
    )


def test_a_matched_file_that_is_no_trial_fails_as_if_listed(tmp_path):
    # data/A_* takes a note lying beside the trials: it is read, and refused, as it would be
    # if the manifest listed it with file = ...
    _files(tmp_path, "data/A_qs.csv", "data/A_240_01.csv")
    (tmp_path / "data" / "A_notes.txt").write_text("subject arrived late\n", encoding="utf-8")
    fast = 'bodies = ["attachment"]\nkind = "fast"\nspeed = 240\n'
    globbed = load_study(
        _manifest(tmp_path, QS + f'[[trials]]\nfiles = "data/A_[2n]*"\n{fast}', "g.toml")
    )
    listed = load_study(
        _manifest(tmp_path, QS + f'[[trials]]\nfile = "data/A_notes.txt"\n{fast}', "l.toml")
    )
    assert [t.file.name for t in globbed.trials] == ["A_qs.csv", "A_240_01.csv", "A_notes.txt"]
    with pytest.raises(InputError) as from_glob:
        globbed.read(2)
    with pytest.raises(InputError) as from_file:
        listed.read(1)
    assert str(from_glob.value) == str(from_file.value)
    assert str(from_glob.value).startswith(str((tmp_path / "data" / "A_notes.txt").resolve()))
    assert "\n" not in str(from_glob.value)


def test_a_format_recognised_per_file_names_the_file(tmp_path):
    # a C3D file among the CSVs is read as c3d: an option only csv takes is refused for it,
    # naming the entry and the file, as its own entry would be
    _files(tmp_path, "data/A_qs.csv", "data/A_240_01.csv")
    vicon_style_c3d(tmp_path / "data" / "A_240_02.c3d")
    fast = 'bodies = ["attachment"]\nkind = "fast"\nspeed = 240\noptions = { delimiter = "," }\n'
    globbed = _manifest(tmp_path, QS + f'[[trials]]\nfiles = "data/A_240_*"\n{fast}', "g.toml")
    listed = _manifest(tmp_path, QS + f'[[trials]]\nfile = "data/A_240_02.c3d"\n{fast}', "l.toml")
    tail = "options.delimiter: unknown option for format 'c3d' (options: none)"
    assert _error(globbed) == f"{globbed}: trials[1] (data/A_240_02.c3d).{tail}"
    assert _error(listed) == f"{listed}: trials[1].{tail}"


def test_patterns_take_folders_and_leave_hidden_files(tmp_path):
    _files(tmp_path, "data/s1/B_01.csv", "data/s2/B_02.csv", "data/s2/.B_03.csv", "data/B_00.csv")
    found = match_files("data/**/B_*.csv", tmp_path, where="x")
    assert [shown for _, shown in found] == [
        "data/B_00.csv",
        "data/s1/B_01.csv",
        "data/s2/B_02.csv",
    ]
    assert [p for p, _ in match_files(str(tmp_path / "data/s?/*.csv"), Path("/"), where="x")] == [
        (tmp_path / "data/s1/B_01.csv").resolve(),
        (tmp_path / "data/s2/B_02.csv").resolve(),
    ]  # an absolute pattern, whatever the manifest's folder
    assert [s for _, s in match_files("data/s2/.B_*.csv", tmp_path, where="x")] == [
        "data/s2/.B_03.csv"
    ]


NAMES = st.text(alphabet=string.ascii_letters + string.digits + "_-", min_size=1, max_size=8)


@given(
    names=st.lists(NAMES, min_size=1, max_size=8, unique_by=str.lower),
    other=st.lists(NAMES, max_size=4),
    wildcard=st.sampled_from(["*", "?*", "[A-Za-z]*", "*_*", "*1*"]),
)
def test_a_pattern_is_its_matches_listed_in_order(tmp_path_factory, names, other, wildcard):
    """Whatever the names: the trials are the files the pattern matches (a shell's rule, case
    as the file system keeps it), sorted, each as its own file entry would be."""
    folder = tmp_path_factory.mktemp("globs")
    _files(folder, "data/A_qs.csv")
    _files(folder, *(f"data/T{n}.csv" for n in names), *(f"data/T{n}.txt" for n in other))
    keys = 'bodies = ["attachment"]\nkind = "fast"\nspeed = 240\n'
    pattern = f"data/T{wildcard}.csv"
    expected = sorted(
        f"data/T{n}.csv" for n in names if fnmatch.fnmatchcase(f"T{n}.csv", f"T{wildcard}.csv")
    )
    manifest = _manifest(folder, QS + f'[[trials]]\nfiles = "{pattern}"\n{keys}')
    if not expected:
        assert f"trials[1].files: no file matches {pattern!r}" in _error(manifest)
        return
    study = load_study(manifest)
    listed = load_study(_manifest(folder, QS + _entries(expected, keys), "listed.toml"))
    assert [t.file for t in study.trials[1:]] == [(folder / e).resolve() for e in expected]
    assert [t.index for t in study.trials] == list(range(len(expected) + 1))
    for g, s in zip(study.trials, listed.trials, strict=True):
        assert _as_given(g) == _as_given(s)


def test_provenance_has_every_matched_file(tmp_path):
    # processed from a pattern, a study records each file by its own name and hash
    manifest = simulate_study(
        tmp_path,
        bodies={"disk": (2.9, 0.035, 0.45)},
        conditions=[("disk",)],
        speeds=(240,),
        trials_per_speed=3,
        seed=3,
    )
    text = manifest.read_text(encoding="utf-8")
    head, _, _ = text.partition("[[trials]]")
    globbed = tmp_path / "globbed.toml"
    globbed.write_text(
        head + '[[trials]]\nfiles = "data/A_q*.csv"\nbodies = ["disk"]\nkind = "quasi-static"\n'
        '[[trials]]\nfiles = "data/A_240_*.csv"\nbodies = ["disk"]\nkind = "fast"\nspeed = 240\n',
        encoding="utf-8",
    )
    processed = process_study(globbed)
    rows = processed.provenance
    assert [r["file"] for r in rows] == [
        "data/A_quasistatic.csv", "data/A_240_01.csv", "data/A_240_02.csv", "data/A_240_03.csv"
    ]  # fmt: skip
    for row in rows:
        digest = hashlib.sha256((tmp_path / row["file"]).read_bytes()).hexdigest()
        assert row["sha256"] == digest
        assert row["status"] == "ok"
    assert list(processed.trials["file"]) == [r["file"] for r in rows]


@pytest.mark.parametrize("key", ["file", "files"])
def test_a_home_folder_that_does_not_exist_is_one_line(tmp_path, key):
    # found by the fuzz test: Path.expanduser raised RuntimeError for "~qs.csv"
    _files(tmp_path, "data/A_qs.csv")
    entry = f'[[trials]]\n{key} = "~nosuch-user-9/B.csv"\nbodies = ["attachment"]\nkind = "fast"\n'
    message = _error(_manifest(tmp_path, QS + entry))
    assert message.endswith(
        f"trials[1].{key}: '~nosuch-user-9/B.csv': ~nosuch-user-9 names no home folder on this "
        "machine"
    )


SCRIPT = """
import sys
from pathlib import Path
from inertiafit.errors import InputError
from inertiafit.io import load_study
try:
    load_study(Path(sys.argv[1]))
except InputError as exc:
    print(exc)
"""


def test_a_file_name_the_file_system_cannot_hold_is_one_line(tmp_path):
    # found by the fuzz test in CI's locale (LC_ALL=C, UTF-8 mode off: an ASCII file-system
    # encoding): os.path.realpath raised UnicodeEncodeError for "\x80qs.csv". Here in a child
    # with that locale; the negative control, a UTF-8 child, says only that the file is missing.
    from conftest import in_ascii_and_utf8_locales

    _files(tmp_path, "data/A_qs.csv")
    entry = '[[trials]]\nfile = "data/\\u00e9.csv"\nbodies = ["attachment"]\nkind = "fast"\n'
    manifest = _manifest(tmp_path, QS + entry)
    said = in_ascii_and_utf8_locales(SCRIPT, str(manifest))
    assert said["C"].endswith(
        "trials[1].file: 'data/é.csv': this machine's file names cannot hold 'é' (file-system "
        "encoding ascii); rename the file or run in a UTF-8 locale"
    )
    assert "file not found" in said["C.UTF-8"]


def test_a_manifest_under_an_unknown_home_folder_is_one_line():
    with pytest.raises(InputError) as info:
        load_study("~nosuch-user-9/study.toml")
    assert str(info.value) == (
        "study manifest: '~nosuch-user-9/study.toml': ~nosuch-user-9 names no home folder on "
        "this machine"
    )
