"""Every tutorial runs as printed, and what it says of its results holds (issue 34, item 6).

Each tutorial in ``docs/tutorials/`` (but ``population.md``, whose five minutes are
``make tutorials``: ``tests/test_tutorial_population.py``) is run once per test run, block by
block, in an empty folder, by the shared runner (``tests/tutorials.py``); the tests then check
what the page claims — the numbers it prints, against the truth it simulated or the values it
states, within the tolerance it states or the sampler's — not only that the blocks ran. A
claim is read from the page (:func:`tutorials.stated`) where the page states a number, so a
test and its page cannot drift apart.

A tutorial runs in whichever test process first asks for it and the others wait for its folder
(``once_per_run``): what the tests need of its Python objects is saved there as it runs.
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import once_per_run
from tutorials import TUTORIALS, Session, blocks, run_tutorial, stated

from inertiafit import open_posterior
from inertiafit.inference.anthropometric import segment_values
from inertiafit.io import load_study
from inertiafit.io.readers.registry import READERS
from inertiafit.io.sections.trials import TrialSpec

# Every tutorial has a test here or its own: a new page fails here until it is run too.
TESTED = {
    "choosing-priors.md",
    "corner-plots-and-intervals.md",
    "custom-trial-format.md",
    "from-published-numbers.md",
    "living-forearm.md",
    "planning.md",
    "study-from-trial-files.md",
}
OWN_TEST = {"population.md": "tests/test_tutorial_population.py", "index.md": "(no code)"}
NUMBER = r"(-?\d+(?:\.\d+)?)"
BRACKETS = rf"{NUMBER} \[{NUMBER}, {NUMBER}\]"  # median [lower, upper]


def _ran(tmp_path_factory, page: str, keep: Callable[[Session], None] | None = None) -> Session:
    """The tutorial's session, run once per test run; ``keep`` saves what tests need of it."""

    def make(folder: Path) -> None:
        session = run_tutorial(TUTORIALS / page, folder)
        if keep is not None:
            keep(session)

    folder = once_per_run(tmp_path_factory, f"tutorial-{page.removesuffix('.md')}", make)
    return Session.load(folder)


def _summary_csv(post, path: Path) -> None:
    post.summary().to_csv(path, index=False)


def _table(path: Path, *index: str) -> pd.DataFrame:
    return pd.read_csv(path).set_index(list(index))


def _toml(path: Path) -> dict:
    with path.open("rb") as f:
        return tomllib.load(f)


def _close(value: float, claimed: float, rel: float, what: str) -> None:
    assert value == pytest.approx(claimed, rel=rel), (
        f"{what}: {value:.5g}, the page says {claimed}"
    )


def _interval(row: pd.Series, claimed: list[float], rel: tuple[float, float], what: str) -> None:
    """A summary row's median and HDI against the page's ``median [lower, upper]``."""
    median, lower, upper = claimed
    _close(row["median"], median, rel[0], f"{what} median")
    _close(row["hdi_lower"], lower, rel[1], f"{what} HDI lower")
    _close(row["hdi_upper"], upper, rel[1], f"{what} HDI upper")


def test_every_tutorial_is_run():
    pages = {p.name for p in TUTORIALS.glob("*.md")}
    assert pages == TESTED | set(OWN_TEST), pages ^ (TESTED | set(OWN_TEST))
    for page in sorted(pages):
        blocks(TUTORIALS / page)  # no block of a language neither run nor shown


def test_the_runner_refuses_what_it_cannot_run(tmp_path):
    # negative controls: an unknown language, a bare fence, a code-block that names no file
    for text, expected in (
        ("```ipython\n1\n```\n", "language 'ipython' is neither run"),
        ("```\nls\n```\n", "a fence without a language"),
        ("```{code-block} toml\n:linenos:\n\na = 1\n```\n", "needs :caption: <file>"),
    ):
        page = tmp_path / "page.md"
        page.write_text(text, encoding="utf-8")
        with pytest.raises(ValueError, match=expected):
            blocks(page)
    # and a failing block fails the run, naming its line
    page.write_text("text\n\n```sh\ntrue\nfalse\necho never\n```\n", encoding="utf-8")
    with pytest.raises(AssertionError, match=r"page\.md, sh block at line 3 exited 1"):
        run_tutorial(page, tmp_path)
    ((block, said),) = Session.load(tmp_path).outputs  # kept, for the log
    assert block.line == 3
    assert "never" not in said


# --------------------------------------------------------------------- from published numbers

