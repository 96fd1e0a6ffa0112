"""Many studies in one command: ``inertiafit run-many``, on a Dask cluster or locally.

:func:`run_many` runs :func:`inertiafit.pipeline.study.run_study` once per study manifest, each into its
own subfolder of ``out``, and writes two tables beside them:

- ``batch.csv``: a row per study in the order given (:data:`BATCH_COLUMNS`): the manifest, its
  folder, ``ok`` or ``failed`` with the one-line error, seconds, convergence and the worst
  R-hat and bulk ESS of its ``summary.csv``; a study refused before its posterior leaves its
  per-trial table (``diagnostics.csv``, as ``inertiafit run`` does) in its folder, which its
  row then names (the folder of any other failed study is empty);
- ``batch-summary.csv``: every ``summary.csv`` of the batch stacked, a ``folder`` column first.

Where the studies run:

- ``scheduler="tcp://host:8786"``: one task per study on that Dask scheduler's workers, which
  must see the manifests, the trial files and ``out`` at the same paths (a shared file system);
- no scheduler, several studies and ``workers`` > 1 (default: the CPUs this process may use):
  a ``LocalCluster`` of single-threaded worker processes on this machine;
- otherwise (``workers=1``, or one study): one after another in this process.

Every study is sampled with ``seed``, as ``inertiafit run STUDY --seed N`` would, and with
one BLAS thread, as in a Dask worker, on whichever worker and in whichever order it runs: its
numbers are the same serially and on a cluster. (``inertiafit run`` uses every BLAS thread;
the sampler's draws depend on that count in their last digits, so its numbers can differ from
``run-many``'s in the last printed digit of a diagnostic such as R-hat.)

One study's failure does not stop the others: it is recorded as ``failed`` with its one-line
error. Bad arguments (no manifests, a manifest that does not exist, an unreachable scheduler)
raise :class:`~inertiafit.errors.InputError` before anything is written. ``out`` is replaced
whole, as by ``run``.

Dask (``dask``, ``distributed``) is the optional ``cluster`` extra (``pip install
"inertiafit[cluster]"``), imported only when a cluster is used. Without it, a batch asked for
no particular ``workers`` runs one study after another in this process (a line says so); a
``scheduler`` or ``workers`` > 1 is refused, naming the command that installs it.
"""

from __future__ import annotations

import importlib.util
import logging
import math
import os
import signal
import socket
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from inertiafit._checks import check_positive, check_probability, check_seed, check_whole
from inertiafit.errors import InputError
from inertiafit.inference.sampler import sampler_settings
from inertiafit.io.manifest import load_study
from inertiafit.io.outputs import MARKER, check_out, guard_outputs, output_folder, write_csv
from inertiafit.pipeline.study import DIAGNOSTICS, run_study, study_inputs
from inertiafit.plotting.style import DEFAULT_FORMATS, check_formats

#: Columns of ``batch.csv``.
BATCH_COLUMNS = [
    "manifest",
    "folder",
    "status",
    "error",
    "seconds",
    "converged",
    "r_hat_max",
    "ess_bulk_min",
    "warnings",
    "seed",
]
#: Files of the batch folder that a study folder must not be named after.
_RESERVED = {"batch.csv", "batch-summary.csv", MARKER}
#: How to install what a cluster needs (the optional ``cluster`` extra).
_CLUSTER_EXTRA = "pip install 'inertiafit[cluster]'"


