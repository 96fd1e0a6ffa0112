"""The extension recipes of docs/architecture.md ("Where new things go"), followed literally
(issue 35, item 5): a trial format, a kind of trial, a manifest table, a figure, a report section
and a command,
each a toy extension defined here, registered as its recipe says, run from its input to the
output it makes, and unregistered after its test (monkeypatch), so that the other tests see
the registries as they were. The likelihood term's recipe is held by test_recipe_term.py and
the export format's by test_export_registry.py.

Every test is cheap: the studies are conftest's ``study_out`` study (copied, processed without
sampling) and the results folders its ``disk_fit`` (copied where changed).
"""

from __future__ import annotations

import argparse
import base64
import functools
import html
import re
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import pytest

from inertiafit import cli
from inertiafit._checks import check_probability
from inertiafit.errors import InputError
from inertiafit.formatting import number
from inertiafit.io import load_study
from inertiafit.io.outputs import MARKER, check_out, guard_outputs, output_folder, write_csv
from inertiafit.io.readers.registry import BINARY_FORMATS, READERS, register_reader
from inertiafit.io.readers.tables import load_table
from inertiafit.io.readers.validation import reject_calibration
from inertiafit.io.sections import SECTIONS, Section, register_section
from inertiafit.io.sections import trials as trial_section
from inertiafit.io.sections.base import as_table, check_keys, number_within
from inertiafit.io.trial import make_trial
from inertiafit.io.units import QUANTITIES, to_si
from inertiafit.plotting.style import PALETTE, axis_label, figure_width, new_figure, style_context
from inertiafit.posterior import open_posterior
from inertiafit.processing.kinds import KINDS, Stage, register_kind
from inertiafit.processing.study import process_study
from inertiafit.processing.trials import trial_row
from inertiafit.report.figures import FIGURES, FigureRecord, register_figure
from inertiafit.report.html import (
    REPORT_SECTIONS,
    PageContext,
    ReportSection,
    register_report_section,
)

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

    from inertiafit.io import TrialSpec
    from inertiafit.posterior import Posterior
    from inertiafit.report.result import Result


def _study(study_out: Path, tmp_path: Path) -> Path:
    """A copy of ``study_out``'s simulated study (two conditions, CSV trials): its manifest."""
    folder = tmp_path / "study"
    shutil.copytree(study_out.parent / "study", folder)
    return folder / "study.toml"


def _results(disk_fit: Path, tmp_path: Path) -> Path:
    """A copy of ``disk_fit``'s results folder (``inertiafit fit`` on the paper's disk)."""
    folder = tmp_path / "fit"
    shutil.copytree(disk_fit, folder)
    return folder


# -- A trial format ------------------------------------------------------------------------------
# Step 1: one function decorated by @register_reader("toy") (registered in the fixture below, so
# that it is removed after the test), returning make_trial(...) in SI units, InputError for
# what it cannot read, its table read through io.readers.tables. The toy format: a lab's export
# with ';' between fields, a decimal comma, its own header and units, and a torque gain option.

TOY_COLUMNS = {"time": "t_ms", "angle": "pos_deg", "velocity": "vel_dps", "torque": "moment_Nm"}
TOY_UNITS = {"time": "ms", "angle": "deg", "velocity": "deg/s", "torque": "N*m"}


def read_toy(path, *, columns=None, units=None, calibration=None, gain=1.0) -> xr.Dataset:
    """A toy export: ``;``-separated, decimal comma, ms/deg/deg/s/N m, torque times ``gain``."""
    reject_calibration(path, calibration, "toy")
    if columns or units:
        raise InputError(f"{path}: the toy format names its own columns and units")
    if isinstance(gain, bool) or not isinstance(gain, int | float) or not gain > 0:
        raise InputError(f"{path}: option gain must be a positive number, got {gain!r}")
    values, lines = load_table(path, TOY_COLUMNS, delimiter=";", decimal=",")
    si = [
        to_si(values[q] * (gain if q == "torque" else 1.0), q, TOY_UNITS[q], where=f"{path}: {q}")
        for q in QUANTITIES
    ]
    return make_trial(*si, source=str(path), format="toy", columns=TOY_COLUMNS, lines=lines)