PUBLISHED = TUTORIALS / "from-published-numbers.md"


def _keep_published(session: Session) -> None:
    ns, folder = session.namespace, session.folder
    _summary_csv(ns["attachment"], folder / "attachment.csv")
    _summary_csv(ns["disk"], folder / "disk.csv")
    ns["disk"].identification().to_csv(folder / "disk-identification.csv", index=False)
    rho = ns["disk"].draws("disk-3kg", "radius_of_gyration")
    (folder / "disk-rho.json").write_text(json.dumps([float(rho.min()), float(rho.max())]))
    _summary_csv(ns["post"], folder / "joint.csv")


@pytest.fixture(scope="session")
def published(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, PUBLISHED.name, _keep_published)


def test_published_numbers_print_as_shown(published):
    # the paper's constants: the printed lines are the listing below the block, exactly
    assert published.output("python", 0) == blocks(PUBLISHED, "text")[0].code


def test_published_attachment_is_where_the_page_says(published):
    table = _table(published.folder / "attachment.csv", "parameter")
    for symbol, parameter in (("m", "mass"), ("x", "com_distance"), ("ρ", "radius_of_gyration")):
        _interval(table.loc[parameter], stated(PUBLISHED, rf"`{symbol}` {BRACKETS}"), (0.01, 0.03),
                  parameter)  # fmt: skip
    inertia, moment = stated(
        PUBLISHED,
        rf"come back as given: {NUMBER} \[[\d., ]+\] kg m² and {NUMBER} \[[\d., ]+\] N m",
    )
    _close(table.loc["inertia", "median"], inertia, 0.005, "I")
    _close(table.loc["gravity_moment", "median"], moment, 0.005, "M_g")
    # the physical bound the page quotes, m >= (M_g/g)^2 / I, and the posterior above it
    (bound,) = stated(PUBLISHED, rf"`m ≥ \(M_g/g\)²/I = {NUMBER}` kg")
    implied = (7.4153 / 9.81) ** 2 / 0.216  # 2.645
    assert implied == pytest.approx(bound, abs=0.01)
    assert table.loc["mass", "hdi_lower"] > bound


def test_published_disk_leaves_rho_to_its_prior(published):
    table = _table(published.folder / "disk.csv", "parameter")
    _interval(table.loc["mass"], stated(PUBLISHED, rf"`m` \({BRACKETS} kg\)"), (0.01, 0.01), "m")
    lo, hi = stated(PUBLISHED, rf"`ρ` is its prior box, {NUMBER}–{NUMBER} m")
    low, high = json.loads((published.folder / "disk-rho.json").read_text())
    assert lo <= low < lo + 0.001  # the box, filled
    assert hi - 0.001 < high <= hi
    (ratio,) = stated(PUBLISHED, rf"posterior SD / prior SD = {NUMBER}")
    ident = _table(published.folder / "disk-identification.csv", "parameter")
    assert ident.loc["radius_of_gyration", "sd_ratio"] == pytest.approx(ratio, abs=0.03)
    assert ident.loc["mass", "identified_by"] == "data"


def test_published_joint_fit_subtracts(published):
    table = _table(published.folder / "joint.csv", "body", "parameter")
    claimed = stated(PUBLISHED, rf"difference of the two conditions' \({BRACKETS} kg m²\)")
    row = table.loc[("disk", "inertia")]
    _interval(row, claimed, (0.005, 0.01), "disk I")
    _close(row["median"], 0.8227 - 0.2157, 0.005, "disk I, the difference of the means")


# -------------------------------------------------------------- corner plots and intervals

CORNER = TUTORIALS / "corner-plots-and-intervals.md"


def _keep_corner(session: Session) -> None:
    _summary_csv(session.namespace["attachment"], session.folder / "attachment.csv")


@pytest.fixture(scope="session")
def corner(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, CORNER.name, _keep_corner)


def test_corner_paragraph_reports_the_fit(corner):
    for name in ("corner-attachment.png", "corner-disk.png"):
        assert (corner.folder / name).stat().st_size > 10_000
    table = _table(corner.folder / "attachment.csv", "parameter")
    _interval(table.loc["mass"], stated(CORNER, rf"mass was {BRACKETS} kg"), (0.005, 0.01), "m")
    claimed = stated(CORNER, rf"about the joint > {BRACKETS} kg m²")
    _interval(table.loc["inertia"], claimed, (0.005, 0.01), "I")
    # converged as the page asks before quoting: r_hat <= 1.01 and ess_bulk >= 1000
    assert (table["r_hat"] <= 1.01).all()
    assert (table["ess_bulk"] >= 1000).all()
    # the disk's rho: its SD ratio as quoted, and "prior" in the table printed
    (ratio,) = stated(CORNER, rf"measurements \(posterior SD / prior SD = {NUMBER}\)")
    rows = [line.split() for line in corner.output("python", 1).splitlines()]
    (rho,) = [r for r in rows if r[0] == "radius_of_gyration"]
    assert float(rho[1]) == pytest.approx(ratio, abs=0.02)
    assert rho[2] == "prior"


