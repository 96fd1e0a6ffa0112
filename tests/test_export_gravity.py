"""Exported models feel gravity as the body did on the dynamometer (issue 34, item 1).

The dynamometer read ``M_g sin(theta + phi)``. Each exported model is checked by a tool that
is not inertiafit: biorbd's inverse dynamics of the ``.bioMod`` at rest, and for the
``.osim`` (OpenSim itself is not installed: a large wheel) biobuddy's OpenSim reader, whose
forward kinematics give the centre of mass in the world, from which the test computes the
potential energy ``V(q) = -m g.com(q)`` and the moment ``dV/dq``. A moment at rest over a
turn is ``a sin q + b cos q`` exactly, so a least-squares fit of the two over a sweep gives
its peak ``hypot(a, b)`` and phase ``atan2(b, a)`` to rounding; both are held to the
posterior's ``M_g = m g x`` (median model and each draw) and to the phase to 1e-9.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from inertiafit import SamplerSettings, fit_body
from inertiafit.cli import main
from inertiafit.inference.priors import anthropometric_prior
from inertiafit.pipeline.export import run_export
from inertiafit.posterior import open_posterior
from inertiafit.report.export import data_phase

G = 9.81
SWEEP = np.linspace(-math.pi, math.pi, 73)
FRAMES = [("+x", "z"), ("-y", "z"), ("+z", "x"), ("-x", "y")]


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    """A de Leva forearm's posterior (about 1 s); a fit from numbers carries no phase."""
    folder = tmp_path_factory.mktemp("results")
    prior = anthropometric_prior("de-leva-male", "forearm", 75.0, 0.27, name="forearm")
    post = fit_body(prior, inertia=0.025, inertia_se=0.0005, gravity_moment=1.5,
                    gravity_moment_se=0.02, seed=3,
                    settings=SamplerSettings(ess_min=100, chunk=100))  # fmt: skip
    post.save(folder / "posterior.nc")
    return folder


@pytest.fixture(scope="module")
def draws(results) -> dict[str, np.ndarray]:
    post = open_posterior(results / "posterior.nc")
    return {p: post.draws("forearm", p).reshape(-1) for p in ("mass", "com_distance")}


def _sinusoid(q: np.ndarray, moment: np.ndarray) -> tuple[float, float]:
    """Peak and phase of ``moment = M sin(q + phi)`` by least squares over ``q``."""
    (a, b), *_ = np.linalg.lstsq(np.column_stack([np.sin(q), np.cos(q)]), moment, rcond=None)
    return math.hypot(a, b), math.atan2(b, a)


def _biorbd_moment(path: Path, dof: int = 0) -> np.ndarray:
    biorbd = pytest.importorskip("biorbd")
    model = biorbd.Model(str(path))
    n = model.nbQ()
    out = []
    for q in SWEEP:
        tau = model.InverseDynamics(np.full(n, q), np.zeros(n), np.zeros(n)).to_array()
        out.append(tau[dof])
    return np.array(out)


def _quiet(_line: str) -> None:
    pass


@pytest.mark.parametrize(("long_axis", "joint_axis"), FRAMES)
def test_biorbd_inverse_dynamics_peaks_at_the_posterior_gravity_moment(
    results, draws, tmp_path, long_axis, joint_axis
):
    out = tmp_path / "out"
    _, sampled = run_export(results, fmt="biomod", out=out, draws=3, seed=2,
                            long_axis=long_axis, joint_axis=joint_axis, echo=_quiet)  # fmt: skip
    m, x = (float(np.median(draws[p])) for p in ("mass", "com_distance"))
    peak, phase = _sinusoid(SWEEP, _biorbd_moment(out / "model.bioMod"))
    assert peak == pytest.approx(m * G * x, rel=1e-9)
    assert phase == pytest.approx(0.0, abs=1e-9)  # a fit from numbers: no phase, phi = 0
    # the old default (joint axis z under biorbd's gravity along -z) gave 0 N m everywhere
    assert peak > 1.0
    for k, (body,) in enumerate(sampled, start=1):
        i = body.draw
        moment = _biorbd_moment(out / "draws" / f"model-000{k}.bioMod")
        peak, phase = _sinusoid(SWEEP, moment)
        assert peak == pytest.approx(draws["mass"][i] * G * draws["com_distance"][i], rel=1e-9)
        assert phase == pytest.approx(0.0, abs=1e-9)


def test_biorbd_peak_at_the_phase_given(results, draws, tmp_path):
    run_export(results, fmt="biomod", out=tmp_path / "out", phase=0.4, echo=_quiet)
    moment = _biorbd_moment(tmp_path / "out" / "model.bioMod")
    m, x = (float(np.median(draws[p])) for p in ("mass", "com_distance"))
    peak, phase = _sinusoid(SWEEP, moment)
    assert peak == pytest.approx(m * G * x, rel=1e-9)
    assert phase == pytest.approx(0.4, abs=1e-9)
    # the dynamometer's own sign: the moment the joint supplies, largest at q = pi/2 - phi
    np.testing.assert_allclose(moment, m * G * x * np.sin(SWEEP + 0.4), rtol=0, atol=1e-9)