@dataclass(frozen=True)
class StudyTask:
    """One study of a batch, as sent to a worker (paths absolute).

    Attributes
    ----------
    index : int
        Position of the manifest in the batch.
    manifest : str
        The study manifest.
    folder : str
        Output folder of this study (inside the batch's temporary folder).
    seed, hdi_prob, formats, ess_min
        As for :func:`inertiafit.pipeline.study.run_study`.
    in_worker : bool
        Runs in a Dask worker: Matplotlib is switched to the Agg backend first.
    """

    index: int
    manifest: str
    folder: str
    seed: int
    hdi_prob: float
    formats: tuple[str, ...]
    in_worker: bool = False
    ess_min: float | None = None


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    if isinstance(exc, InputError):
        return text
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def run_one(task: StudyTask) -> dict[str, Any]:
    """Run one study of a batch; never raises for a problem of the study itself.

    Returns
    -------
    dict
        ``status`` (``"ok"`` or ``"failed"``), ``error`` (one line), ``traceback`` (for an
        error other than an :class:`~inertiafit.errors.InputError`), ``seconds``,
        ``converged``, ``warnings`` (list of str), ``host`` and ``diagnostics`` (whether a
        refused study left its per-trial table, ``diagnostics.csv``, in its folder).
    """
    t0 = time.perf_counter()
    record: dict[str, Any] = {
        "status": "ok",
        "error": "",
        "traceback": "",
        "converged": None,
        "warnings": [],
        "host": socket.gethostname(),
        "diagnostics": False,
    }
    try:
        manifest = Path(task.manifest)
        if not manifest.is_file():
            raise InputError(
                f"{manifest}: not found on {record['host']}; every worker must see the "
                "manifests, trial files and --out at the same paths (a shared file system)"
            )
        from threadpoolctl import threadpool_limits

        with ExitStack() as stack:
            if task.in_worker:
                import dask
                import matplotlib

                matplotlib.use("Agg")  # figures are files; no worker has a display
                # xarray asks dask for a scheduler when it writes posterior.nc; in a worker
                # that would connect a client of the worker's own (and nothing here is a dask
                # computation).
                stack.enter_context(dask.config.set(scheduler="synchronous"))
            # One BLAS thread, as in a Dask worker: the sampler's draws depend on the BLAS
            # thread count in their last digits, so this makes a study's numbers the same
            # wherever it runs (and keeps concurrent studies from oversubscribing the cores).
            stack.enter_context(threadpool_limits(limits=1))
            caught = stack.enter_context(warnings.catch_warnings(record=True))
            warnings.simplefilter("always", UserWarning)  # e.g. ConvergenceWarning
            result = run_study(
                manifest,
                out=task.folder,
                seed=task.seed,
                hdi_prob=task.hdi_prob,
                formats=task.formats,
                echo=lambda _msg: None,
                progress=lambda _msg: None,
                ess_min=task.ess_min,
            )
        record["converged"] = bool(result.posterior.converged)
        record["warnings"] = [
            *result.warnings,
            *(" ".join(str(w.message).split()) for w in caught),
        ]
    except Exception as exc:  # noqa: BLE001 - one study's failure must not end the batch
        record.update(status="failed", error=_one_line(exc))
        if not isinstance(exc, InputError):
            record["traceback"] = traceback.format_exc()
        # a study refused before its posterior wrote its per-trial table (run_study)
        record["diagnostics"] = (Path(task.folder) / DIAGNOSTICS).is_file()
    record["seconds"] = time.perf_counter() - t0
    return record


def study_names(manifests: Sequence[str | Path]) -> list[str]:
    """Folder names of a batch's studies: the manifests' stems, made unique.

    Manifests that share a stem (``s01/study.toml``, ``s02/study.toml``) are named after their
    folder too (``s01-study``, ``s02-study``); any name still taken gets ``-2``, ``-3``...
    """
    paths = [Path(m).resolve() for m in manifests]
    stems = [p.stem.lstrip(".") or "study" for p in paths]
    names = []
    used: set[str] = set()
    for path, stem in zip(paths, stems, strict=True):
        base = stem
        if stems.count(stem) > 1 and path.parent.name:
            base = f"{path.parent.name.lstrip('.')}-{stem}"
        name, k = base, 1
        while name in used or name in _RESERVED:
            k += 1
            name = f"{base}-{k}"
        used.add(name)
        names.append(name)
    return names


@dataclass
class BatchResult:
    """What a batch did.

    Attributes
    ----------
    out : Path
        The batch folder.
    table : pandas.DataFrame
        ``batch.csv``: a row per study, columns :data:`BATCH_COLUMNS`.
    summary : pandas.DataFrame
        ``batch-summary.csv``: every successful study's ``summary.csv``, ``folder`` first.
    where : str
        Where the studies ran: ``"one after another in this process"``, ``"on a local Dask
        cluster of N worker processes"`` or ``"on the Dask scheduler at ADDR with N workers"``.
    seconds : float
        Wall time of the whole batch, cluster start-up included.
    startup_seconds : float
        Time to start the local cluster or connect to the scheduler (0 when serial).
    """

    out: Path
    table: pd.DataFrame
    summary: pd.DataFrame
    where: str
    seconds: float
    startup_seconds: float

    @property
    def failed(self) -> list[str]:
        """Manifests of the studies that failed, in the order given."""
        return [str(m) for m in self.table.loc[self.table["status"] != "ok", "manifest"]]

    @property
    def ok(self) -> bool:
        """Whether every study finished."""
        return not self.failed


