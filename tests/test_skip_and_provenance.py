"""A study survives a bad trial (``on_trial_error = "skip"``), and its inputs are on record."""

import hashlib
import json
import re
import shutil

import pandas as pd
import pytest
from cases import PRIORS, TRUTH

import inertiafit.io.sections.trials as trials_module  # where a trial file is read
from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.inference.evidence import condition_evidence
from inertiafit.io import load_study
from inertiafit.io.outputs import MARKER
from inertiafit.pipeline.redraw import load_result
from inertiafit.posterior import open_posterior
from inertiafit.processing.study import TRIAL_COLUMNS, process_study
from inertiafit.simulate import simulate_study

FLAG = "velocity sign flipped to match d(angle)/dt"


@pytest.fixture(scope="module")
def clean_study(tmp_path_factory):
    """Two conditions, each one quasi-static trial (22 s) and three fast trials at 240 deg/s."""
    folder = tmp_path_factory.mktemp("skip") / "study"
    simulate_study(
        folder,
        bodies=TRUTH,
        conditions=[("attachment",), ("attachment", "weight")],
        speeds=(240,),
        trials_per_speed=3,
        quasi_static_speed=4.0,
        seed=7,
        phi=0.2,
        offset=1.5,
        priors=PRIORS,
    )
    return folder


def _copy(clean_study, tmp_path, policy=None):
    folder = tmp_path / "study"
    shutil.copytree(clean_study, folder)
    if policy is not None:
        manifest = folder / "study.toml"
        manifest.write_text(
            f'on_trial_error = "{policy}"\n' + manifest.read_text(encoding="utf-8")
        )
    return folder


def _truncate(path, rows=4):
    path.write_text("\n".join(path.read_text(encoding="utf-8").splitlines()[: rows + 1]) + "\n")


def _edit_csv(path, func):
    func(pd.read_csv(path)).to_csv(path, index=False)


CORRUPT = {  # how a trial goes bad -> the reason trials.csv gives
    "truncated": (_truncate, r"^skipped: only 4 samples; a trial needs at least 10"),
    "sampling rate": (
        lambda p: _edit_csv(p, lambda f: f.iloc[::2]),
        r"^skipped: sampling rate 500 Hz differs from 1000 Hz of [AB]_",
    ),
    "no acceleration window": (
        lambda p: _edit_csv(p, lambda f: f.assign(velocity=240.0, angle=f.time * 240.0)),
        r"^skipped: .*window",
    ),
}


def test_on_trial_error_is_stop_unless_the_manifest_says_skip(clean_study, tmp_path):
    assert load_study(clean_study / "study.toml").on_trial_error == "stop"
    assert load_study(_copy(clean_study, tmp_path / "a", "skip") / "study.toml").on_trial_error
    bad = _copy(clean_study, tmp_path / "b", "ignore") / "study.toml"
    with pytest.raises(
        InputError, match=r'study\.toml: on_trial_error: expected "stop" or "skip"'
    ):
        load_study(bad)