@pytest.fixture
def toy_reader():
    register_reader("toy")(read_toy)
    yield "toy"
    READERS.pop("toy", None)
    BINARY_FORMATS.discard("toy")


def _as_toy(csv: Path, gain: float) -> Path:
    """A simulated CSV trial (s, deg, deg/s, N m) written in the toy format."""
    table = pd.read_csv(csv)
    toy = pd.DataFrame(
        {
            TOY_COLUMNS["time"]: table["time"] * 1000.0,
            TOY_COLUMNS["angle"]: table["angle"],
            TOY_COLUMNS["velocity"]: table["velocity"],
            TOY_COLUMNS["torque"]: table["torque"] / gain,
        }
    )
    path = csv.with_suffix(".toy")
    toy.to_csv(path, sep=";", decimal=",", index=False, lineterminator="\n")
    return path


def test_a_trial_format_added_by_the_recipe_reads_a_study(toy_reader, study_out, tmp_path):
    manifest = _study(study_out, tmp_path)
    head, *entries = manifest.read_text(encoding="utf-8").split("\n[[trials]]\n")
    kept = [e for e in entries if 'bodies = ["attachment"]\n' in e]  # one condition's, fewer
    text = "\n[[trials]]\n".join([head, *kept])
    manifest.write_text(text, encoding="utf-8")
    assert 'units = { time = "s", angle = "deg", velocity = "deg/s", torque = "N*m" }' in text
    for csv in sorted((manifest.parent / "data").glob("A_*.csv")):
        _as_toy(csv, gain=2.0)
    # step 3's manifest: the format and its option in [defaults], each trial's file its .toy
    defaults = 'format = "toy"\noptions = { gain = 2.0 }\n'
    toy_text = re.sub(r"(?m)^(columns|units) = \{.*\}\n", "", text, count=2)
    toy_text = toy_text.replace("[defaults]\n", f"[defaults]\n{defaults}", 1)
    toy_manifest = manifest.with_name("toy.toml")
    toy_manifest.write_text(toy_text.replace('.csv"', '.toy"'), encoding="utf-8")

    as_csv, as_toy = process_study(manifest), process_study(toy_manifest)
    assert list(as_toy.trials["file"]) == [f.replace(".csv", ".toy") for f in as_csv.trials.file]
    assert len(as_toy.trials) == len(as_csv.trials) == len(kept) > 4
    for column in ("inertia", "inertia_se", "gravity_moment", "gravity_phase", "offset"):
        np.testing.assert_allclose(as_toy.trials[column], as_csv.trials[column], rtol=1e-9)
    reader = as_toy.provenance[0]["reader"]
    assert reader["format"] == "toy"
    assert reader["options"] == {"gain": 2.0}

    # the reader's own errors reach the study as one line naming the file
    first = next(iter(sorted((manifest.parent / "data").glob("*.toy"))))
    first.write_text(first.read_text(encoding="utf-8").replace("pos_deg", "angle"), "utf-8")
    with pytest.raises(InputError, match=re.escape(str(first))):
        process_study(toy_manifest)


def test_without_its_registration_the_toy_format_is_unknown(tmp_path):
    (tmp_path / "a.toy").write_text("t_ms;pos_deg;vel_dps;moment_Nm\n", encoding="utf-8")
    manifest = tmp_path / "study.toml"
    manifest.write_text(
        '[bodies.attachment]\nprior = "biodex-elbow-attachment"\n\n[[trials]]\nfile = "a.toy"\n'
        'bodies = ["attachment"]\nkind = "quasi-static"\nformat = "toy"\n',
        encoding="utf-8",
    )
    assert "toy" not in READERS  # the fixture of the test above removed it
    with pytest.raises(InputError, match=r"trials\[0\]\.format: unknown trial format 'toy'"):
        load_study(manifest)


# -- A kind of trial -------------------------------------------------------------------------
# Step 1: a class with `name`, `read(stage, spec, ds)` and `after_gravity(stage, trials)`,
# registered with register_kind (here through monkeypatch, so that it is removed); step 2: its
# name in io.sections.trials.KINDS. The toy kind: a "check" of a condition's gravity model on
# any recording of it, the RMS of the torque less the model once the model is known.


