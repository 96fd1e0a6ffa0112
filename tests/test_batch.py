"""`inertiafit run-many`: a batch of studies, serially or on a Dask cluster."""

import contextlib
import os
import socket
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from inertiafit.cli import main
from inertiafit.io.outputs import MARKER
from inertiafit.pipeline import batch as batch_module
from inertiafit.pipeline.batch import BATCH_COLUMNS, StudyTask, run_many, run_one, study_names
from inertiafit.posterior import SUMMARY_COLUMNS
from inertiafit.simulate import Noise, simulate_study

#: Two small one-body studies with different truths (kg, m, m): 10 trials each.
TRUTHS = {"a": (2.85, 0.12, 0.24), "b": (1.60, 0.05, 0.15)}
FILES = {
    "summary.csv",
    "trials.csv",
    "speed_effect.csv",
    "identification.csv",
    "comparison.csv",
    "posterior.nc",
    "report.html",
    "corner-attachment.png",
}


def _small_study(folder: Path, truth, seed: int) -> Path:
    return simulate_study(
        folder,
        bodies={"attachment": truth},
        conditions=[("attachment",)],
        speeds=(240.0,),
        trials_per_speed=3,
        quasi_static_speed=4.0,  # a 22 s quasi-static trial instead of 90 s
        seed=seed,
        noise=Noise(trial_offset_sd=0.1),
    )


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """``a/study.toml``, ``a/broken.toml`` (names a missing trial file), ``b/study.toml``."""
    root = tmp_path_factory.mktemp("studies")
    a = _small_study(root / "a", TRUTHS["a"], seed=11)
    b = _small_study(root / "b", TRUTHS["b"], seed=12)
    broken = a.with_name("broken.toml")
    broken.write_text(
        a.read_text(encoding="utf-8").replace("data/A_240_02.csv", "data/missing.csv", 1)
    )
    return [a, broken, b]


def _batch(studies, out: Path, **kwargs):
    lines: list[str] = []
    result = run_many(studies, out, formats=("png",), echo=lines.append, **kwargs)
    return result, lines


@pytest.fixture(scope="module")
def serial(studies, tmp_path_factory):
    return _batch(studies, tmp_path_factory.mktemp("serial") / "out", workers=1)


@pytest.fixture(scope="module")
def on_cluster(studies, tmp_path_factory):
    environ = dict(os.environ)
    with contextlib.ExitStack() as stack:
        # Dask's default HTTP port taken (another cluster): no warning (warnings are errors)
        busy = stack.enter_context(socket.socket())
        with contextlib.suppress(OSError):  # already taken by someone else: as good
            busy.bind(("0.0.0.0", 8787))
            busy.listen()
        result = _batch(studies, tmp_path_factory.mktemp("cluster") / "out", workers=2)
    return (*result, environ, dict(os.environ))


@pytest.mark.slow
def test_batch_records_every_study_and_a_bad_one_does_not_stop_the_others(serial, studies):
    result, lines = serial
    out = result.out
    assert result.where == "one after another in this process"
    assert result.startup_seconds == 0
    table = pd.read_csv(out / "batch.csv", keep_default_na=False)
    assert list(table.columns) == BATCH_COLUMNS
    assert table["manifest"].tolist() == [str(p) for p in studies]  # the order given
    # both manifests are called study.toml: their folders are named after their folders too
    assert table["folder"].tolist() == ["a-study", "", "b-study"]
    assert table["status"].tolist() == ["ok", "failed", "ok"]
    error = table.loc[1, "error"]
    assert error.startswith(f"{studies[1]}: ")
    assert "missing.csv" in error
    assert "\n" not in error
    assert result.failed == [str(studies[1])]
    assert not result.ok
    ok = table[table["status"] == "ok"]
    assert (ok["converged"] == "True").all()
    assert (ok["seconds"].astype(float) > 0).all()
    for _, row in ok.iterrows():  # the worst diagnostics of the study's own summary.csv
        s = pd.read_csv(out / row["folder"] / "summary.csv")
        assert float(row["r_hat_max"]) == s["r_hat"].max() < 1.05
        assert float(row["ess_bulk_min"]) == s["ess_bulk"].min() > 1000
    assert (table["seed"] == 0).all()
    # each good study's folder is complete; the failed one left nothing behind
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["a-study", "b-study", "batch.csv", "batch-summary.csv", MARKER]
    )
    for name in ("a-study", "b-study"):
        assert {p.name for p in (out / name).iterdir()} >= FILES
    # progress: a line per study as it ends, the failure with its error
    assert lines[0] == "running 3 studies one after another in this process"
    assert f"[2/3] broken: failed: {error}" in lines
    assert any(line.startswith("[3/3] b-study: ok in ") for line in lines)