@pytest.mark.parametrize("policy", [None, "stop"])
def test_stop_ends_the_run_at_the_bad_trial(clean_study, tmp_path, capsys, policy):
    folder = _copy(clean_study, tmp_path, policy)
    _truncate(folder / "data" / "A_240_02.csv")
    out = tmp_path / "out"
    assert main(["run", str(folder / "study.toml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert re.fullmatch(r"inertiafit: error: \S+A_240_02\.csv: only 4 samples; .*", err[-1])
    # nothing but the per-trial table gathered so far, the trial at fault marked (issue 21)
    assert sorted(p.name for p in out.iterdir()) == [".inertiafit-output", "diagnostics.csv"]
    table = pd.read_csv(out / "diagnostics.csv").set_index("file")
    assert table.loc["data/A_240_02.csv", "status"] == "refused"
    assert table.loc["data/A_240_02.csv", "cause"].startswith("only 4 samples; ")
    assert table.status.value_counts().to_dict() == {"not reached": 7, "refused": 1}  # reading


@pytest.mark.parametrize("case", list(CORRUPT))
def test_skip_leaves_out_the_bad_trial_only(clean_study, tmp_path, case):
    folder = _copy(clean_study, tmp_path, "skip")
    corrupt, reason = CORRUPT[case]
    corrupt(folder / "data" / "A_240_02.csv")
    processed = process_study(folder / "study.toml")
    table = processed.all_trials
    assert list(table.columns) == TRIAL_COLUMNS
    assert list(table.file) == [
        t.file.relative_to(folder).as_posix() for t in processed.study.trials
    ]
    bad = table.set_index("file").loc["data/A_240_02.csv"]
    assert bad["status"] == "skipped"
    assert re.match(reason, bad["flags"]), bad["flags"]
    assert pd.isna(bad["inertia"])
    assert (table.status == "ok").sum() == 7
    assert "data/A_240_02.csv" not in set(processed.trials.file)
    [line] = [w for w in processed.warnings if "skipped" in w]
    assert re.fullmatch(r"\S+/A_240_02\.csv: trial skipped: .+", line)
    # the evidence is the other two fast trials of the condition; the other condition keeps 3
    inertia = {c.label: c.inertia.n for c in condition_evidence(processed)}
    assert inertia == {"attachment": 2, "attachment+weight": 3}


def test_skip_of_every_fast_trial_of_a_condition_is_an_error(clean_study, tmp_path, capsys):
    folder = _copy(clean_study, tmp_path, "skip")
    for i in (1, 2, 3):
        _truncate(folder / "data" / f"A_240_0{i}.csv")
    assert main(["run", str(folder / "study.toml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert re.fullmatch(
        r"inertiafit: error: \S+study\.toml: condition 'attachment': no usable fast trial; "
        r"skipped: data/A_240_01\.csv \(only 4 samples; .*\), data/A_240_02\.csv \(.*\), "
        r"data/A_240_03\.csv \(.*\); its inertia has no evidence",
        err,
    ), err


def test_skip_of_the_only_quasi_static_trial_is_an_error(clean_study, tmp_path):
    folder = _copy(clean_study, tmp_path, "skip")
    _truncate(folder / "data" / "B_quasistatic.csv")
    with pytest.raises(InputError) as info:
        process_study(folder / "study.toml")
    message = str(info.value)
    assert "\n" not in message
    assert re.search(
        r"condition 'attachment\+weight': no usable quasi-static trial; skipped: "
        r"data/B_quasistatic\.csv \(only 4 samples; .*\); its fast trials need the gravity model",
        message,
    ), message


def test_reader_flags_reach_trials_csv_and_the_warnings(clean_study, tmp_path, monkeypatch):
    read = trials_module.read_trial

    def flagging_reader(path, **kwargs):
        trial = read(path, **kwargs)
        if path.name in ("A_240_01.csv", "B_quasistatic.csv"):
            trial.attrs["flags"] = [FLAG]
        return trial

    monkeypatch.setattr(trials_module, "read_trial", flagging_reader)
    processed = process_study(clean_study / "study.toml")
    flags = processed.trials.set_index("file")["flags"]
    assert flags["data/A_240_01.csv"].split("; ")[0] == FLAG
    assert flags["data/B_quasistatic.csv"].split("; ")[0] == FLAG
    assert (
        not flags.drop(["data/A_240_01.csv", "data/B_quasistatic.csv"])
        .str.contains("sign flipped")
        .any()
    )
    flagged = [w for w in processed.warnings if FLAG in w]
    assert len(flagged) == 2
    assert flagged[0].endswith(f"A_240_01.csv: {FLAG}")


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_skip_runs_the_study_to_the_end_with_its_inputs_on_record(
    clean_study, tmp_path, capsys, no_figures
):
    # the tables, report.html and posterior.nc are the point here
    folder = _copy(clean_study, tmp_path, "skip")
    _truncate(folder / "data" / "A_240_02.csv")
    out = tmp_path / "out"
    assert main(["run", str(folder / "study.toml"), "--out", str(out), "--formats", "png"]) == 0
    printed = capsys.readouterr().out
    assert re.search(r"warning: \S+A_240_02\.csv: trial skipped: only 4 samples", printed)

    trials = pd.read_csv(out / "trials.csv")
    assert list(trials.columns) == TRIAL_COLUMNS
    assert len(trials) == 8
    assert list(trials.status).count("skipped") == 1
    assert (
        trials.set_index("file")
        .loc["data/A_240_02.csv", "flags"]
        .startswith("skipped: only 4 samples")
    )
    effect = pd.read_csv(out / "speed_effect.csv")
    speeds = effect[effect["row"] == "speed"].set_index("condition")["n"]
    assert speeds.to_dict() == {"attachment": 2, "attachment+weight": 3}

    post = open_posterior(out / "posterior.nc")
    observed = post.tree["observed_data"]["inertia"]
    assert list(observed["inertia_condition"].values).count("attachment") == 2
    assert observed.size == 5

    html = (out / "report.html").read_text(encoding="utf-8")
    assert "<h2 id='skipped-trials'>Skipped trials</h2>" in html
    assert html.index("<h2 id='skipped-trials'>") < html.index("<h2 id='posterior'>")
    assert "1 of 8 trials could not be read or processed" in html

    provenance = json.loads(post.attrs["provenance"])
    assert provenance["on_trial_error"] == "skip"
    assert provenance["manifest"]["sha256"] == _sha256(folder / "study.toml")
    files = {t["file"]: t for t in provenance["trials"]}
    assert len(files) == 8
    for name, trial in files.items():
        assert trial["sha256"] == _sha256(folder / name), name
        assert trial["reader"]["format"] == "csv"
        assert trial["reader"]["units"]["torque"] == "N*m"
        assert trial["status"] == ("skipped" if name == "data/A_240_02.csv" else "ok")
    hashes = [provenance["manifest"]["sha256"], *(t["sha256"] for t in files.values())]
    assert len(set(hashes)) == 9  # every file its own digest
    assert provenance["priors"] == {"attachment": {"path": "inline"}, "weight": {"path": "inline"}}
    for digest in hashes:
        assert digest in html

    # `inertiafit report` redraws both from posterior.nc and trials.csv alone
    shutil.rmtree(folder)
    (out / "report.html").unlink()
    assert main(["report", str(out), "--formats", "png"]) == 0
    redrawn = (out / "report.html").read_text(encoding="utf-8")
    assert "<h2 id='skipped-trials'>Skipped trials</h2>" in redrawn
    assert all(digest in redrawn for digest in hashes)

    # a trials.csv written before the status column existed is read as every trial used,
    # one written before the lag columns with them empty
    old = trials[trials.status == "ok"].drop(columns=["status", "lag", "lag_se"])
    old.to_csv(out / "trials.csv", index=False)
    # ... in a folder of that older inertiafit, whose marker listed no files
    (out / MARKER).write_text("written by inertiafit; the whole folder is replaced on rerun\n")
    result = load_result(out)
    assert (result.trials.status == "ok").all()
    assert result.trials["lag"].isna().all()
    assert len(result.trials) == 7


@pytest.mark.parametrize("how", ["copy", "hard link"])
def test_one_recording_listed_twice_is_refused(clean_study, tmp_path, how):
    # A byte-identical copy or a hard link of a fast trial under another name would count one
    # recording twice and narrow the inertia's interval as if it were two.
    folder = _copy(clean_study, tmp_path)
    data = folder / "data"
    if how == "copy":
        shutil.copyfile(data / "A_240_02.csv", data / "A_240_09.csv")
    else:
        (data / "A_240_09.csv").hardlink_to(data / "A_240_02.csv")
    manifest = folder / "study.toml"
    manifest.write_text(
        manifest.read_text(encoding="utf-8")
        + '\n[[trials]]\nfile = "data/A_240_09.csv"\nbodies = ["attachment"]\nkind = "fast"\n'
        + "speed = 240.0\n"
    )
    with pytest.raises(
        InputError,
        match=r"A_240_09\.csv: the same recording as data/A_240_02\.csv \(identical content, "
        r"SHA-256 [0-9a-f]{12}\.\.\.\); list each recording once$",
    ):
        process_study(manifest)
    # under "skip" the second listing is left out with the reason, the first one counts once
    manifest.write_text('on_trial_error = "skip"\n' + manifest.read_text(encoding="utf-8"))
    processed = process_study(manifest)
    inertia = {c.label: c.inertia.n for c in condition_evidence(processed)}
    assert inertia == {"attachment": 3, "attachment+weight": 3}
    assert list(processed.skipped.file) == ["data/A_240_09.csv"]
