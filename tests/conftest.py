import matplotlib
from threadpoolctl import threadpool_limits

matplotlib.use("Agg")

# One BLAS thread per test process: `make test` runs two pytest workers on two cores, and
# OpenBLAS's own threads on cores that are already busy cost more than they give (one
# 90 000-sample dot product took 8 ms instead of 25 us when the cores were loaded). Results
# within a process do not depend on it; the gravity fit already runs on one thread.
threadpool_limits(limits=1)

from hypothesis import HealthCheck, settings

# Property tests (tests/test_io_properties.py): the suite runs the "ci" profile, a few
# derandomised examples per test (the same every run); `make fuzz` runs the "fuzz" profile,
# many random examples (pytest --hypothesis-profile=fuzz).
settings.register_profile(
    "ci",
    max_examples=25,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "fuzz",
    max_examples=1500,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("ci")


import os
import shutil
from pathlib import Path

import pytest

# Commands the tests start (``inertiafit ...``, the tutorials' shell blocks) write UTF-8, which
# the tests read, also where the locale is ASCII and Python's UTF-8 mode is off (CI:
# ``PYTHONUTF8=0 LC_ALL=C``). What such a terminal shows instead: test_cli.py.
os.environ["PYTHONIOENCODING"] = "utf-8"
# Figures at 100 dpi, not the 300 users get (inertiafit.plotting.style.DPI_VARIABLE): drawing
# them is most of a run's time, and the suite runs a few dozen. Tests of the default and of
# the variable set their own (test_plots.py).
os.environ["INERTIAFIT_DPI"] = "100"


#: Modules whose tests share one costly build (a tutorial's runs, a cohort's fits, a batch's
#: studies), put first in the collection. pytest-xdist's worksteal gives each worker a
#: contiguous half of the collection and steals from the tail of a queue, so these run from
#: the start on one worker while the other works through the rest. Left where their names
#: sort, at the tail, both workers reached them together and one waited for the other's
#: build (a tutorial's: 15 s) or made its own copy of a module's (a cohort: 10 s).
FIRST = ("test_tutorials.py", "test_population_command.py", "test_batch.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(FIRST)))  # stable: else as found


@pytest.fixture
def no_figures(monkeypatch):
    """Commands write every output but the figures: for tests of numbers, tables and messages
    (every figure is tested in test_plots.py and test_report_command.py)."""
    from inertiafit.report import outputs

    monkeypatch.setattr(outputs, "figure_records", lambda result: [])


def once_per_run(tmp_path_factory, name: str, make) -> Path:
    """``make(folder)``'s folder, made once per test run, shared by pytest-xdist's processes.

    `make test` runs two processes; a session fixture of their own would make each of them
    write the same folder (a fit of several seconds) when tests of both read it. The first to
    ask writes it under their common temporary folder, holding a lock; the other waits for it.
    Only a completed folder is shared: a ``make`` that raised leaves none, and the next to ask
    tries again (and meets the same error). Run without xdist, or without ``fcntl``: a folder
    of this process's own.
    """
    try:
        import fcntl
    except ImportError:  # no POSIX locks: each process writes its own
        fcntl = None
    if fcntl is None or "PYTEST_XDIST_WORKER" not in os.environ:
        folder = tmp_path_factory.mktemp(name)
        make(folder)
        return folder
    root = tmp_path_factory.getbasetemp().parent  # one per run, shared by its workers
    folder, done = root / name, root / f"{name}.done"
    with (root / f"{name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)  # what an attempt that raised left
            folder.mkdir()
            make(folder)
            done.touch()
    return folder


@pytest.fixture(scope="session")
def disk_fit(tmp_path_factory):
    """`inertiafit fit` on the paper's disk (cases.DISK_FIT, seed 4, PNG and PDF): its folder,
    written once per test run (:func:`once_per_run`). Read it only; copy it to change it."""
    from cases import DISK_FIT

    from inertiafit.cli import main

    def make(folder):
        out = folder / "out"
        assert main([*DISK_FIT, "--out", str(out), "--seed", "4", "--formats", "png,pdf"]) == 0

    return once_per_run(tmp_path_factory, "disk-fit", make) / "out"


@pytest.fixture(scope="session")
def study_out(tmp_path_factory):
    """`inertiafit run` (seed 2) on a simulated study of the attachment and the weight (3 fast
    trials per speed at 240 and 300 deg/s, the weight's ideal disk declared): its folder, written
    once per test run (:func:`once_per_run`; the study beside it, in ``../study``). Read it only;
    copy it to change it.

    Its figures are drawn by figure workers started before the trials are read (as on an idle
    machine, not the test suite's): every test that reads them checks that path too.
    """
    import concurrent.futures

    from cases import PRIORS, STUDY_IDEAL, TRUTH

    from inertiafit.cli import main
    from inertiafit.report import outputs as outputs_module
    from inertiafit.simulate import simulate_study

    def make(root):
        manifest = simulate_study(
            root / "study",
            bodies=TRUTH,
            conditions=[("attachment",), ("attachment", "weight")],
            speeds=(240, 300),
            trials_per_speed=3,
            seed=4,
            priors=PRIORS,
        )
        with manifest.open("a") as fh:
            fh.write(STUDY_IDEAL)
        pools = []
        draw = outputs_module.draw_figures

        def recording(*args, **kwargs):
            pools.append(kwargs.get("pool"))
            return draw(*args, **kwargs)

        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(outputs_module, "idle_cores", lambda: 2)
            mp.setattr(outputs_module, "draw_figures", recording)
            assert main(["run", str(manifest), "--out", str(root / "out"), "--seed", "2"]) == 0
        assert len(pools) == 1
        assert isinstance(pools[0], concurrent.futures.ProcessPoolExecutor)

    return once_per_run(tmp_path_factory, "rep", make) / "out"


def in_ascii_and_utf8_locales(script: str, *args: str) -> dict[str, str]:
    """What a child Python running ``script`` prints, per locale: ``"C"`` as CI runs (UTF-8
    mode off: an ASCII file-system encoding) and ``"C.UTF-8"`` (the negative control)."""
    import subprocess
    import sys

    said = {}
    for locale, utf8 in (("C", "0"), ("C.UTF-8", "1")):
        env = dict(os.environ, LC_ALL=locale, PYTHONUTF8=utf8, PYTHONIOENCODING="utf-8")
        done = subprocess.run(
            [sys.executable, "-c", script, *args],
            capture_output=True, text=True, encoding="utf-8", env=env, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        said[locale] = done.stdout.strip()
    return said
