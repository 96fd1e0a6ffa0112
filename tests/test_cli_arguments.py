"""Bad arguments and misleading messages (issue 22): one line naming the argument, exit 2.

Every case goes through the command line (``inertiafit.cli.main``) where it can, and through
the Python API where only the API takes it; none runs the sampler.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import shutil
import subprocess
import sys

import pytest
from cases import DISK_FIT, PRIORS, TRUTH
from hypothesis import given
from hypothesis import strategies as st

from inertiafit.cli import _as_options, build_parser, main
from inertiafit.errors import InputError
from inertiafit.io import load_study
from inertiafit.simulate import simulate_study

FIT = DISK_FIT
SEED_MAX = 2**32 - 1


def run_cli(argv: list[str]) -> tuple[int, str]:
    """Exit status and stderr of ``inertiafit ARGV`` (argparse's own errors included)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code  # type: ignore[assignment]
    return int(code), err.getvalue()


def assert_one_line(err: str, *patterns: str) -> None:
    """One error line, the last on stderr (progress lines may come before it)."""
    assert "Traceback" not in err
    assert err.endswith("\n"), err
    lines = err.splitlines()
    assert [x for x in lines if x.startswith("inertiafit: error: ")] == lines[-1:], err
    for pattern in patterns:
        assert re.search(pattern, lines[-1]), (pattern, err)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Two conditions, one quasi-static trial and three fast trials each (nothing sampled)."""
    folder = tmp_path_factory.mktemp("cli-args") / "study"
    simulate_study(
        folder,
        bodies=TRUTH,
        conditions=[("attachment",), ("attachment", "weight")],
        speeds=(240,),
        trials_per_speed=3,
        quasi_static_speed=4.0,
        seed=7,
        priors=PRIORS,
    )
    return folder


def copy_study(study, tmp_path, name="study"):
    folder = tmp_path / name
    shutil.copytree(study, folder)
    return folder


# --- seeds: checked while parsing, before any work ------------------------------------------


@pytest.mark.parametrize("seed", ["-1", str(SEED_MAX + 1), "1.5", "x"])
@pytest.mark.parametrize(
    "command",
    [
        FIT,
        ["run", "study.toml"],
        ["plan", "design.toml"],
        ["demo"],
        ["run-many", "study.toml", "--out", "batch"],
    ],
    ids=["fit", "run", "plan", "demo", "run-many"],
)
def test_a_seed_out_of_range_is_one_line_naming_seed(tmp_path, command, seed):
    out = tmp_path / "o"
    code, err = run_cli([*command, f"--seed={seed}", "--out", str(out)])
    assert code == 2
    assert_one_line(err, rf"--seed: expected a whole number from 0 to {SEED_MAX}, got")
    assert not out.exists()


@pytest.mark.parametrize("seed", [-1, SEED_MAX + 1, 1.5, "0", None, True])
def test_the_api_checks_seeds_before_any_work(tmp_path, study, seed):
    from inertiafit.inference.fit import fit_body
    from inertiafit.pipeline.study import analyse_study

    for call in (
        lambda: fit_body(
            "disk-3kg", inertia=0.594, inertia_se=0.01, gravity_moment=12.8,
            gravity_moment_se=0.05, seed=seed,
        ),
        lambda: analyse_study(study / "study.toml", seed=seed),
    ):  # fmt: skip
        with pytest.raises(InputError, match=r"^seed: expected a whole number from 0 to "):
            call()


def test_the_largest_seed_is_accepted():
    from inertiafit._checks import check_seed

    assert check_seed(SEED_MAX) == SEED_MAX
    assert check_seed(0) == 0
    assert check_seed(7.0) == 7


# --- numbers of the fit command ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("option", "value", "match"),
    [
        ("--gravity", "inf", r"--gravity: expected a positive finite number \(m/s\^2\), got inf"),
        ("--gravity", "nan", r"--gravity: expected a positive finite number"),
        ("--gravity", "0", r"--gravity: must be positive \(m/s\^2\), got 0\.0"),
        ("--gravity", "-9.81", r"--gravity: must be positive"),
        ("--hdi-prob", "nan", r"--hdi-prob: expected a probability in \(0, 1\), got nan"),
        ("--torque-gain-sd", "nan", r"--torque-gain-sd: expected a relative SD"),
    ],
)
def test_fit_numbers_are_one_line_naming_the_option(tmp_path, option, value, match):
    out = tmp_path / "o"
    code, err = run_cli([*FIT, f"{option}={value}", "--out", str(out)])
    assert code == 2
    assert_one_line(err, match)
    assert not out.exists()


def test_a_scheduler_that_is_not_an_address_is_one_line_and_no_traceback(tmp_path, study):
    # A subprocess: the traceback came at exit, from a half-built Dask client closing.
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "inertiafit.cli",
            "run-many",
            str(study / "study.toml"),
            "--scheduler",
            "not a url",
            "--out",
            str(tmp_path / "batch"),
        ],
        capture_output=True,
        text=True,
        encoding="utf-8",
        timeout=120,
        check=False,
    )
    assert res.returncode == 2
    assert_one_line(res.stderr, r"--scheduler: not a url: cannot connect \(missing port number")
    assert not (tmp_path / "batch").exists()


# --- the Python API: one line naming the argument ---------------------------------------------


def _api_cases():
    from inertiafit import Design, Mounting, plan
    from inertiafit.inference.fit import fit_body
    from inertiafit.inference.observations import Observation
    from inertiafit.inference.priors import Prior, load_prior
    from inertiafit.inference.reference import reference_posterior
    from inertiafit.inference.sampler import SamplerSettings

    disk = {"inertia_se": 0.01, "gravity_moment": 12.8, "gravity_moment_se": 0.05}
    gauss = math.inf
    return {
        "inertia=None": (
            lambda: fit_body("disk-3kg", inertia=None, **disk),  # type: ignore[arg-type]
            r"^inertia: expected a number or a sequence of numbers, got None$",
        ),
        "gravity=0": (
            lambda: fit_body("disk-3kg", inertia=0.594, gravity=0, **disk),
            r"^gravity: must be positive \(m/s\^2\), got 0$",
        ),
        "chunk=0": (lambda: SamplerSettings(chunk=0), r"^chunk: expected a whole number >= 1"),
        "n_walkers=1.5": (
            lambda: SamplerSettings(n_walkers=1.5),  # type: ignore[arg-type]
            r"^n_walkers: expected a whole number >= 2, got 1\.5$",
        ),
        "Observation(scale=0)": (
            lambda: Observation(0.594, 0.0, gauss, 1),
            r"^Observation: scale: must be positive, got 0\.0$",
        ),
        "Observation(df=nan)": (
            lambda: Observation(0.594, 0.01, math.nan, 1),
            r"^Observation: df: must be positive",
        ),
        "Prior with missing keys": (
            lambda: Prior("x", {"mass": 1.0}, {"mass": 0.5}, {"mass": 2.0}),
            r"^Prior 'x': nominal: missing 'com_distance'",
        ),
        "plan(draws=0)": (
            lambda: plan(
                {"attachment": (2.91, 0.13, 0.225)},
                [Design("a", (Mounting(("attachment",)),))],
                draws=0,
            ),
            r"^draws: expected a whole number >= 2, got 0$",
        ),
        "reference_posterior(n_identified=0)": (
            lambda: reference_posterior(
                load_prior("disk-3kg"),
                Observation(0.594, 0.01, gauss, 1),
                Observation(12.8, 0.05, gauss, 1),
                n_identified=0,
            ),
            r"^n_identified: expected a whole number >= 2, got 0$",
        ),
    }


@pytest.mark.parametrize("case", list(_api_cases()))
def test_api_arguments_are_one_input_error_naming_the_argument(case):
    call, match = _api_cases()[case]
    with pytest.raises(InputError) as info:
        call()
    assert "\n" not in str(info.value)
    assert re.search(match, str(info.value)), str(info.value)


# --- messages: option names only where the library names its own argument -------------------


GRAVITY_MOMENT_PATH = (
    "/s/gravity_moment/study.toml: trials[1].file: file not found: "
    "/s/gravity_moment/data/A_240_02.csv"
)


@pytest.mark.parametrize(
    ("library", "shown"),
    [
        ("mass: needs its SD mass_sd too", "--mass: needs its SD --mass-sd too"),
        (
            "inertia_sd and inertia_n describe one mean; give one inertia value",
            "--inertia-sd and --inertia-n describe one mean; give one inertia value",
        ),
        ("out: /a/hdi_prob/x exists", "--out: /a/hdi_prob/x exists"),
        (GRAVITY_MOMENT_PATH, GRAVITY_MOMENT_PATH),
        (
            "/s/study.toml: bodies.attachment.com_distance.sd: must be positive (m), got -1",
            "/s/study.toml: bodies.attachment.com_distance.sd: must be positive (m), got -1",
        ),
        ("design.toml: trials_per_speed: expected", "design.toml: trials_per_speed: expected"),
    ],
)
def test_only_a_leading_argument_and_whole_names_become_options(library, shown):
    assert _as_options(library, build_parser()) == shown


def test_a_path_holding_an_argument_name_is_shown_as_it_is(study, tmp_path):
    folder = copy_study(study, tmp_path / "gravity_moment")
    missing = min((folder / "data").glob("*_240_02.csv"))
    missing.unlink()
    code, err = run_cli(["run", str(folder / "study.toml"), "--out", str(tmp_path / "o")])
    assert code == 2
    assert_one_line(err, re.escape(f"file not found: {missing}"))
    assert "--gravity-moment" not in err


def test_a_manifest_key_holding_an_argument_name_is_shown_as_it_is(study, tmp_path):
    folder = copy_study(study, tmp_path)
    manifest = folder / "study.toml"
    text = manifest.read_text(encoding="utf-8")
    assert "[bodies.attachment]\n" in text
    manifest.write_text(
        text.replace(
            "[bodies.attachment]\n",
            "[bodies.attachment]\ncom_distance = { value = 0.2, sd = -1 }\n",
        )
    )
    code, err = run_cli(["run", str(manifest), "--out", str(tmp_path / "o")])
    assert code == 2
    assert_one_line(err, r"study\.toml: bodies\.attachment\.com_distance\.sd: must be positive")
    assert "--com-distance" not in err


def test_torque_sign_advice_never_repeats_what_is_set(study, tmp_path):
    folder = copy_study(study, tmp_path)
    manifest = folder / "study.toml"
    text = manifest.read_text(encoding="utf-8")
    name = min((folder / "data").glob("*_240_01.csv")).name
    block = f'file = "data/{name}"\n'
    assert text.count(block) == 1
    manifest.write_text(text.replace(block, block + "torque_sign = -1.0\n"))
    code, err = run_cli(["run", str(manifest), "--out", str(tmp_path / "o")])
    assert code == 2
    assert_one_line(
        err, rf"{name}: torque: inertia -0\.\d+ kg m\^2 is negative", r"torque_sign = 1"
    )
    assert "set torque_sign = -1" not in err


def test_a_manifest_with_a_byte_order_mark_is_read(study, tmp_path):
    folder = copy_study(study, tmp_path)
    manifest = folder / "study.toml"
    plain = load_study(manifest)
    manifest.write_bytes(b"\xef\xbb\xbf" + manifest.read_bytes())
    marked = load_study(manifest)
    assert [t.file for t in marked.trials] == [t.file for t in plain.trials]
    assert marked.bodies == plain.bodies
    # and through the command line: an error is about the manifest's content, not its first byte
    manifest.write_bytes(manifest.read_bytes().replace(b'kind = "fast"', b'kind = "quick"', 1))
    code, err = run_cli(["run", str(manifest), "--out", str(tmp_path / "o")])
    assert code == 2
    assert_one_line(err, r"kind")
    assert "Invalid statement" not in err


def test_a_file_that_is_not_a_trial_is_never_echoed(study, tmp_path):
    folder = copy_study(study, tmp_path)
    secret = tmp_path / "elsewhere" / "notes.txt"
    secret.parent.mkdir()
    secret.write_text("SECRET root:x:0:0:root:/root\nsecond line\n")
    manifest = folder / "study.toml"
    name = min((folder / "data").glob("*_240_01.csv")).name
    manifest.write_text(
        manifest.read_text(encoding="utf-8").replace(f"data/{name}", secret.as_posix())
    )
    code, err = run_cli(["run", str(manifest), "--out", str(tmp_path / "o")])
    assert code == 2
    assert_one_line(err, re.escape(str(secret)), "is it a trial file")
    assert "SECRET" not in err
    assert "root:" not in err


# --- property: no argument value ever gives a traceback ----------------------------------------

VALUES = st.one_of(
    st.integers(min_value=-(2**70), max_value=2**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=12),
)


@given(seed=VALUES, gravity=VALUES, hdi_prob=VALUES)
def test_no_value_of_seed_gravity_or_hdi_prob_gives_a_traceback(seed, gravity, hdi_prob):
    # The prior does not exist: a run whose arguments all pass stops there, before any work.
    argv = [*FIT[:2], "no-such-prior", *FIT[3:]]
    argv += [
        f"--seed={seed}",
        f"--gravity={gravity}",
        f"--hdi-prob={hdi_prob}",
        "--out=/nonexistent/o",
    ]
    code, err = run_cli(argv)
    assert code == 2
    assert_one_line(err)
    # the first bad value is named, else the prior is
    named = re.match(r"inertiafit: error: (--[\w-]+|prior)", err)
    assert named, err


def test_a_reader_that_goes_away_is_no_traceback():
    # `inertiafit priors | head -1`: stdout closed before the command writes
    proc = subprocess.Popen(
        [sys.executable, "-m", "inertiafit.cli", "priors"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        encoding="utf-8",
    )
    assert proc.stdout is not None
    proc.stdout.close()
    _, err = proc.communicate(timeout=120)
    assert err == ""
    assert proc.returncode == 1