# --------------------------------------------------------------------------- choosing priors

PRIORS = TUTORIALS / "choosing-priors.md"


def _keep_priors(session: Session) -> None:
    ns = session.namespace
    boxes = {
        name: {"nominal": prior.nominal, "lower": prior.lower, "upper": prior.upper}
        for name, prior in (("box", ns["forearm"]), ("file", ns["written"]))
    }
    boxes["file"]["description"] = ns["written"].description
    (session.folder / "boxes.json").write_text(json.dumps(boxes))


@pytest.fixture(scope="session")
def priors(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, PRIORS.name, _keep_priors)


def test_priors_print_as_shown(priors):
    listings = [b.code for b in blocks(PRIORS, "text")]
    assert [priors.output("python", k) for k in (1, 2)] == listings


def test_priors_table_arithmetic_holds(priors):
    # the page's worked Dempster row: m = 0.022 x 75, x = 0.682 x 0.27, rho = 0.468 x 0.27 —
    # and the package's own table gives the same row
    row = segment_values("dempster", "forearm+hand", 75.0, 0.27)
    for symbol, value in (("m", row.mass), ("x", row.com_distance), ("ρ", row.radius_of_gyration)):
        fraction, scale, result = stated(PRIORS, rf"`{symbol} = {NUMBER} × {NUMBER} = {NUMBER}`")
        assert fraction * scale == pytest.approx(result, abs=0.0005)
        assert value == pytest.approx(result, abs=0.0005), symbol
    proximal, cm, x = stated(PRIORS, rf"`{NUMBER}² = {NUMBER}² \+ {NUMBER}²`")
    assert math.hypot(cm, x) == pytest.approx(proximal, abs=0.0005)
    # the box: nominal x (1 +- spread); the file's, read back, the same but a wider radius
    boxes = json.loads((priors.folder / "boxes.json").read_text())
    box, file = boxes["box"], boxes["file"]
    for p, nominal in box["nominal"].items():
        assert (box["lower"][p], box["upper"][p]) == pytest.approx((0.7 * nominal, 1.3 * nominal))
        spread = 0.5 if p == "radius_of_gyration" else 0.3
        bounds = ((1 - spread) * nominal, (1 + spread) * nominal)
        assert (file["lower"][p], file["upper"][p]) == pytest.approx(bounds), p
    assert file["description"].startswith("Forearm + hand of subject 07")


def test_priors_de_leva_fractions_are_the_package_s():
    mass_f, mass_m, cm_f, cm_m, hand_f, hand_m = stated(
        PRIORS,
        rf"{NUMBER} % \(F\) / {NUMBER} % \(M\) of body mass with its CM at {NUMBER} % / "
        rf"{NUMBER} % of its length, the hand {NUMBER} % / {NUMBER} %",
    )
    for table, mass, cm, hand in (
        ("female", mass_f, cm_f, hand_f),
        ("male", mass_m, cm_m, hand_m),
    ):
        forearm = segment_values(f"de-leva-{table}", "forearm", 100.0, 1.0)
        assert (forearm.mass, 100 * forearm.com_distance) == pytest.approx((mass, cm))
        assert segment_values(f"de-leva-{table}", "hand", 100.0, 1.0).mass == pytest.approx(hand)


# ----------------------------------------------------------------------- custom trial format

CUSTOM = TUTORIALS / "custom-trial-format.md"


def _keep_custom(session: Session) -> None:
    ns, folder = session.namespace, session.folder
    try:  # the page registers its format in this process: read what needs it, then drop it
        study = load_study(folder / "lab" / "labtext.toml")
        formats = sorted({t.format for t in study.trials})
        (folder / "formats.json").write_text(json.dumps(formats))
        angle = float(abs(ns["trial"].angle - ns["truth"].angle).max())
        (folder / "angle-error.json").write_text(json.dumps(angle))
        _summary_csv(ns["result"].posterior, folder / "summary.csv")
        ns["result"].trials.to_csv(folder / "trials.csv", index=False)
    finally:
        READERS.pop("labtext", None)