@pytest.mark.parametrize(("long_axis", "joint_axis"), FRAMES)
def test_osim_gravity_moment_through_biobuddy(results, draws, tmp_path, long_axis, joint_axis):
    biobuddy = pytest.importorskip("biobuddy")
    from biobuddy.model_parser.opensim import OsimModelParser  # its reader keeps the gravity

    out = tmp_path / "out"
    _, sampled = run_export(results, fmt="osim", out=out, draws=2, seed=4, phase=-0.7,
                            long_axis=long_axis, joint_axis=joint_axis, echo=_quiet)  # fmt: skip
    files = [out / "model.osim", *(out / "draws" / f"model-000{k}.osim" for k in (1, 2))]
    masses = [float(np.median(draws["mass"])), *(draws["mass"][b[0].draw] for b in sampled)]
    arms = [float(np.median(draws["com_distance"])),
            *(draws["com_distance"][b[0].draw] for b in sampled)]  # fmt: skip
    for path, m, x in zip(files, masses, arms, strict=True):
        parser = OsimModelParser(str(path), biobuddy.MuscleType.HILL_DE_GROOTE,
                                 biobuddy.MuscleStateType.DEGROOTE, print_warnings=False)  # fmt: skip
        model = parser.to_real()
        gravity = np.asarray(parser.gravity, dtype=float)
        np.testing.assert_allclose(gravity, [0.0, -G, 0.0])  # OpenSim's own axis
        com = model.segment_com_in_global("forearm", SWEEP[None, :])[:3]
        energy = -m * gravity @ com
        # V = c + a cos q + b sin q, so dV/dq = b cos q - a sin q = M_g sin(q + phi)
        design = np.column_stack([np.ones_like(SWEEP), np.cos(SWEEP), np.sin(SWEEP)])
        (_, a, b), *_ = np.linalg.lstsq(design, energy, rcond=None)
        assert math.hypot(a, b) == pytest.approx(m * G * x, rel=1e-9)
        assert math.atan2(b, -a) == pytest.approx(-0.7, abs=1e-9)


def test_json_says_where_gravity_points(results, draws, tmp_path):
    run_export(results, fmt="json", out=tmp_path / "out", phase=1.1, long_axis="-y",
               joint_axis="x", echo=_quiet)  # fmt: skip
    data = json.loads((tmp_path / "out" / "model.json").read_text(encoding="utf-8"))
    assert data["phase"] == 1.1
    body = data["bodies"]["forearm"]
    com, m = np.array(body["com"]), body["mass"]
    down = np.array(data["gravity_at_zero"])  # in the body frame at q = 0
    joint = np.array([1.0, 0.0, 0.0])
    for q in SWEEP[::6]:
        # at q the body has turned by q about +x: gravity in its frame turned by -q
        c, s = math.cos(-q), math.sin(-q)
        turn = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
        weight = m * data["gravity"] * (turn @ down)
        supplied = -np.cross(com, weight) @ joint
        assert supplied == pytest.approx(m * G * -com[1] * math.sin(q + 1.1), abs=1e-12)


def _with_trials(results: Path, folder: Path, trials: dict) -> Path:
    post = open_posterior(results / "posterior.nc")
    inputs = json.loads(post.tree.attrs.get("inputs", "{}") or "{}")
    inputs["trials"] = trials
    post.tree.attrs["inputs"] = json.dumps(inputs)
    folder.mkdir()
    post.save(folder / "posterior.nc")
    return folder


def test_phase_from_the_quasi_static_trials(results, tmp_path, capsys):
    nan = float("nan")
    trials = {  # two sweeps in the reference posture, one elsewhere, one failed, one fast
        "kind": ["quasi-static", "quasi-static", "quasi-static", "quasi-static", "fast"],
        "condition": ["A", "B", "A", "A", "A"],
        "posture": ["upright", "upright", "rotated", "upright", "upright"],
        "status": ["ok", "ok", "ok", "failed", "ok"],
        "gravity_phase": [0.30, 0.36, 1.2, 2.0, nan],
        "gravity_moment": [6.0, 9.0, 6.0, 6.0, nan],
        "gravity_moment_se": [0.02, 0.06, 0.02, 0.02, nan],
    }
    folder = _with_trials(results, tmp_path / "results", trials)
    w1, w2 = (6.0 / 0.02) ** 2, (9.0 / 0.06) ** 2  # (M_g / SE)^2: a phase's inverse variance
    expected = math.atan2(w1 * math.sin(0.30) + w2 * math.sin(0.36),
                          w1 * math.cos(0.30) + w2 * math.cos(0.36))  # fmt: skip
    phase, source = data_phase(open_posterior(folder / "posterior.nc"))
    assert phase == pytest.approx(expected, abs=1e-15)
    assert "2 quasi-static trial(s) in posture upright" in source
    assert main(["export", str(folder), "--format", "biomod", "--out", str(tmp_path / "o")]) == 0
    assert f"phi = {expected:.4g} rad" in capsys.readouterr().out
    _, got = _sinusoid(SWEEP, _biorbd_moment(tmp_path / "o" / "model.bioMod"))
    assert got == pytest.approx(expected, abs=1e-9)
    # the command line's --phase, in degrees, wins
    assert main(["export", str(folder), "--format", "json", "--out", str(tmp_path / "p"),
                 "--phase", "-15"]) == 0  # fmt: skip
    data = json.loads((tmp_path / "p" / "model.json").read_text(encoding="utf-8"))
    assert data["phase"] == pytest.approx(math.radians(-15.0), abs=1e-15)
    assert data["phase_source"] == "given"
    code = main(["export", str(folder), "--format", "json", "--out", str(tmp_path / "q"),
                 "--phase", "nan"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2
    assert "--phase: expected a finite angle in degrees" in err
    assert err.count("\n") == 1


def test_help_names_a_docs_page_that_exists(capsys):
    with pytest.raises(SystemExit):
        main(["export", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    (title,) = re.findall(r"docs page '([^']+)'", text)
    docs = Path(__file__).resolve().parents[1] / "docs"
    titles = {
        p.read_text(encoding="utf-8").splitlines()[0].lstrip("# ").strip()
        for p in docs.rglob("*.md")
    }
    assert title in titles