# ---------------------------------------------------------------------------------------------
# Where the tasks run
# ---------------------------------------------------------------------------------------------

Done = Callable[[StudyTask, dict[str, Any]], None]


class _Serial:
    """One study after another in this process."""

    where = "one after another in this process"
    in_worker = False

    def run(self, tasks: Sequence[StudyTask], done: Done) -> None:
        for task in tasks:
            done(task, run_one(task))

    def abort(self) -> None:
        """Nothing runs elsewhere."""

    def close(self) -> None:
        """Nothing to close."""


@contextmanager
def _workers_ignore_sigint() -> Iterator[None]:
    """Start worker processes with Ctrl-C ignored (they inherit it across ``exec``).

    A Ctrl-C in a terminal reaches the whole process group. This process then cancels the
    batch and stops its workers; the workers themselves would only print tracebacks.
    """
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: leave the signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)


def _restore_environ(saved: dict[str, str]) -> None:
    for key in set(os.environ) - set(saved):
        del os.environ[key]
    for key, value in saved.items():
        if os.environ.get(key) != value:
            os.environ[key] = value


class _Dask:
    """One task per study on a Dask cluster: a scheduler's, or a LocalCluster started here."""

    in_worker = True

    def __init__(self, scheduler: str | None, workers: int, timeout: float) -> None:
        from distributed import Client, LocalCluster

        self.cluster = None
        self.futures: list = []
        if scheduler:
            try:
                self.client = Client(scheduler, timeout=timeout, set_as_default=False)
            except (OSError, ValueError) as exc:  # refused or timed out; malformed address
                raise InputError(
                    f"scheduler: {scheduler}: cannot connect ({' '.join(str(exc).split())}); "
                    "expected the address of a running Dask scheduler, e.g. tcp://host:8786 "
                    "as printed by 'dask scheduler'"
                ) from None
            n = len(self.client.nthreads())
            self.where = f"on the Dask scheduler at {scheduler} with {n} worker{'s' * (n != 1)}"
        else:
            import dask

            saved = dict(os.environ)
            try:
                # No dashboard or profiler (nobody watches this private cluster), and the
                # scheduler's HTTP endpoints on a free local port: the default 8787 may be
                # another cluster's, which would only earn a warning.
                with (
                    dask.config.set({"distributed.worker.profile.enabled": False}),
                    _workers_ignore_sigint(),
                ):
                    self.cluster = LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                        silence_logs=logging.ERROR,
                    )
            finally:
                _restore_environ(saved)  # the nannies export OMP_NUM_THREADS=1 etc. into ours
            self.client = Client(self.cluster, set_as_default=False)
            self.where = f"on a local Dask cluster of {workers} worker processes"

    def run(self, tasks: Sequence[StudyTask], done: Done) -> None:
        from distributed import as_completed

        by_future = {self.client.submit(run_one, t, pure=False): t for t in tasks}
        self.futures = list(by_future)
        for future in as_completed(self.futures, loop=self.client.loop):
            task = by_future[future]
            try:
                record = future.result()
            except Exception as exc:  # noqa: BLE001 - the task never finished: a worker died
                record = {
                    "status": "failed",
                    "error": f"the Dask task failed: {_one_line(exc)}",
                    "traceback": "",
                    "converged": None,
                    "warnings": [],
                    "seconds": math.nan,
                }
            done(task, record)

    def abort(self) -> None:
        """Cancel what has not run; a local cluster is stopped so that no worker writes on."""
        if self.futures:
            self.client.cancel(self.futures)
        if self.cluster is not None:
            self.close()

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
            self.cluster = None


# ---------------------------------------------------------------------------------------------
# The batch
# ---------------------------------------------------------------------------------------------


def _check_address(scheduler: str) -> None:
    """Refuse a malformed scheduler address before a Client is made.

    A Client that fails on one is left half-built, and closing it at exit prints a traceback
    after 20 s.
    """
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:
        scheme, location = parse_address(scheduler)
        get_backend(scheme)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except ValueError as exc:
        raise InputError(
            f"scheduler: {scheduler}: cannot connect ({' '.join(str(exc).split())}); "
            "expected the address of a running Dask scheduler, e.g. tcp://host:8786 "
            "as printed by 'dask scheduler'"
        ) from None