@pytest.fixture(scope="session")
def custom(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, CUSTOM.name, _keep_custom)


def test_custom_reader_reads_the_written_file(custom):
    assert custom.output("python", 2) == blocks(CUSTOM, "text")[0].code
    assert json.loads((custom.folder / "angle-error.json").read_text()) < 1e-6  # rad
    assert "labtext" not in READERS  # not left for the other tests of this process


def test_custom_study_in_the_lab_format_finds_the_truth(custom):
    assert json.loads((custom.folder / "formats.json").read_text()) == ["labtext"]
    trials = pd.read_csv(custom.folder / "trials.csv")
    assert list(trials["file"]) == [
        "data/A_quasistatic.txt", "data/A_240_01.txt", "data/A_240_02.txt", "data/A_240_03.txt"
    ]  # fmt: skip
    truth = _toml(custom.folder / "lab" / "truth.toml")["bodies"]["attachment"]
    inertia, moment = stated(CUSTOM, rf"`I` = {NUMBER} kg m² and `M_g` = {NUMBER} N m")
    assert truth["inertia"] == pytest.approx(inertia, abs=0.00005)
    assert truth["gravity_moment"] == pytest.approx(moment, abs=0.0005)
    (tolerance,) = stated(CUSTOM, rf"the posterior medians are within {NUMBER} % of both")
    summary = _table(custom.folder / "summary.csv", "parameter")
    for p in ("inertia", "gravity_moment"):
        row = summary.loc[p]
        assert row["median"] == pytest.approx(truth[p], rel=tolerance / 100), p
        assert row["hdi_lower"] < truth[p] < row["hdi_upper"], p


# ---------------------------------------------------------------- a study from trial files

STUDY = TUTORIALS / "study-from-trial-files.md"


def _keep_study(session: Session) -> None:
    _summary_csv(session.namespace["result"].posterior, session.folder / "python-summary.csv")


@pytest.fixture(scope="session")
def study(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, STUDY.name, _keep_study)


def _as_given(spec: TrialSpec) -> tuple:
    """What a trial is, whichever way its manifest listed it."""
    return (spec.file, spec.condition, spec.kind, spec.speed, spec.posture, spec.window)


@pytest.mark.slow  # about 14 s: the whole pipeline twice, the command drawing every figure
def test_study_manifest_is_the_simulated_session(study):
    assert study.output("python", 1) == blocks(STUDY, "text")[0].code
    # the patterns list exactly the simulator's files, each as its own entry would
    written = load_study(study.folder / "session" / "elbow.toml")
    simulated = load_study(study.folder / "session" / "study.toml")
    assert sorted(map(_as_given, written.trials)) == sorted(map(_as_given, simulated.trials))
    assert len(written.trials) == 14
    assert sum(bool(t.pattern) for t in written.trials) == 12


@pytest.mark.slow
def test_study_finds_the_truth_and_records_each_file(study):
    results = study.folder / "results"
    for name in ("trials.csv", "speed_effect.csv", "summary.csv", "comparison.csv",
                 "posterior.nc", "corner-attachment.png", "corner-weight.png",
                 "fast-trials-attachment.png", "fast-trials-attachment+weight.png",
                 "inertia-by-speed.png", "report.html"):  # fmt: skip
        assert (results / name).is_file(), name
    (tolerance,) = stated(STUDY, rf"`I` and `M_g` is within {NUMBER} % of its truth")
    truth = _toml(study.folder / "session" / "truth.toml")["bodies"]
    summary = _table(results / "summary.csv", "body", "parameter")
    printed = study.output("python", -1).splitlines()
    assert len(printed) == 4
    for body in ("attachment", "weight"):
        for p in ("inertia", "gravity_moment"):
            row, true = summary.loc[(body, p)], truth[body][p]
            assert row["median"] == pytest.approx(true, rel=tolerance / 100), (body, p)
            assert row["hdi_lower"] < true < row["hdi_upper"], (body, p)
            assert any(line.split()[:2] == [body, p] and f"truth {true:.4f}" in line
                       for line in printed)  # fmt: skip
    # the command and the Python call: the same study, the same seed, the same posterior
    python = _table(study.folder / "python-summary.csv", "body", "parameter")
    assert python["median"].to_numpy() == pytest.approx(summary["median"].to_numpy(), rel=1e-6)
    # provenance: every file the patterns matched, by its own name and hash
    provenance = json.loads(open_posterior(results / "posterior.nc").attrs["provenance"])
    recorded = {t["file"]: t["sha256"] for t in provenance["trials"]}
    data = study.folder / "session" / "data"
    assert recorded == {
        f"data/{f.name}": hashlib.sha256(f.read_bytes()).hexdigest() for f in data.glob("*.csv")
    }


