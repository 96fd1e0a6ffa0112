"""Inputs shared by many tests: the paper's disk as numbers for `inertiafit fit`, and the
attachment with a 3 kg disk as simulated bodies with their priors; a
script run as an ordinary user."""

import importlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path

import pytest

#: `inertiafit fit` on the paper's 3 kg disk (Son et al., Table 3): inertia and gravity moment
#: with their standard errors.
DISK_FIT = [
    "fit",
    "--prior",
    "disk-3kg",
    "--inertia",
    "0.594",
    "--inertia-se",
    "0.0105",
    "--gravity-moment",
    "12.8",
    "--gravity-moment-se",
    "0.05",
]

#: Truth (mass kg, radius of gyration m, CoM distance m) of the simulated attachment and disk.
TRUTH = {"attachment": (2.85, 0.12, 0.24), "weight": (2.92, 0.0354, 0.45)}

#: Their priors: the nominal values, boxes of +-50 %.
PRIORS = {
    "attachment": {"mass": 2.91, "radius_of_gyration": 0.130, "com_distance": 0.225},
    "weight": {"mass": 2.92, "radius_of_gyration": 0.035, "com_distance": 0.45},
}

#: The weight's ideal (textbook) body, appended to the manifest of conftest's ``study_out``.
STUDY_IDEAL = """
[bodies.weight.ideal]
shape = "solid-disk"
radius = 0.05
thickness = 0.06
mass = 2.92
com_distance = 0.45
"""

#: The path of the first fast trial of :func:`one_condition_study`.
ONE_CONDITION_FAST = "data/A_240_01.csv"


def one_condition_study(folder):
    """The attachment alone: a quasi-static trial (4 deg/s over 90 deg) and three fast trials
    at 240 deg/s (ramp 0.2-0.35 s, constant speed 0.35-0.57 s); the plausibility checks' and
    issue 22's catalogue's study. Returns ``folder``."""
    from inertiafit.simulate import simulate_study

    simulate_study(
        folder,
        bodies={"attachment": TRUTH["attachment"]},
        conditions=[("attachment",)],
        speeds=(240,),
        trials_per_speed=3,
        quasi_static_speed=4.0,
        seed=7,
        phi=0.2,
        offset=1.5,
        priors={"attachment": PRIORS["attachment"]},
    )
    return folder


def as_ordinary_user(
    script: str, imports: tuple[str, ...] = ()
) -> subprocess.CompletedProcess[str]:
    """Run a Python ``script`` without root's rights, in a fresh folder of its own (its cwd).

    Root ignores file permissions, and CI containers run as root, so there the script runs in a
    forked child that drops to ``nobody`` (an interpreter kept under /root could not be run by
    it, nor the modules it has not imported yet: name them in ``imports``); any other user runs
    it the same way as themselves. The script prints what the test checks and must leave its
    folder removable by its user.
    """
    ids = None
    if os.name == "posix" and os.geteuid() == 0:
        import pwd

        try:
            nobody = pwd.getpwnam("nobody")
        except KeyError:
            pytest.skip("running as root and no user 'nobody' to drop to")
        ids = (nobody.pw_uid, nobody.pw_gid)
    folder = Path(tempfile.mkdtemp(prefix="inertiafit-user-"))
    try:
        if ids is not None:
            os.chown(folder, *ids)
        code = compile(script, "<as_ordinary_user>", "exec")
        return in_fork(
            lambda: exec(code, {}),
            cwd=folder,
            imports=imports,
            user=ids,
        )
    finally:
        shutil.rmtree(folder)


def in_fork(
    body: Callable[[], object],
    *,
    cwd: Path,
    imports: tuple[str, ...] = (),
    user: tuple[int, int] | None = None,
    timeout: int | None = None,
) -> subprocess.CompletedProcess[str]:
    """Run ``body`` in a forked child with ``cwd`` as its working folder; its exit status,
    stdout and stderr (a traceback when it raised).

    The child first imports ``imports`` (those it does not share with this process yet), then
    drops to ``user`` (uid, gid) if given. Whatever it registers or sets stays in the child.
    ``timeout`` (s) kills it with SIGALRM (status -14).
    """
    with (
        tempfile.TemporaryFile("w+", encoding="utf-8") as out,
        tempfile.TemporaryFile("w+", encoding="utf-8") as err,
    ):
        with warnings.catch_warnings():
            # pytest-xdist's threads: the child only runs the body and exits
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:  # pragma: no cover (the child)
            status = 1
            try:
                if timeout is not None:
                    signal.signal(signal.SIGALRM, signal.SIG_DFL)
                    signal.alarm(timeout)
                for name in imports:
                    importlib.import_module(name)
                if user is not None:
                    os.setgroups([])
                    os.setgid(user[1])
                    os.setuid(user[0])
                os.chdir(cwd)
                sys.stdout, sys.stderr = out, err
                body()
                status = 0
            except BaseException:  # noqa: BLE001 (reported to the parent, as a traceback)
                traceback.print_exc(file=err)
            finally:
                out.flush()
                err.flush()
                os._exit(status)
        status = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
        out.seek(0)
        err.seek(0)
        return subprocess.CompletedProcess(["<in_fork>"], status, out.read(), err.read())
