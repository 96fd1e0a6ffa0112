"""inertiafit report: redraw tables, figures and report.html from saved results."""

import concurrent.futures
import functools
import html
import json
import os
import pickle
import re
import shutil
import signal
import time

import pandas as pd
import pytest

from inertiafit.cli import main
from inertiafit.pipeline.redraw import load_result
from inertiafit.posterior import SUMMARY_COLUMNS, open_posterior
from inertiafit.processing.study import TRIAL_COLUMNS
from inertiafit.report import figures as figures_module
from inertiafit.report import outputs as outputs_module
from inertiafit.report import plots
from inertiafit.report.figures import FigureRecord, figure_records


def test_run_writes_every_output(study_out):
    trials = pd.read_csv(study_out / "trials.csv")
    assert list(trials.columns) == TRIAL_COLUMNS
    assert len(trials) == 2 + 2 * 6
    assert set(trials.condition) == {"attachment", "attachment+weight"}
    assert trials.file.iloc[0].startswith("data/")
    summary = pd.read_csv(study_out / "summary.csv")
    assert list(summary.columns) == SUMMARY_COLUMNS
    assert len(summary) == 2 * 5
    effect = pd.read_csv(study_out / "speed_effect.csv")
    assert {"condition", "speed", "n", "mean", "sd", "F", "p"} <= set(effect.columns)
    post = open_posterior(study_out / "posterior.nc")
    assert post.bodies == ("attachment", "weight")
    html = (study_out / "report.html").read_text(encoding="utf-8")
    assert html.count("data:image/png;base64,") >= 10
    assert "http://" not in html
    assert "https://" not in html  # readable offline


def test_run_writes_tables_in_three_formats_and_the_paper_figures(study_out):
    for stem in ("summary", "comparison", "speed_effect", "identification"):
        for ext in ("csv", "md", "tex"):
            assert (study_out / f"{stem}.{ext}").is_file(), f"{stem}.{ext}"
    assert r"\toprule" in (study_out / "comparison.tex").read_text(encoding="utf-8")
    for stem in (
        "corner-attachment",
        "corner-weight",
        "corner-joint",
        "identification-weight",
        "trace-weight",
        "rank-weight",
        "fast-trials-attachment",
        "inertia-by-speed",
    ):
        assert (study_out / f"{stem}.png").is_file(), stem
        assert not (study_out / f"{stem}.pdf").exists(), stem  # PDF where asked (--formats)
    comp = pd.read_csv(study_out / "comparison.csv").set_index(["body", "parameter"])
    # the disk's ideal values lie inside the posterior intervals (its rho is prior-decided)
    for p in ("mass", "com_distance", "radius_of_gyration", "inertia"):
        assert bool(comp.loc[("weight", p), "ideal_in_hdi"]), p
    assert comp.loc[("weight", "mass"), "baseline"] == pytest.approx(2.92, rel=0.03)


def missing_figures(folder, records, ext="png"):
    """Records whose file is not in ``folder`` or whose image is not in its report.html."""
    page = (folder / "report.html").read_text(encoding="utf-8")
    shown = set(re.findall(r"<img alt='([^']*)'", page))
    return [
        r.stem
        for r in records
        if not (folder / f"{r.stem}.{ext}").is_file() or html.escape(r.caption) not in shown
    ]