# ---------------------------------------------------------------------------------- planning

PLANNING = TUTORIALS / "planning.md"


@pytest.fixture(scope="session")
def planning(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, PLANNING.name)


def test_planning_design_file_is_the_example():
    # the page's design file is examples/plan-session.toml (its header comment aside)
    (saved,) = (b for b in blocks(PLANNING) if b.saved_as == "plan-session.toml")
    example = (TUTORIALS.parents[1] / "examples" / "plan-session.toml").read_text(encoding="utf-8")
    assert example.endswith(saved.code)
    assert all(line.startswith("#") for line in example.removesuffix(saved.code).splitlines())


@pytest.mark.slow  # about 20 s: four commands, the pilot study through `inertiafit run`
def test_planning_prints_the_search_shown(planning):
    listing = blocks(PLANNING, "text")[0].code.splitlines()
    printed = planning.output("sh", 0).splitlines()
    start = printed.index(listing[0])
    assert printed[start : start + len(listing)] == listing


@pytest.mark.slow
def test_planning_claims_hold_in_its_table(planning):
    plan = _table(planning.folder / "plan-output" / "plan.csv", "design", "body", "parameter")
    width, relative = plan["hdi_width"], plan["relative_width"]
    # an anthropometric prior narrows the forearm's m 2.4x and x 2.0x against the box
    mass, com = stated(PLANNING, rf"narrows the forearm's `m` {NUMBER}× and `x` {NUMBER}×")
    for p, factor in (("mass", mass), ("com_distance", com)):
        ratio = width[("box alone", "forearm", p)] / width[("de Leva prior", "forearm", p)]
        assert ratio == pytest.approx(factor, abs=0.1), p
    # no number of trials buys m; more narrow I
    ten, three = stated(
        PLANNING,
        rf"a 95 % HDI of {NUMBER} % of its value at 10 fast trials per speed, {NUMBER} % at 3",
    )
    assert 100 * relative[("box alone", "forearm", "mass")] == pytest.approx(ten, abs=1)
    assert 100 * relative[("box, 3 per speed", "forearm", "mass")] == pytest.approx(three, abs=1)
    (narrower,) = stated(PLANNING, rf"its HDI {NUMBER}× narrower at 10 per speed than at 3")
    inertia = [width[(d, "forearm", "inertia")] for d in ("box, 3 per speed", "box alone")]
    assert inertia[0] / inertia[1] == pytest.approx(narrower, abs=0.1)
    # the forearm's I, a difference of two conditions, known to +-17 % at 10 per speed
    (percent,) = stated(PLANNING, rf"is known to ±{NUMBER} % at 10 trials per speed")
    assert 100 * relative[("box alone", "forearm", "inertia")] / 2 == pytest.approx(percent, abs=1)
    assert (planning.folder / "plan.pdf").stat().st_size > 5_000  # from Python


@pytest.mark.slow
def test_planning_from_the_pilot_adds_variants(planning):
    plan = pd.read_csv(planning.folder / "pilot-plan" / "plan.csv")
    assert list(dict.fromkeys(plan["design"])) == [
        "pilot",  # the pilot's own design first, then the options' variants
        "pilot, 5 per speed",
        "pilot, 10 per speed",
        "pilot, forearm weighed",
        "pilot, forearm also at +0.05 m",
    ]
    pilot = plan[plan["design"] == "pilot"].set_index(["body", "parameter"])
    assert (pilot["trials_per_speed"] == 3).all()
    # the pilot's nominal values are its posterior means: its I near the simulated truth
    truth = _toml(planning.folder / "pilot" / "truth.toml")["bodies"]
    for body in ("attachment", "forearm"):
        nominal = pilot.loc[(body, "inertia"), "nominal"]
        assert nominal == pytest.approx(truth[body]["inertia"], rel=0.03), body


# ---------------------------------------------------------------------------- living forearm

LIVING = TUTORIALS / "living-forearm.md"


def _keep_living(session: Session) -> None:
    mean, sd = session.namespace["mean"], session.namespace["sd"]
    (session.folder / "ankle-holds.json").write_text(json.dumps([list(mean), list(sd)]))