@pytest.mark.slow
def test_each_study_recovers_its_own_truth(serial, studies):
    out = serial[0].out
    for key, name in (("a", "a-study"), ("b", "b-study")):
        truth = tomllib.loads(
            (Path(studies[0]).parents[1] / key / "truth.toml").read_text(encoding="utf-8")
        )
        t = truth["bodies"]["attachment"]
        s = pd.read_csv(out / name / "summary.csv").set_index("parameter")
        for p in ("inertia", "gravity_moment"):
            assert s.loc[p, "hdi_lower"] < t[p] < s.loc[p, "hdi_upper"], (name, p)
            assert s.loc[p, "sd"] < 0.1 * s.loc[p, "median"], (name, p)  # the data pin them
    # the two studies really are different bodies: 0.28 vs 0.04 kg m^2
    ia = pd.read_csv(out / "a-study" / "summary.csv").set_index("parameter").loc["inertia"]
    ib = pd.read_csv(out / "b-study" / "summary.csv").set_index("parameter").loc["inertia"]
    assert ia["median"] > 5 * ib["median"]


@pytest.mark.slow
def test_batch_summary_stacks_the_study_summaries(serial):
    out = serial[0].out
    stacked = pd.read_csv(out / "batch-summary.csv")
    assert list(stacked.columns) == ["folder", *SUMMARY_COLUMNS]
    assert stacked["folder"].tolist() == ["a-study"] * 5 + ["b-study"] * 5
    for name in ("a-study", "b-study"):
        own = pd.read_csv(out / name / "summary.csv")
        part = stacked[stacked["folder"] == name].drop(columns="folder").reset_index(drop=True)
        pd.testing.assert_frame_equal(part, own)
    pd.testing.assert_frame_equal(
        serial[0].summary.reset_index(drop=True), stacked, check_dtype=False
    )


#: `inertiafit run` as `pip install inertiafit` installs it: without the `cluster` extra (Dask
#: hidden: importing it fails), with one BLAS thread as run-many uses. Prints the Dask modules
#: imported after all (none expected).
RUN_WITHOUT_DASK = """
import sys
sys.modules.update(dask=None, distributed=None)
from threadpoolctl import threadpool_limits
from inertiafit.cli import main
with threadpool_limits(limits=1):
    code = main(sys.argv[1:])
print(sorted(m for m, mod in sys.modules.items() if m.startswith(("dask", "distributed")) and mod))
sys.exit(code)
"""


@pytest.mark.slow
def test_a_study_folder_is_what_run_writes_also_without_dask(serial, studies, tmp_path):
    """Same seed, same files as `inertiafit run` (one BLAS thread, as run-many uses), run
    where Dask is not installed: the default install works, never imports it, and gives the
    same numbers as the batch run beside Dask."""
    out = tmp_path / "run"
    argv = ["run", str(studies[2]), "--out", str(out), "--formats", "png"]
    done = subprocess.run(
        [sys.executable, "-c", RUN_WITHOUT_DASK, *argv],
        check=False,
        capture_output=True,
        text=True,
        encoding="utf-8",
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]"
    batch = serial[0].out / "b-study"
    assert {p.name for p in batch.iterdir()} == {p.name for p in out.iterdir()}
    for name in ("summary.csv", "trials.csv", "comparison.csv"):
        assert (batch / name).read_bytes() == (out / name).read_bytes(), name
    with (
        xr.open_datatree(out / "posterior.nc") as p,
        xr.open_datatree(batch / "posterior.nc") as q,
    ):
        for var in p["posterior"].data_vars:
            np.testing.assert_array_equal(p["posterior"][var], q["posterior"][var])