def dask_installed() -> bool:
    """Whether ``dask`` and ``distributed`` (the ``cluster`` extra) can be imported.

    Asked without importing them: importing ``distributed`` alone takes about half a second.
    """
    return all(importlib.util.find_spec(name) is not None for name in ("dask", "distributed"))


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _available_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _check_inputs(
    manifests, out: Path, scheduler, workers, hdi_prob, seed, connect_timeout
) -> list[Path]:
    if isinstance(manifests, str | Path):
        manifests = [manifests]
    paths = [Path(m) for m in manifests]
    if not paths:
        raise InputError("run-many: no study manifests given; expected one or more STUDY.toml")
    for p in paths:
        if not p.exists():
            raise InputError(f"{p}: manifest not found; expected a study manifest (TOML file)")
        if not p.is_file():
            raise InputError(f"{p}: is not a file; expected a study manifest (TOML file)")
    check_probability(hdi_prob, "hdi_prob")
    check_seed(seed)
    check_positive(connect_timeout, "connect_timeout", "seconds")
    if workers is not None:
        check_whole(workers, "workers", 1)
    if scheduler is not None and workers is not None:
        raise InputError(
            "workers: applies to a local run only; the cluster at scheduler has its own"
        )
    if scheduler is not None and not str(scheduler).strip():
        raise InputError("scheduler: expected an address such as tcp://host:8786, got ''")
    if (scheduler is not None or (workers or 1) > 1) and not dask_installed():
        asked = f"scheduler: {scheduler}" if scheduler is not None else f"workers: {workers}"
        local = (
            "" if scheduler is not None else ", or ask for one worker (one study after another)"
        )
        raise InputError(
            f"{asked}: runs the studies on a Dask cluster, and Dask is not installed; "
            f"install it with {_CLUSTER_EXTRA}{local}"
        )
    if scheduler is not None:
        _check_address(str(scheduler))
    # Checked and claimed before a cluster is started for nothing: out may not hold a manifest
    # or a file a manifest reads (a manifest that cannot be read fails as its study).
    inputs: list[Path] = list(paths)
    for p in paths:
        with suppress(InputError):
            inputs += study_inputs(load_study(p))
    check_out(out, inputs=inputs)
    return paths


def _row(manifest: Path, name: str, record: dict[str, Any], seed: int) -> dict[str, Any]:
    return {
        "manifest": str(manifest),
        # a refused study's folder holds its per-trial table (diagnostics.csv)
        "folder": name if record["status"] == "ok" or record.get("diagnostics") else "",
        "status": record["status"],
        "error": record["error"],
        "seconds": round(float(record["seconds"]), 3),
        "converged": record["converged"],
        "r_hat_max": math.nan,
        "ess_bulk_min": math.nan,
        "warnings": " | ".join(record["warnings"]),
        "seed": seed,
    }


