import re
import subprocess
import sys

import pandas as pd
import pytest
from cases import DISK_FIT

from inertiafit.cli import main
from inertiafit.pipeline.redraw import load_result
from inertiafit.posterior import SUMMARY_COLUMNS, open_posterior
from inertiafit.report.figures import figure_records

DISK = DISK_FIT


@pytest.fixture
def disk_run(disk_fit):
    """conftest's disk_fit: ``fit`` on DISK, seed 4, PNG and PDF."""
    return disk_fit


def test_fit_writes_every_output(disk_run):
    # the set `inertiafit run` writes, less the trial tables (trials, speed_effect, traces)
    figures = ["intervals", "corner", "identification-disk-3kg", "trace-disk-3kg", "rank-disk-3kg"]
    tables = ["summary", "identification", "comparison"]
    written = {p.name for p in disk_run.iterdir()}
    expected = {
        ".inertiafit-output",
        "posterior.nc",
        "report.html",
        "methods.md",
        "references.bib",
        *(f"{t}.{ext}" for t in tables for ext in ("csv", "md", "tex")),
        *(f"{f}.{ext}" for f in figures for ext in ("png", "pdf")),
    }
    assert expected <= written
    # anything more is a figure (one added by docs/architecture.md's recipe), in both formats
    records = {r.stem for r in figure_records(load_result(disk_run))}
    assert written - expected == {
        f"{r}.{ext}" for r in records - set(figures) for ext in ("png", "pdf")
    }
    s = pd.read_csv(disk_run / "summary.csv")
    assert list(s.columns) == SUMMARY_COLUMNS
    assert set(s.body) == {"disk-3kg"}
    assert list(s.parameter) == [
        "mass",
        "com_distance",
        "radius_of_gyration",
        "inertia",
        "gravity_moment",
    ]
    row = s.set_index("parameter").loc["mass"]
    # m is pinned near (M_g/g)^2/I = 2.87 kg; the 95 % HDI holds the paper's 2.90 kg
    assert row.hdi_lower < 2.90 < row.hdi_upper
    assert row.hdi_upper - row.hdi_lower < 0.3
    assert (s.r_hat < 1.01).all()
    assert (s.ess_bulk > 1000).all()
    assert (disk_run / "corner.png").read_bytes()[:4] == b"\x89PNG"
    assert (disk_run / "corner.pdf").read_bytes()[:4] == b"%PDF"


def test_netcdf_round_trip_keeps_every_group_and_the_summary(disk_run):
    post = open_posterior(disk_run / "posterior.nc")
    for group in (
        "posterior",
        "sample_stats",
        "log_likelihood",
        "observed_data",
        "prior",
        "constant_data",
    ):
        assert group in post.tree.children
    assert post.attrs["seed"] == 4
    assert post.converged
    saved = pd.read_csv(disk_run / "summary.csv")
    again = post.summary(0.95)
    pd.testing.assert_frame_equal(
        saved.drop(columns=["body", "parameter"]),
        again.drop(columns=["body", "parameter"]),
        check_exact=False,
        rtol=1e-7,
    )
    assert float(post.tree["constant_data"]["upper"].sel(body="disk-3kg", parameter="mass")) == (
        pytest.approx(4.38)
    )


@pytest.mark.reproducibility
def test_same_seed_gives_byte_identical_summary_and_fit_prints_the_table(
    tmp_path, disk_run, capsys, no_figures
):
    out = tmp_path / "again"
    assert main([*DISK, "--out", str(out), "--seed", "4"]) == 0
    assert (out / "summary.csv").read_bytes() == (disk_run / "summary.csv").read_bytes()
    capsys.readouterr()
    # another seed (and a 90 % HDI, to see it printed): other draws, other means
    other = tmp_path / "other"
    assert main([*DISK, "--out", str(other), "--seed", "5", "--hdi-prob", "0.9"]) == 0
    text = capsys.readouterr().out
    assert "90% HDI" in text
    assert "paper baseline" in text
    assert "Son et al. Table 3, estimated" in text
    assert "identified by" in text
    assert "prior (" in text
    means = [pd.read_csv(f / "summary.csv")["mean"] for f in (disk_run, other)]
    assert (means[0] != means[1]).all()