def _without_dask(monkeypatch) -> None:
    """As if the `cluster` extra were not installed: importing dask or distributed fails."""
    monkeypatch.setitem(sys.modules, "dask", None)
    monkeypatch.setitem(sys.modules, "distributed", None)


def test_without_dask_a_batch_runs_one_study_after_another_and_says_so(
    studies, tmp_path, monkeypatch
):
    _without_dask(monkeypatch)
    monkeypatch.setattr(batch_module, "_available_cpus", lambda: 4)  # a cluster by default
    result, lines = _batch([studies[1], studies[1]], tmp_path / "out")  # both fail at once
    assert lines[0] == (
        "Dask is not installed (pip install 'inertiafit[cluster]' runs the studies in "
        "parallel): running them one after another"
    )
    assert lines[1] == "running 2 studies one after another in this process"
    assert result.where == "one after another in this process"
    assert result.table["status"].tolist() == ["failed", "failed"]
    assert result.startup_seconds == 0


@pytest.mark.parametrize(
    ("extra", "asked", "local"),
    [
        (["--workers", "2"], "--workers: 2", ", or ask for one worker (one study after another)"),
        (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler: tcp://127.0.0.1:8786", ""),
    ],
    ids=["workers", "scheduler"],
)
def test_without_dask_a_cluster_is_one_line_exit_2_naming_the_extra(
    studies, tmp_path, capsys, monkeypatch, extra, asked, local
):
    _without_dask(monkeypatch)
    out = tmp_path / "out"
    argv = ["run-many", str(studies[0]), str(studies[2]), "--out", str(out), *extra]
    assert _one_line_exit_2(argv, capsys, out) == (
        f"inertiafit: error: {asked}: runs the studies on a Dask cluster, and Dask is not "
        f"installed; install it with pip install 'inertiafit[cluster]'{local}"
    )


@pytest.mark.slow
def test_local_cluster_of_two_workers_gives_the_same_numbers_as_serial(serial, on_cluster):
    (ser, _), (clu, lines, environ_before, environ_after) = serial, on_cluster
    assert environ_after == environ_before  # Dask's nannies export OMP_NUM_THREADS=1 etc.
    assert clu.where == "on a local Dask cluster of 2 worker processes"
    assert lines[0] == "starting a local Dask cluster of 2 workers"
    assert lines[1].startswith("running 3 studies on a local Dask cluster of 2 worker processes")
    assert clu.startup_seconds > 0
    a = pd.read_csv(ser.out / "batch.csv", keep_default_na=False)
    b = pd.read_csv(clu.out / "batch.csv", keep_default_na=False)
    pd.testing.assert_frame_equal(a.drop(columns="seconds"), b.drop(columns="seconds"))
    assert (ser.out / "batch-summary.csv").read_bytes() == (
        clu.out / "batch-summary.csv"
    ).read_bytes()
    for name in ("a-study", "b-study"):
        for f in ("summary.csv", "trials.csv", "comparison.csv", "identification.csv"):
            assert (ser.out / name / f).read_bytes() == (clu.out / name / f).read_bytes()
        with (
            xr.open_datatree(ser.out / name / "posterior.nc") as p,
            xr.open_datatree(clu.out / name / "posterior.nc") as q,
        ):
            for var in p["posterior"].data_vars:
                np.testing.assert_array_equal(p["posterior"][var], q["posterior"][var])


def _clients_here() -> int:
    import gc

    return sum(type(o).__name__ == "Client" for o in gc.get_objects())


@pytest.mark.slow
def test_cli_on_an_explicit_scheduler(studies, serial, tmp_path, capsys):
    from distributed import Client, LocalCluster

    out = tmp_path / "out"
    with (
        LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env={"MPLBACKEND": "pdf"},  # the task must switch the worker to Agg itself
        ) as cluster,
        Client(cluster, set_as_default=False) as client,
    ):
        addr = cluster.scheduler_address
        argv = ["run-many", str(studies[2]), "--out", str(out), "--formats", "png"]
        assert main([*argv, "--scheduler", addr, "--seed", "0"]) == 0
        backends = client.run(lambda: __import__("matplotlib").get_backend().lower())
        # xarray writing posterior.nc must not have made the worker a client of its own
        clients = client.run(_clients_here)
    assert list(backends.values()) == ["agg"]
    assert list(clients.values()) == [0]
    cap = capsys.readouterr()
    assert f"running 1 study on the Dask scheduler at {addr} with 1 worker (ready in " in cap.err
    assert "1 of 1 studies done" in cap.out
    table = pd.read_csv(out / "batch.csv")
    assert table["status"].tolist() == ["ok"]
    assert table["folder"].tolist() == ["study"]  # alone in this batch: just its stem
    assert (out / "study" / "summary.csv").read_bytes() == (
        serial[0].out / "b-study" / "summary.csv"
    ).read_bytes()