class GravityCheck:
    """``kind = "check"``: the torque of a recording against its condition's gravity model."""

    name = "check"

    def read(self, stage: Stage, spec: TrialSpec, ds: xr.Dataset) -> None:
        """Its row, with the samples it has; no fit of its own."""
        row = trial_row(stage.study, spec, reader=stage.run.reader_flags(spec))
        row["n_window"] = ds.sizes["time"]
        stage.rows[spec.index] = row

    def after_gravity(self, stage: Stage, trials: list[tuple[TrialSpec, xr.Dataset]]) -> None:
        """Each check's residual RMS against its condition's gravity model."""
        for spec, ds in trials:
            fit = stage.gravity[spec.condition]
            model = fit.gravity_moment * np.sin(ds["angle"].values + fit.gravity_phase)
            left = ds["torque"].values - model - fit.offset
            stage.rows[spec.index]["residual_rms"] = float(np.sqrt(np.mean(left**2)))


@pytest.fixture
def check_kind(monkeypatch):
    monkeypatch.setattr(trial_section, "KINDS", (*trial_section.KINDS, "check"))
    register_kind(GravityCheck())
    yield "check"
    KINDS.pop("check", None)


def test_a_kind_of_trial_added_by_the_recipe_is_processed(check_kind, study_out, tmp_path):
    manifest = _study(study_out, tmp_path)
    plain = process_study(manifest)
    trials = plain.trials.set_index("file")
    sweep = trials.index[trials["kind"] == "quasi-static"][0]
    fast = trials.index[trials["kind"] == "fast"][0]
    copies = []
    for file in (sweep, fast):  # each recording counts once: the second half of each, checked
        copy = str(Path(file).with_name(f"check-{Path(file).name}"))
        table = pd.read_csv(manifest.parent / file, dtype=str)
        table.iloc[len(table) // 2 :].to_csv(manifest.parent / copy, index=False)
        body = '", "'.join(trials.loc[file, "condition"].split("+"))
        manifest.write_text(
            manifest.read_text(encoding="utf-8")
            + f'\n[[trials]]\nfile = "{copy}"\nbodies = ["{body}"]\nkind = "{check_kind}"\n',
            encoding="utf-8",
        )
        copies.append(copy)
    processed = process_study(manifest)
    checks = processed.trials[processed.trials["kind"] == check_kind]
    assert list(checks["file"]) == copies
    checks = checks.set_index(pd.Index([sweep, fast]))
    assert (checks["status"] == "ok").all()
    # the first pass gave each its row, the second its residual against the gravity model
    assert checks.loc[sweep, "n_window"] > 0.4 * trials.loc[sweep, "n_window"] > 0
    # half a sweep leaves the noise the model's own fit left; a fast move, its I alpha too
    assert checks.loc[sweep, "residual_rms"] == pytest.approx(
        trials.loc[sweep, "residual_rms"], rel=0.1
    )
    assert checks.loc[fast, "residual_rms"] > 5 * checks.loc[sweep, "residual_rms"]
    # and the rest of the study is as it was without them
    others = processed.trials[processed.trials["kind"] != check_kind].reset_index(drop=True)
    pd.testing.assert_frame_equal(others, plain.trials.reset_index(drop=True))


def test_the_manifest_names_the_kinds_it_has(check_kind, tmp_path):
    # a kind in io.sections.trials.KINDS is in the message of a kind it does not have
    (tmp_path / "a.csv").write_text("time,angle,velocity,torque\n", encoding="utf-8")
    manifest = tmp_path / "study.toml"
    manifest.write_text(
        '[bodies.attachment]\nprior = "biodex-elbow-attachment"\n\n[[trials]]\nfile = "a.csv"\n'
        'bodies = ["attachment"]\nkind = "tare"\n',
        encoding="utf-8",
    )
    kinds = '"quasi-static", "fast", "rest", "mvc" or "check"'
    with pytest.raises(InputError, match=re.escape(f"kind: expected {kinds}, got 'tare'")):
        load_study(manifest)


# -- A manifest table --------------------------------------------------------------------------
# A reader read(value, context) checking its own keys with io.sections.base's helpers,
# registered with register_section(Section(name, read, order=...)) (here with the registry
# restored after the test); load_study allows its key and keeps its value in
# Study.sections[name]. The toy table: [room], the temperature and humidity the trials were
# recorded at.


def read_room(value: object, context) -> dict[str, float] | None:
    """``[room]``: ``temperature`` (deg C) and, optionally, ``humidity`` (%)."""
    if value is None:
        return None
    where = f"{context.where}: room"
    table = as_table(value, where=where, what="temperature = deg C, humidity = %")
    check_keys(table, ("temperature", "humidity"), where=where)
    if "temperature" not in table:
        raise InputError(f"{where}.temperature: missing (deg C)")
    assert "bodies" in context.read  # read after [bodies] (its order), as asked
    out = {"temperature": number_within(table["temperature"], f"{where}.temperature",
                                        (-10.0, 50.0), "deg C", what="a temperature in deg C",
                                        hint=" (in K?)")}  # fmt: skip
    if "humidity" in table:
        out["humidity"] = number_within(table["humidity"], f"{where}.humidity", (0.0, 100.0),
                                        "%", what="a relative humidity in %", hint="")  # fmt: skip
    return out


@pytest.fixture
def room():
    before = dict(SECTIONS)
    register_section(Section("room", read_room, order=50))
    yield "room"
    SECTIONS.clear()
    SECTIONS.update(before)


def test_a_manifest_table_added_by_the_recipe_reaches_the_study(room, study_out, tmp_path):
    manifest = _study(study_out, tmp_path)
    text = manifest.read_text(encoding="utf-8")
    names = list(SECTIONS)
    assert names.index("bodies") < names.index(room) < names.index("trials")
    manifest.write_text(f"{text}\n[room]\ntemperature = 21.5\nhumidity = 40\n", encoding="utf-8")
    processed = process_study(manifest)
    assert processed.study.sections[room] == {"temperature": 21.5, "humidity": 40.0}
    assert len(processed.trials) == text.count("[[trials]]")  # the rest read as before

    for table, message in (
        ("temperature = 294.6", r"room\.temperature: expected -10 to 50 deg C, got 294\.6 \(in K"),
        ('temperature = "warm"', r"room\.temperature: expected a temperature in deg C, got 'wa"),
        ("humidity = 40", r"room\.temperature: missing"),
        ("temperature = 20\nwind = 2", r"room\.wind: unknown key \(allowed: temperature, humid"),
    ):
        manifest.write_text(f"{text}\n[room]\n{table}\n", encoding="utf-8")
        with pytest.raises(InputError, match=message):
            load_study(manifest)


# -- A figure ----------------------------------------------------------------------------------
# Step 1: a function that takes a Posterior and returns a Matplotlib Figure without touching
# global state, styled through plotting.style; step 2: a function giving its FigureRecords of a
# result, registered with register_figure (in the fixture below, so that it is removed after
# the test): write_outputs saves every record, report.html shows each under its section.


def plot_mass_draws(posterior: Posterior, body: str, *, width="single") -> Figure:
    """A histogram of a body's posterior draws of the mass."""
    with style_context():
        fig = new_figure(None, (figure_width(width), 2.0))
        ax = fig.add_subplot()
        ax.hist(posterior.draws(body, "mass").reshape(-1), bins=30, color=PALETTE[0])
        ax.set_xlabel(axis_label("mass", body))
        ax.set_ylabel("draws")
    return fig


def mass_draws_figures(result: Result) -> list[FigureRecord]:
    """The toy's records of a result: one per body, in the "Diagnostics" section."""
    post = result.posterior
    return [
        FigureRecord(
            f"mass-draws-{body}",
            functools.partial(plot_mass_draws, post, body),
            "Diagnostics",
            f"{body}: the posterior draws of the mass",
        )
        for body in post.bodies
    ]


@pytest.fixture
def mass_draws():
    register_figure("mass-draws")(mass_draws_figures)
    yield "mass-draws"
    FIGURES.pop("mass-draws", None)


def test_a_figure_added_by_the_recipe_is_saved_and_shown(mass_draws, disk_fit, tmp_path):
    import matplotlib.pyplot as plt

    folder = _results(disk_fit, tmp_path)
    post = open_posterior(folder / "posterior.nc")
    open_figures = plt.get_fignums()
    assert plot_mass_draws(post, post.bodies[0]).axes[0].get_xlabel()
    assert plt.get_fignums() == open_figures  # no global state
    with pytest.raises(ValueError, match="registered already"):
        register_figure(mass_draws)(mass_draws_figures)

    assert cli.main(["report", str(folder), "--formats", "png"]) == 0
    (body,) = post.bodies
    stem, caption = f"mass-draws-{body}", html.escape(f"{body}: the posterior draws of the mass")
    png = (folder / f"{stem}.png").read_bytes()
    assert png[:4] == b"\x89PNG"
    page = (folder / "report.html").read_text(encoding="utf-8")
    assert f"<img alt='{caption}'" in page
    assert base64.b64encode(png).decode("ascii") in page  # the very file, embedded
    assert page.index(">Diagnostics</h2>") < page.index(caption)  # under its section,
    assert page.index(html.escape(f"{body}: rank plots")) < page.index(caption)  # registered last
    assert caption not in (disk_fit / "report.html").read_text(encoding="utf-8")  # control


def test_the_toy_figure_is_gone_after_its_test():
    assert "mass-draws" not in FIGURES


# -- A report section --------------------------------------------------------------------------
# A builder that takes the page's PageContext (the result, the HDI's probability, the figures)
# and returns the section's items, or None when the section does not apply to this result; one
# ReportSection (its anchor, heading, builder and order) registered with
# register_report_section (here with the registry restored after the test): report.html shows
# it where its order puts it, and its table of contents links to it. The toy sections: each
# body's posterior mass, after the "Posterior" section, and the number of trials, which a fit
# from reported numbers (no trials) leaves out.


def mass_items(page: PageContext) -> list:
    """Each body's posterior median mass, in a table."""
    post = page.posterior
    medians = [float(np.median(post.draws(body, "mass"))) for body in post.bodies]
    return [
        "Each body's posterior median mass:",
        pd.DataFrame({"body": post.bodies, "median mass (kg)": medians}),
    ]


def trial_count_items(page: PageContext) -> list | None:
    """How many trials the study read; ``None`` (no section) for a fit without trials."""
    if not len(page.result.trials):
        return None
    return [f"{len(page.result.trials)} trials."]


@pytest.fixture
def toy_sections():
    before = dict(REPORT_SECTIONS)
    register_report_section(ReportSection("body-masses", "Body masses", mass_items, order=25))
    register_report_section(ReportSection("trial-count", "Trial count", trial_count_items))
    yield "body-masses", "trial-count"
    REPORT_SECTIONS.clear()
    REPORT_SECTIONS.update(before)


def test_a_report_section_added_by_the_recipe_is_shown(toy_sections, disk_fit, tmp_path):
    folder = _results(disk_fit, tmp_path)
    assert cli.main(["report", str(folder), "--formats", "png"]) == 0
    page = (folder / "report.html").read_text(encoding="utf-8")
    contents = page[page.index("<nav class='toc'") : page.index("</nav>")]
    assert "<li><a href='#body-masses'>Body masses</a></li>" in contents
    assert "<h2 id='body-masses'>Body masses</h2>" in page
    post = open_posterior(folder / "posterior.nc")
    body = post.bodies[0]
    shown = number(float(np.median(post.draws(body, "mass"))))
    # where its order puts it, after "Posterior" and before "What pins what", with its table
    section = page[page.index("<h2 id='body-masses'>") : page.index("<h2 id='what-pins-what'>")]
    assert page.index("<h2 id='posterior'>") < page.index("<h2 id='body-masses'>")
    assert f"{html.escape(body)}</td><td>{shown}</td>" in section
    assert "Body masses" not in (disk_fit / "report.html").read_text(encoding="utf-8")  # control


def test_a_report_section_that_does_not_apply_leaves_no_heading(toy_sections, disk_fit, tmp_path):
    folder = _results(disk_fit, tmp_path)
    assert cli.main(["report", str(folder), "--formats", "png"]) == 0
    page = (folder / "report.html").read_text(encoding="utf-8")
    assert "Trial count" not in page  # neither a heading nor a line in the contents
    assert "trial-count" not in page
    assert "<h2 id='body-masses'>" in page  # the page's other sections as they were


def test_the_toy_report_sections_are_gone_after_their_test():
    assert "body-masses" not in REPORT_SECTIONS
    assert "trial-count" not in REPORT_SECTIONS


# -- A command ---------------------------------------------------------------------------------
# Step 1: a function decorated with guard_outputs that first calls check_out(out, inputs=...),
# then reads its inputs and writes through output_folder; step 2: one cli.Command block
# registered with cli.register_command (in the fixture below, so that it is removed after the
# test) whose handler only calls it. The toy command: `inertiafit masses DIR --out OUT`, each
# body's posterior mass (median and central interval) as masses.csv.


@guard_outputs
def run_masses(folder: str | Path, *, out: str | Path, hdi_prob: float = 0.95) -> Path:
    """Each body's posterior median mass and central ``hdi_prob`` interval, as masses.csv."""
    hdi_prob = check_probability(hdi_prob, "hdi_prob")
    folder = Path(folder)
    check_out(out, inputs=[folder])
    post = open_posterior(folder / "posterior.nc")
    tail = (1 - hdi_prob) / 2
    rows = []
    for body in post.bodies:
        mass = post.draws(body, "mass").reshape(-1)
        lo, mid, hi = np.quantile(mass, [tail, 0.5, 1 - tail])
        rows.append({"body": body, "median": mid, "lower": lo, "upper": hi})
    with output_folder(out) as tmp:
        write_csv(pd.DataFrame(rows), tmp / "masses.csv")
    return Path(out)


class Masses(cli.Command):
    name = "masses"
    help = "each body's posterior mass from a results folder"

    @staticmethod
    def arguments(p: argparse.ArgumentParser) -> None:
        p.add_argument("folder", type=Path, metavar="DIR", help="an output folder")
        cli.add_out(p, None)
        cli.add_hdi_prob(p)

    @staticmethod
    def run(args: argparse.Namespace) -> int:
        run_masses(args.folder, out=args.out, hdi_prob=args.hdi_prob)
        return 0


@pytest.fixture
def masses():
    cli.register_command(Masses)
    yield Masses.name
    cli.COMMANDS.pop(Masses.name, None)


def test_a_command_added_by_the_recipe_runs_from_main(masses, disk_fit, tmp_path, capsys):
    assert masses in cli.build_parser().format_help()
    out = tmp_path / "masses"
    assert cli.main([masses, str(disk_fit), "--out", str(out), "--hdi-prob", "0.9"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted([MARKER, "masses.csv"])
    table = pd.read_csv(out / "masses.csv").set_index("body")
    post = open_posterior(disk_fit / "posterior.nc")
    mass = post.draws(post.bodies[0], "mass").reshape(-1)
    row = table.loc[post.bodies[0]]
    assert row["median"] == pytest.approx(np.median(mass), rel=1e-7)
    assert (row["lower"], row["upper"]) == pytest.approx(np.quantile(mass, [0.05, 0.95]), rel=1e-7)

    # its arguments checked before any work, in the command line's words, and its out folder
    capsys.readouterr()
    assert cli.main([masses, str(disk_fit), "--out", str(tmp_path / "no"), "--hdi-prob", "2"]) == 2
    assert capsys.readouterr().err.startswith("inertiafit: error: --hdi-prob: expected a prob")
    assert not (tmp_path / "no").exists()
    assert cli.main([masses, str(disk_fit), "--out", str(disk_fit)]) == 2
    assert "inertiafit: error: --out: " in capsys.readouterr().err
    assert "masses.csv" not in {p.name for p in disk_fit.iterdir()}


def test_the_toy_command_is_gone_after_its_test():
    assert "masses" not in cli.COMMANDS