@pytest.fixture(scope="session")
def living(tmp_path_factory) -> Session:
    return _ran(tmp_path_factory, LIVING.name, _keep_living)


@pytest.mark.slow  # about 18 s: a living study of 26 trials through `inertiafit run`
def test_living_forearm_is_an_adult_s(living):
    # de Leva's value for the subject, printed as shown; the simulated forearm near it
    assert living.output("python", 0) == blocks(LIVING, "text")[0].code
    de_leva = segment_values("de-leva-male", "forearm+hand", 78.0, 0.28)
    truth = _toml(living.folder / "forearm-study" / "truth.toml")["bodies"]["forearm"]
    assert truth["inertia"] == pytest.approx(de_leva.inertia, rel=0.15)
    inertia, below = stated(LIVING, rf"`I` = {NUMBER} kg m², {NUMBER} % below de Leva's")
    assert truth["inertia"] == pytest.approx(inertia, abs=0.00005)
    assert 100 * (1 - truth["inertia"] / de_leva.inertia) == pytest.approx(below, abs=0.5)


@pytest.mark.slow
def test_living_manifest_shown_is_the_study_simulated(living):
    # the manifest the page shows is the file the run read, and it is the simulated study:
    # the same trials (each as the simulator's own manifest lists it), bodies, joint, postures
    study = living.folder / "forearm-study"
    (shown,) = (b for b in blocks(LIVING) if b.saved_as)
    assert (living.folder / shown.saved_as).read_text(encoding="utf-8") == shown.code
    assert "forearm-study/forearm.toml" in living.output("sh", 0)  # the run named it
    written, simulated = load_study(study / "forearm.toml"), load_study(study / "study.toml")
    assert sorted(map(_as_given, written.trials)) == sorted(map(_as_given, simulated.trials))
    assert len(written.trials) == 26
    assert written.passive == simulated.passive
    assert written.postures == simulated.postures
    assert _toml(study / "forearm.toml")["bodies"] == _toml(study / "study.toml")["bodies"]
    # the two manifests read a trial alike (the simulator's spells the default columns out)
    first = {t.file: t for t in simulated.trials}
    for spec in (written.trials[0], written.trials[-1]):
        assert spec.read().torque.equals(first[spec.file].read().torque)


@pytest.mark.slow
def test_living_run_finds_the_forearm(living):
    results = living.folder / "results"
    truth = _toml(living.folder / "forearm-study" / "truth.toml")["bodies"]["forearm"]
    summary = _table(results / "summary.csv", "body", "parameter")
    i_tol, mg_tol = stated(
        LIVING, rf"`I` comes out within {NUMBER} % of the truth and its `M_g` within {NUMBER} %"
    )
    (half,) = stated(LIVING, rf"`M_g`'s about ±{NUMBER} % wide")
    for p, tolerance in (("inertia", i_tol), ("gravity_moment", mg_tol)):
        row = summary.loc[("forearm", p)]
        assert row["median"] == pytest.approx(truth[p], rel=tolerance / 100), p
        assert row["hdi_lower"] < truth[p] < row["hdi_upper"], p
    mg = summary.loc[("forearm", "gravity_moment")]
    assert 50 * (mg["hdi_upper"] - mg["hdi_lower"]) / mg["median"] == pytest.approx(half, abs=3)
    assert living.output("python", 2).endswith("M_g pinned by: a second posture\n")
    # what comes out, as listed
    for name in ("passive_parameters.csv", "passive_parameters.md", "passive_parameters.tex",
                 "passive.csv", "passive-curve.png", "static_fit.csv", "static-fit.png",
                 "identification.csv", "report.html"):  # fmt: skip
        assert (results / name).is_file(), name
    assert {"stiffness", "damping", "hysteresis"} <= {
        p for b, p in summary.index if b == "forearm"
    }
    trials = pd.read_csv(results / "trials.csv")
    assert {"posture", "damping"} <= set(trials.columns)
    assert set(trials["posture"]) == {"upright", "tilted"}
    assert "Living joint" in (results / "report.html").read_text(encoding="utf-8")


@pytest.mark.slow
def test_living_real_ankle_block_runs_on_the_recordings(living):
    mean, sd = (np.array(v) for v in json.loads((living.folder / "ankle-holds.json").read_text()))
    assert mean.shape == sd.shape == (3,)
    assert np.isfinite(mean).all()
    assert (sd > 0).all()
    # the predicted static moment rises towards dorsiflexion as the sweeps do (about -18 to -8)
    assert -20 < mean[0] < mean[1] < mean[2] < -8
