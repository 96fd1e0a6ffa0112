"""The suite's own helpers: conftest's :func:`once_per_run` (a folder shared by xdist's processes)."""

import multiprocessing
import time

import pytest
from conftest import once_per_run


class _Factory:
    """What once_per_run uses of pytest's tmp_path_factory: a worker's folder under ``root``."""

    def __init__(self, root, worker):
        self.base = root / worker
        self.count = 0

    def getbasetemp(self):
        self.base.mkdir(parents=True, exist_ok=True)
        return self.base

    def mktemp(self, name):
        self.count += 1
        path = self.getbasetemp() / f"{name}{self.count}"
        path.mkdir()
        return path


def _slow_make(log):
    def make(folder):
        with log.open("a") as fh:
            fh.write("made\n")
        time.sleep(0.5)  # long enough for the other process to ask meanwhile
        (folder / "result.txt").write_text("42")

    return make


def _in_other_worker(root, log, queue):
    import os

    os.environ["PYTEST_XDIST_WORKER"] = "gw1"
    queue.put(str(once_per_run(_Factory(root, "gw1"), "shared", _slow_make(log))))


def test_two_workers_share_one_folder_made_once(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw0")
    log = tmp_path / "log.txt"
    queue = multiprocessing.get_context("fork").Queue()
    other = multiprocessing.get_context("fork").Process(
        target=_in_other_worker, args=(tmp_path, log, queue)
    )
    other.start()
    here = once_per_run(_Factory(tmp_path, "gw0"), "shared", _slow_make(log))
    there = queue.get(timeout=30)
    other.join(timeout=30)
    assert other.exitcode == 0
    assert str(here) == there == str(tmp_path / "shared")
    assert log.read_text(encoding="utf-8") == "made\n"  # once, whichever process came first
    assert (here / "result.txt").read_text(encoding="utf-8") == "42"
    assert sorted(p.name for p in here.iterdir()) == ["result.txt"]  # no marker inside


def test_a_make_that_raised_is_tried_again_on_a_clean_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw0")
    factory = _Factory(tmp_path, "gw0")

    def broken(folder):
        (folder / "half.txt").write_text("half")
        raise RuntimeError("the fit failed")

    with pytest.raises(RuntimeError, match="the fit failed"):
        once_per_run(factory, "shared", broken)
    calls = []
    folder = once_per_run(factory, "shared", lambda f: calls.append(sorted(f.iterdir())))
    assert calls == [[]]  # made again, in an empty folder
    assert folder == tmp_path / "shared"
    once_per_run(factory, "shared", calls.append)
    assert len(calls) == 1  # then shared


def test_without_xdist_each_call_makes_its_own(tmp_path, monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    factory = _Factory(tmp_path, "main")
    made = []
    first = once_per_run(factory, "own", made.append)
    second = once_per_run(factory, "own", made.append)
    assert made == [first, second]
    assert first != second