def test_cli_exit_1_names_the_failed_study_and_keeps_the_batch_table(studies, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run-many", str(studies[1]), "--out", str(out), "--workers", "1"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == (
        f"inertiafit: error: 1 of 1 studies failed: {studies[1]} (errors in {out / 'batch.csv'})"
    )
    table = pd.read_csv(out / "batch.csv")
    assert table["status"].tolist() == ["failed"]
    assert "missing.csv" in table.loc[0, "error"]
    assert pd.read_csv(out / "batch-summary.csv").columns.tolist() == ["folder"]


def _one_line_exit_2(argv, capsys, out: Path) -> str:
    assert main(argv) == 2
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    assert lines[0].startswith("inertiafit: error: ")
    assert not out.exists()
    assert not list(out.parent.glob(f".{out.name}.*"))  # no temporary folder left either
    return lines[0]


def test_missing_manifest_is_one_line_exit_2(studies, tmp_path, capsys):
    out = tmp_path / "out"
    missing = tmp_path / "nope" / "study.toml"
    line = _one_line_exit_2(
        ["run-many", str(studies[0]), str(missing), "--out", str(out)], capsys, out
    )
    assert line == (
        f"inertiafit: error: {missing}: manifest not found; expected a study manifest (TOML file)"
    )


def test_no_manifests_is_one_line_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run-many", "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err == "inertiafit: error: the following arguments are required: STUDY\n"
    with pytest.raises(Exception, match="no study manifests given"):
        run_many([], tmp_path / "out")
    assert not (tmp_path / "out").exists()


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_one_line_exit_2(studies, tmp_path, capsys):
    out = tmp_path / "out"
    addr = f"tcp://127.0.0.1:{_closed_port()}"
    t0 = time.perf_counter()
    argv = ["run-many", str(studies[0]), "--out", str(out), "--connect-timeout", "1"]
    line = _one_line_exit_2([*argv, "--scheduler", addr], capsys, out)
    assert time.perf_counter() - t0 < 20
    assert line.startswith(f"inertiafit: error: --scheduler: {addr}: cannot connect (")
    assert line.endswith(
        "expected the address of a running Dask scheduler, e.g. "
        "tcp://host:8786 as printed by 'dask scheduler'"
    )
    line = _one_line_exit_2(
        ["run-many", str(studies[0]), "--out", str(out), "--scheduler", "nonsense"],
        capsys,
        out,
    )
    assert (
        "--scheduler: nonsense: cannot connect (missing port number in address 'nonsense')" in line
    )


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--workers", "0"], "--workers: expected a whole number >= 1, got 0"),
        (
            ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"],
            "--workers: applies to a local run only",
        ),
        (["--hdi-prob", "1.5"], "--hdi-prob: expected a probability in (0, 1), got 1.5"),
        (["--formats", "png,gif"], "--formats: expected a comma-separated subset"),
        (["--connect-timeout", "0"], "--connect-timeout: must be positive"),
    ],
)
def test_bad_options_are_one_line_exit_2(studies, tmp_path, capsys, extra, expected):
    out = tmp_path / "out"
    line = _one_line_exit_2(["run-many", str(studies[0]), "--out", str(out), *extra], capsys, out)
    assert expected in line