@guard_outputs
def run_many(
    manifests: Sequence[str | Path],
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    seed: int = 0,
    hdi_prob: float = 0.95,
    formats: Sequence[str] = DEFAULT_FORMATS,
    echo: Callable[[str], None] | None = None,
    connect_timeout: float = 10.0,
    ess_min: float | None = None,
) -> BatchResult:
    """Run a batch of studies: each manifest's whole pipeline into ``out/<name>``.

    Parameters
    ----------
    manifests : sequence of path
        Study manifests (TOML). Folder names are their stems, made unique
        (:func:`study_names`).
    out : path
        The batch folder, replaced whole (as by ``inertiafit run``).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); its workers must see the
        same file system. Without one, the studies run on this machine.
    workers : int, optional
        Local worker processes (default: the CPUs this process may use, at most one per
        study). ``1`` runs the studies one after another in this process.
    seed : int
        Seed of every study's sampler (the same for each, as ``inertiafit run --seed``).
    hdi_prob : float
        Probability of the highest-density intervals.
    formats : sequence of str
        Figure formats (``pdf``, ``png``, ``svg``).
    echo : callable, optional
        Receives the progress lines (default: printed to stderr).
    connect_timeout : float
        Seconds to wait for ``scheduler``.
    ess_min : float, optional
        Every study's bulk ESS target (as ``inertiafit run --ess-min``).

    Returns
    -------
    BatchResult
        Failed studies are in ``.failed``; they do not raise.

    Raises
    ------
    InputError
        No manifests, a manifest that does not exist, bad options, an ``out`` that may not be
        replaced, or a scheduler that cannot be reached; nothing is written then.
    """
    t_start = time.perf_counter()
    say = echo or _stderr
    out = Path(out)
    paths = _check_inputs(manifests, out, scheduler, workers, hdi_prob, seed, connect_timeout)
    sampler_settings(ess_min)  # a bad value before any study runs
    formats = check_formats(formats)
    names = study_names(paths)
    n_local = min(workers or _available_cpus(), len(paths))
    pool: _Serial | _Dask
    if scheduler is None and n_local > 1 and not dask_installed():  # workers not asked for
        say(
            f"Dask is not installed ({_CLUSTER_EXTRA} runs the studies in parallel): "
            "running them one after another"
        )
        n_local = 1
    if scheduler is None and n_local <= 1:
        pool = _Serial()
    else:
        if scheduler is None:
            say(f"starting a local Dask cluster of {n_local} workers")
        pool = _Dask(scheduler, n_local, connect_timeout)
    startup = time.perf_counter() - t_start if isinstance(pool, _Dask) else 0.0
    n = len(paths)
    started = f" (ready in {startup:.1f} s)" if isinstance(pool, _Dask) else ""
    say(f"running {n} {'study' if n == 1 else 'studies'} {pool.where}{started}")
    if pool.where.endswith(" with 0 workers"):
        say("the scheduler has no workers yet: the studies wait until one connects")
    rows: dict[int, dict[str, Any]] = {}
    try:
        with output_folder(out.resolve()) as tmp:
            tasks = [
                StudyTask(
                    index=i,
                    manifest=str(path.resolve()),
                    folder=str(tmp / name),
                    seed=seed,
                    hdi_prob=hdi_prob,
                    formats=formats,
                    in_worker=pool.in_worker,
                    ess_min=ess_min,
                )
                for i, (path, name) in enumerate(zip(paths, names, strict=True))
            ]

            def done(task: StudyTask, record: dict[str, Any]) -> None:
                name = names[task.index]
                rows[task.index] = _row(paths[task.index], name, record, seed)
                head = f"[{len(rows)}/{n}] {name}:"
                if record["status"] == "ok":
                    state = "converged" if record["converged"] else "NOT converged"
                    say(f"{head} ok in {record['seconds']:.1f} s ({state})")
                    for w in record["warnings"]:
                        say(f"{head} warning: {w}")
                else:
                    say(f"{head} failed: {record['error']}")
                    if record.get("diagnostics"):
                        say(f"{head} per-trial table in {name}/{DIAGNOSTICS}")
                    if record.get("traceback"):
                        (tmp / f"{name}-traceback.txt").write_text(record["traceback"])

            try:
                pool.run(tasks, done)
            except BaseException:
                pool.abort()
                raise
            say(f"writing {out}")
            table, summary = _tables(tmp, [rows[i] for i in range(n)])
    finally:
        pool.close()
    return BatchResult(
        out=out,
        table=table,
        summary=summary,
        where=pool.where,
        seconds=time.perf_counter() - t_start,
        startup_seconds=startup,
    )


def _tables(folder: Path, rows: list[dict[str, Any]]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``batch.csv`` and ``batch-summary.csv`` into ``folder``, from the studies' summaries."""
    summaries = []
    for row in rows:
        if row["status"] != "ok":
            continue
        s = pd.read_csv(folder / row["folder"] / "summary.csv")
        row["r_hat_max"] = float(s["r_hat"].max())
        row["ess_bulk_min"] = float(s["ess_bulk"].min())
        summaries.append(s.assign(folder=row["folder"]))
    table = pd.DataFrame(rows, columns=BATCH_COLUMNS)
    table["converged"] = table["converged"].astype("boolean")
    if summaries:
        summary = pd.concat(summaries, ignore_index=True)
        summary = summary[["folder", *(c for c in summary.columns if c != "folder")]]
    else:
        summary = pd.DataFrame(columns=["folder"])
    write_csv(table, folder / "batch.csv")
    write_csv(summary, folder / "batch-summary.csv")
    return table, summary


__all__ = [
    "BATCH_COLUMNS",
    "BatchResult",
    "StudyTask",
    "dask_installed",
    "run_many",
    "run_one",
    "study_names",
]