def _with(**changes):
    """DISK arguments with some options replaced (None removes an option)."""
    opts = {
        "--prior": ["disk-3kg"],
        "--inertia": ["0.594"],
        "--inertia-se": ["0.0105"],
        "--gravity-moment": ["12.8"],
        "--gravity-moment-se": ["0.05"],
    }
    for key, value in changes.items():
        opt = "--" + key.replace("_", "-")
        if value is None:
            opts.pop(opt)
        else:
            opts[opt] = value if isinstance(value, list) else [value]
    return ["fit"] + [x for k, v in opts.items() for x in (k, *v)]


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (_with(prior="no-such-prior"), "no such shipped prior"),
        (_with(inertia="abc"), "--inertia: expected a number, got 'abc'"),
        (_with(inertia="-0.5"), "--inertia.*positive"),
        (_with(inertia_se="0"), "--inertia-se: must be positive, got 0.0"),
        (_with(gravity_moment_se=None), "--gravity-moment: one value needs its standard error"),
        (_with(inertia_se=None, inertia_n="30"), "--inertia-sd and --inertia-n go together"),
        (_with(hdi_prob="1.5"), r"--hdi-prob: expected a probability in \(0, 1\)"),
        (_with(seed="x"), "--seed: expected a whole number"),
        (
            _with(inertia="0.30", inertia_se="0.003"),
            r"contains no solution.*mass upper bound 4\.38 kg is below \(M_g/g\)\^2/I = 5\.67",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(tmp_path, capsys, argv, match):
    out = tmp_path / "o"
    try:
        code = main([*argv, "--out", str(out)])
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert err.startswith("inertiafit: error: ")
    assert re.search(match, err), err
    assert not out.exists()  # nothing partial left behind


def test_malformed_prior_file_through_the_command(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[mass]\nnominal = 2\n")
    code = main([*DISK[:2], str(bad), *DISK[3:], "--out", str(tmp_path / "o")])
    assert code == 2
    assert "bad.toml" in capsys.readouterr().err


def test_out_folder_of_someone_elses_is_not_replaced(tmp_path, capsys):
    precious = tmp_path / "data"
    precious.mkdir()
    (precious / "trial.csv").write_text("1,2\n")
    assert main([*DISK, "--out", str(precious)]) == 2
    assert "not written by inertiafit" in capsys.readouterr().err
    assert (precious / "trial.csv").exists()


def test_command_is_installed_and_quiet_when_not_a_terminal(tmp_path):
    res = subprocess.run(
        [sys.executable, "-m", "inertiafit.cli", "priors"],
        capture_output=True,
        text=True,
        encoding="utf-8",
        check=True,
    )
    assert "biodex-elbow-attachment" in res.stdout
    assert res.stderr == ""


def test_run_rejects_unknown_figure_formats_before_doing_anything(tmp_path, capsys):
    assert (
        main(
            [
                "run",
                str(tmp_path / "study.toml"),
                "--formats",
                "pdf,gif",
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    assert "--formats" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("library", "shown"),
    [
        ("hdi_prob: expected a probability in (0, 1), got 2", "--hdi-prob: expected"),
        ("inertia_sd and inertia_n go together; give both", "--inertia-sd and --inertia-n go"),
        ("inertia[1]: expected a positive finite number", "--inertia[1]: expected"),
        ("out: folder x exists", "--out: folder x exists"),
        ("gravity_moment: one value needs its standard error", "--gravity-moment: one value"),
        # prose and file names stay as they are
        ("the prior box contains no solution", "the prior box contains no solution"),
        ("study.toml: trials[0].file: not found", "study.toml: trials[0].file: not found"),
    ],
)
def test_library_argument_names_are_shown_as_options(library, shown):
    from inertiafit.cli import _as_options, build_parser

    assert _as_options(library, build_parser()).startswith(shown)


def test_an_ascii_terminal_gets_escapes_not_a_traceback(monkeypatch):
    """The reports print ``·`` and ``ρ``; a terminal that cannot encode them (an ASCII locale,
    Python's UTF-8 mode off) gets their escapes. Negative control: the same stream unfixed
    raises UnicodeEncodeError, as ``run`` did in CI after writing its results."""
    import io

    from inertiafit.cli import _speak_any_terminal

    for errors in ("strict", "surrogateescape"):  # Python's default and the C locale's
        raw = io.BytesIO()
        stream = io.TextIOWrapper(raw, encoding="ascii", errors=errors)
        with pytest.raises(UnicodeEncodeError):
            print("m·x, ρ", file=stream, flush=True)
        monkeypatch.setattr(sys, "stdout", stream)
        monkeypatch.setattr(sys, "stderr", stream)
        _speak_any_terminal()
        print("m·x, ρ", file=stream, flush=True)
        assert raw.getvalue().endswith(b"m\\xb7x, \\u03c1\n")