def test_out_that_may_not_be_replaced_is_refused(studies, tmp_path, capsys):
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "notes.txt").write_text("keep me")
    assert main(["run-many", str(studies[0]), "--out", str(theirs)]) == 2
    assert "was not written by inertiafit" in capsys.readouterr().err
    assert (theirs / "notes.txt").read_text(encoding="utf-8") == "keep me"
    # an earlier output folder that now holds a manifest: replacing it would delete the input
    old = tmp_path / "old"
    old.mkdir()
    (old / MARKER).write_text("")
    manifest = old / "study.toml"
    manifest.write_text(Path(studies[0]).read_text(encoding="utf-8"))
    assert main(["run-many", str(manifest), "--out", str(old)]) == 2
    assert f"holds the input {manifest} of this run" in capsys.readouterr().err
    assert manifest.is_file()


def test_an_unexpected_error_is_recorded_with_its_traceback(studies, tmp_path, monkeypatch):
    import inertiafit.pipeline.batch

    def boom(*_args, **_kwargs):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr(inertiafit.pipeline.batch, "run_study", boom)
    result, _ = _batch([studies[0]], tmp_path / "out", workers=1)
    row = result.table.iloc[0]
    assert (row["status"], row["error"], row["folder"]) == (
        "failed",
        "RuntimeError: boom second line",
        "",
    )
    trace = (tmp_path / "out" / "study-traceback.txt").read_text(encoding="utf-8")
    assert "RuntimeError: boom" in trace
    assert "run_one" in trace


def test_a_worker_that_cannot_see_the_manifest_says_so(tmp_path):
    task = StudyTask(0, str(tmp_path / "gone.toml"), str(tmp_path / "o"), 0, 0.95, ("png",))
    record = run_one(task)
    assert record["status"] == "failed"
    assert record["error"].startswith(f"{tmp_path / 'gone.toml'}: not found on ")
    assert "shared file system" in record["error"]
    assert not (tmp_path / "o").exists()


def test_study_names_are_unique_and_readable(tmp_path):
    paths = [
        tmp_path / "s01" / "study.toml",
        tmp_path / "s02" / "study.toml",
        tmp_path / "elbow.toml",
        tmp_path / "s01" / "study.toml",  # the same manifest twice
        tmp_path / "batch.csv.toml",  # would collide with the batch table
    ]
    assert study_names(paths) == ["s01-study", "s02-study", "elbow", "s01-study-2", "batch.csv-2"]


def test_importing_the_command_line_and_batch_does_not_import_dask():
    code = (
        "import sys, inertiafit.cli, inertiafit.pipeline.batch; "
        "print(sorted(m for m in ('dask', 'distributed') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, encoding="utf-8", check=True
    ).stdout
    assert out.strip() == "[]"


def test_every_study_of_a_batch_gets_its_ess_target_and_a_bad_one_stops_nothing_started(
    studies, tmp_path, monkeypatch
):
    """``run-many --ess-min``: each study's run_study is asked for it (run_study's own test,
    tests/test_study.py, checks what it does); a bad value is one line before any study."""
    asked = []

    def fake(manifest, **kwargs):
        asked.append(kwargs["ess_min"])
        raise batch_module.InputError(f"{manifest}: stopped here")

    monkeypatch.setattr(batch_module, "run_study", fake)
    _batch([studies[0], studies[2]], tmp_path / "out", workers=1, ess_min=5000)
    assert asked == [5000, 5000]
    with pytest.raises(batch_module.InputError, match=r"^ess_min: expected a number in "):
        _batch([studies[0]], tmp_path / "bad", workers=1, ess_min=10)
    assert not (tmp_path / "bad").exists()
    assert len(asked) == 2