def test_every_registered_figure_is_written_and_shown_in_report_html(study_out, tmp_path):
    records = figure_records(load_result(study_out))
    # each figure the study has (not their number: a figure added by docs/architecture.md's
    # recipe is one more record, checked below like these): intervals, 3 corner, 2
    # identification, 6 trials (the gravity fit, per condition its fast trials and their
    # tau-alpha fits, inertia by speed), 4 diagnostics
    stems = [r.stem for r in records]
    conditions = ("attachment", "attachment+weight")
    bodies = ("attachment", "weight")
    assert {
        "intervals",
        "corner-joint",
        "gravity-fit",
        "inertia-by-speed",
        *(f"{f}-{b}" for f in ("corner", "identification", "trace", "rank") for b in bodies),
        *(f"{f}-{c}" for f in ("fast-trials", "tau-alpha") for c in conditions),
    } <= set(stems)
    assert len(set(stems)) == len(stems)
    assert missing_figures(study_out, records) == []
    page = (study_out / "report.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == len(records)
    # in the order of the sections that show them
    order = [page.index(f"<img alt='{html.escape(r.caption)}'") for r in records]
    assert order == sorted(order)
    # negative control: a record added to the registry after the folder was written is missing
    extra = FigureRecord("new-figure", lambda: None, "Diagnostics", "a new figure")
    assert missing_figures(study_out, [*records, extra]) == ["new-figure"]


def test_a_figure_registered_once_is_saved_and_embedded(study_out, tmp_path, monkeypatch):
    # one registration is all a new figure needs: the writer saves it, report.html shows it
    def with_extra(result):
        post = result.posterior
        extra = FigureRecord(
            "extra-rank",
            functools.partial(plots.plot_rank, post, post.bodies[0]),
            "Diagnostics",
            "an extra figure registered once",
        )
        return [*records_of(result)[:1], extra]  # one drawn figure besides: enough to show it

    records_of = figures_module.figure_records
    monkeypatch.setattr(outputs_module, "figure_records", with_extra)
    result = load_result(study_out)
    folder = tmp_path / "out"
    folder.mkdir()
    outputs_module.write_outputs(folder, result, save_data=False, workers=1)
    records = with_extra(result)
    assert missing_figures(folder, records) == []
    assert "an extra figure registered once" in (folder / "report.html").read_text(
        encoding="utf-8"
    )


@pytest.mark.parametrize(("running", "expected"), [(1, 2), (2, 1), (7, 1)])
def test_figures_are_drawn_in_parallel_only_on_idle_cores(
    monkeypatch, tmp_path, running, expected
):
    # two cores: alone (the kernel counts this process running) two drawing workers; with
    # another process running (the test suite's other worker), drawn in-process
    monkeypatch.setattr(outputs_module.os, "sched_getaffinity", lambda pid: {0, 1})
    loadavg = tmp_path / "loadavg"
    loadavg.write_text(f"0.52 0.41 0.30 {running}/180 9999\n")
    monkeypatch.setattr(outputs_module, "LOADAVG", loadavg)
    assert outputs_module.idle_cores() == expected
    assert outputs_module._worker_count(5, None) == expected
    assert outputs_module._worker_count(5, 2) == 2  # asked for: always
    assert outputs_module._worker_count(1, None) == 1  # one figure
    monkeypatch.setattr(outputs_module, "LOADAVG", tmp_path / "missing")
    assert outputs_module.idle_cores() == 2  # not readable: every core


def test_figures_drawn_in_worker_processes_are_the_same_files(study_out, tmp_path):
    result = load_result(study_out)
    records = [r for r in figure_records(result) if r.stem.startswith("fast-trials-")][:2]
    serial, forked = tmp_path / "serial", tmp_path / "forked"
    serial.mkdir()
    forked.mkdir()
    started = tmp_path / "started"  # workers forked before the records existed: pickled
    started.mkdir()
    one = outputs_module.draw_figures(records, serial, ("png", "pdf"), workers=1)
    two = outputs_module.draw_figures(records, forked, ("png", "pdf"), workers=2)
    with outputs_module.figure_workers(2) as pool:
        assert isinstance(pool, concurrent.futures.ProcessPoolExecutor)
        pids = {pool.submit(os.getpid).result() for _ in range(4)}
        three = outputs_module.draw_figures(records, started, ("png", "pdf"), pool=pool)
    assert os.getpid() not in pids
    assert one == two == three
    for r in records:
        for ext in ("png", "pdf"):
            want = (serial / f"{r.stem}.{ext}").read_bytes()
            assert (forked / f"{r.stem}.{ext}").read_bytes() == want
            assert (started / f"{r.stem}.{ext}").read_bytes() == want


def test_figure_workers_start_only_where_figures_would_be_drawn_in_parallel(monkeypatch):
    with outputs_module.figure_workers(1) as pool:
        assert pool is None
    monkeypatch.setattr(outputs_module, "idle_cores", lambda: 1)  # a busy machine
    with outputs_module.figure_workers() as pool:
        assert pool is None


def _pid_after(seconds):
    time.sleep(seconds)
    return os.getpid()


def test_figure_workers_leave_ctrl_c_to_the_command(capfd):
    # Ctrl-C reaches every process of the command: the workers go on (the command stops them
    # and says "interrupted" once) rather than each printing a traceback
    with outputs_module.figure_workers(2) as pool:
        pids = {f.result() for f in [pool.submit(_pid_after, 0.5) for _ in range(2)]}
        assert len(pids) == 2
        for pid in pids:
            os.kill(pid, signal.SIGINT)
        assert {f.result() for f in [pool.submit(_pid_after, 0.5) for _ in range(2)]} == pids
    err = capfd.readouterr().err
    assert "KeyboardInterrupt" not in err
    assert "Traceback" not in err


def test_every_figure_record_of_a_study_and_a_fit_pickles(study_out, disk_fit):
    # what a started pool needs: the records travel to its workers (the living joint's are
    # checked in test_living_study)
    for folder in (study_out, disk_fit):
        records = figure_records(load_result(folder))
        assert len(records) >= 4
        for r in records:
            back = pickle.loads(pickle.dumps(r))
            assert (back.stem, back.section, back.caption) == (r.stem, r.section, r.caption)


def _copy(folder, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    return copy


def _only(monkeypatch, prefix):
    """Redraw only the figures whose file stem starts with ``prefix`` (every figure is drawn by
    test_every_registered_figure_is_written_and_shown_in_report_html)."""
    every = figures_module.figure_records
    monkeypatch.setattr(
        outputs_module,
        "figure_records",
        lambda result: [r for r in every(result) if r.stem.startswith(prefix)],
    )


def test_report_redraws_without_sampling(study_out, tmp_path, capsys, monkeypatch):
    _only(monkeypatch, "corner-weight")  # the figure it deletes
    study_out = _copy(study_out, tmp_path)  # redrawn with some figures: not the shared folder
    nc = (study_out / "posterior.nc").read_bytes()
    (study_out / "corner-weight.png").unlink()
    assert main(["report", str(study_out), "--formats", "png,svg", "--hdi-prob", "0.8"]) == 0
    assert (study_out / "corner-weight.png").is_file()
    assert (
        (study_out / "corner-weight.svg").read_text(encoding="utf-8").lstrip().startswith("<?xml")
    )
    assert (study_out / "posterior.nc").read_bytes() == nc
    summary = pd.read_csv(study_out / "summary.csv")
    assert (summary.hdi_prob == 0.8).all()
    html = (study_out / "report.html").read_text(encoding="utf-8")
    assert "80% HDI" in html
    assert "redrew" in capsys.readouterr().out


def test_report_redraws_from_saved_outputs_only(study_out, tmp_path, monkeypatch):
    # the trial files are gone and the folder has moved: nothing but the outputs is read
    _only(monkeypatch, "fast-trials-")
    moved = tmp_path / "moved"
    shutil.copytree(study_out, moved)
    trials_dir = study_out.parent / "study"
    hidden = trials_dir.rename(study_out.parent / "study-hidden")
    try:
        trials_csv = (moved / "trials.csv").read_bytes()
        traces_csv = (moved / "traces.csv").read_bytes()
        for stale in moved.glob("fast-trials-*.png"):
            stale.unlink()
        assert main(["report", str(moved), "--formats", "png"]) == 0
        assert sorted(p.name for p in moved.glob("fast-trials-*.png")) == [
            "fast-trials-attachment+weight.png",
            "fast-trials-attachment.png",
        ]
        assert (moved / "trials.csv").read_bytes() == trials_csv  # data files are read only
        assert (moved / "traces.csv").read_bytes() == traces_csv
        assert "Trial traces not drawn" not in (moved / "report.html").read_text(encoding="utf-8")
        traces = pd.read_csv(moved / "traces.csv")
        assert traces.groupby("condition")["trial"].nunique().to_dict() == {
            "attachment": 6,
            "attachment+weight": 6,
        }
        # a folder without traces.csv is redrawn without the fast-trial figures, and says so
        (moved / "traces.csv").unlink()
        for stale in moved.glob("fast-trials-*.png"):
            stale.unlink()
        assert main(["report", str(moved), "--formats", "png"]) == 0
        assert not list(moved.glob("fast-trials-*.png"))
        assert "Trial traces not drawn" in (moved / "report.html").read_text(encoding="utf-8")
    finally:
        hidden.rename(trials_dir)


def test_report_without_png_files_still_embeds_every_figure(study_out, tmp_path, monkeypatch):
    # figures are drawn and let go one at a time; report.html gets a PNG of each all the same
    # (four of the fifteen figures after the intervals figure keep the test short)
    every = figures_module.figure_records
    chosen = []
    monkeypatch.setattr(
        outputs_module,
        "figure_records",
        lambda result: chosen.extend(every(result)[1::4]) or chosen,
    )
    study_out = _copy(study_out, tmp_path)
    assert main(["report", str(study_out), "--formats", "pdf"]) == 0
    html = (study_out / "report.html").read_text(encoding="utf-8")
    figures = sorted(p.stem for p in study_out.glob("*.pdf"))
    assert len(figures) == len(chosen) >= 4
    assert figures == sorted(r.stem for r in chosen)
    assert html.count("data:image/png;base64,") == len(figures)


def test_report_on_a_fit_folder(tmp_path, disk_fit):
    out = tmp_path / "fit"
    shutil.copytree(disk_fit, out)  # `fit` on DISK_FIT's numbers (conftest)
    (out / "identification-disk-3kg.png").unlink()
    before = (out / "comparison.csv").read_text(encoding="utf-8")
    assert main(["report", str(out)]) == 0
    assert (out / "report.html").is_file()
    assert (out / "identification-disk-3kg.png").is_file()
    assert (out / "comparison.csv").read_text(
        encoding="utf-8"
    ) == before  # fit's own comparison is kept


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["report", "{tmp}/nowhere"], "no such output folder"),
        (["report", "{tmp}"], "posterior file not found"),
        (["report", "{out}", "--formats", "gif"], "--formats"),
        (["report", "{out}", "--hdi-prob", "2"], "--hdi-prob"),
    ],
)
def test_report_bad_input(study_out, tmp_path, capsys, args, match):
    argv = [a.format(tmp=tmp_path, out=study_out) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert re.search(match, err), err


def test_report_rejects_a_foreign_trials_table(study_out, tmp_path, capsys):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(study_out, copy)
    pd.read_csv(copy / "trials.csv").drop(columns=["inertia"]).to_csv(copy / "trials.csv")
    assert main(["report", str(copy)]) == 2
    assert "trials.csv: column 'inertia' missing" in capsys.readouterr().err


def test_report_refuses_a_truncated_traces_table(study_out, tmp_path, capsys):
    # A traces.csv cut short keeps its columns and was redrawn without a word; the marker lists
    # the size inertiafit wrote, and report holds the data files to it.
    copy = tmp_path / "copy"
    shutil.copytree(study_out, copy)
    lines = (copy / "traces.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    (copy / "traces.csv").write_text("".join(lines[: len(lines) // 2]), encoding="utf-8")
    before = {p.name: p.read_bytes() for p in copy.iterdir() if p.is_file()}
    assert main(["report", str(copy)]) == 2
    err = capsys.readouterr().err.strip()
    assert re.fullmatch(
        r"inertiafit: error: \S+/traces\.csv: \d+ bytes where inertiafit wrote \d+: changed or "
        r"truncated since it was written; rerun the analysis to rebuild it",
        err,
    ), err
    assert {p.name: p.read_bytes() for p in copy.iterdir() if p.is_file()} == before


def test_run_writes_methods_with_the_protocol_as_run(study_out):
    md = (study_out / "methods.md").read_text(encoding="utf-8")
    result = load_result(study_out)
    assert "2 bodies (attachment and weight) in 2 conditions" in md
    assert (
        "'attachment' (attachment): 1 quasi-static trial and 3 fast trials at each of 240 and "
        "300 °/s; 'attachment+weight' (attachment and weight): 1 quasi-static trial and 3 fast "
        "trials at each of 240 and 300 °/s."
    ) in md
    provenance = json.loads(result.posterior.attrs["provenance"])
    rates = {t["sampling_rate"] for t in provenance["trials"]}
    assert rates == {1000.0}
    assert "The trials were sampled at 1000 Hz and read from csv files." in md
    assert "order 2 and cut-off 20 Hz" in md
    fast = result.trials[result.trials.kind == "fast"]
    width = 1000 * (fast.window_end - fast.window_start)
    assert f"windows lasted {width.median():.0f} ms" in md
    assert f"median {1000 * fast.lag.median():.1f} ms" in md
    summary = result.posterior.summary(0.95)
    assert f"largest R-hat {summary.r_hat.max():.3f}" in md
    bib = (study_out / "references.bib").read_text(encoding="utf-8")
    keys = re.findall(r"^@\w+\{([^,]+),", bib, flags=re.MULTILINE)
    assert set(re.findall(r"\[@(\w+)\]", md)) == set(keys)


def test_report_html_reads_at_a_glance(study_out):
    page = (study_out / "report.html").read_text(encoding="utf-8")
    # one table per condition and kind of trial (folded, after the Methods), units in the
    # headers
    trials = page[page.index("<h2 id='trial-tables'>") : page.index("<h2 id='inputs-and")]
    assert re.findall(r"<summary>([^<]*) \(\d+ trials?\)</summary>", trials) == [
        "attachment: quasi-static trials",
        "attachment: fast trials",
        "attachment+weight: quasi-static trials",
        "attachment+weight: fast trials",
    ]
    assert "I [kg m²] ± SE</th>" in trials
    assert "M_g [N m] ± SE</th>" in trials
    assert "lag [ms] ± SE</th>" in trials
    assert trials.count("<tr>") == 4 + 2 + 12  # header rows + quasi-static + fast trials
    effect = page[page.index("<h2 id='speed-effect'>") : page.index("<h2 id='diagnostics'>")]
    assert "&lt;NA&gt;" not in effect
    assert ">nan<" not in effect
    assert "mean_difference" not in effect
    assert "p_tukey" not in effect
    assert effect.count("240 vs 300") == 2
    # provenance: one line, every file folded under it
    inputs = page[page.index("<h2 id='inputs-and-provenance'>") :]
    assert inputs.startswith(
        "<h2 id='inputs-and-provenance'>Inputs and provenance</h2>\n<details><summary>14 trial files, the manifest and 2 "
        "priors"
    )
    assert inputs.index("</summary>") < inputs.index("<table>")
    assert "body(ies)" not in page
    assert "identify m x" not in page
