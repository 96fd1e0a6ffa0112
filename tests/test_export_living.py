"""A living body's joint in the exported models: passive moment and damping (issue 34, item 2).

The posterior is a living forearm's (``living_cases``: the joint fit of two postures' sweeps,
and the body's posterior on its gravity moment). The fitted curve is what the study wrote in
``posterior.nc`` (``living/curve``, ``processing.living``'s own table, as ``passive.csv``):
every model file is read back by its tool or parsed here, and its passive moment compared
with that table at the table's angles.

- ``.bioMod``: biorbd (1.12) reads passive torques of type constant, linear (slope per degree)
  and a fixed exponential form; the export writes the straight line closest to the curve, so
  biorbd's ``passiveJointTorque`` is held to ``-(P0 + k q)``, ``(P0, k)`` the least-squares
  line through the model's tabulated curve (computed here with ``numpy.polyfit``);
- ``.osim``: the ``ExpressionBasedCoordinateForce``'s expression is evaluated here (a small
  evaluator of its operators, OpenSim not being installed) against ``-(P + b qdot)``;
- JSON and ``passive.csv``: the numbers themselves.
"""

from __future__ import annotations

import ast
import json
import math
import operator
from collections.abc import Callable
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pandas as pd
import pytest
from living_cases import DAMPING, GRAVITY_MOMENT, PHI, living_results

from inertiafit.cli import main
from inertiafit.pipeline.export import run_export
from inertiafit.posterior import open_posterior
from inertiafit.processing.living import LIVING_GROUP, living_tables_from_tree
from inertiafit.report.export import declared_radii
from inertiafit.report.living_joint import condition_moments, living_joint

RATIOS = {"forearm": declared_radii("forearm", {"ratio_long": 0.45, "ratio_cross": 1.0},
                                    where="test")}  # fmt: skip
G = 9.81


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    return living_results(tmp_path_factory.mktemp("living") / "results")


@pytest.fixture(scope="module")
def table(results) -> pd.DataFrame:
    """The study's own passive curve (device angle deg, median N m, 2 deg steps)."""
    post = open_posterior(results / "posterior.nc")
    return living_tables_from_tree(post.tree)["passive_curve"]


@pytest.fixture(scope="module")
def exported(results, tmp_path_factory) -> dict[str, Path]:
    """The posterior exported in each shipped format with 3 draws (seed 7)."""
    root = tmp_path_factory.mktemp("exported")
    out = {}
    for fmt in ("biomod", "osim", "json"):
        out[fmt] = root / fmt
        run_export(results, fmt=fmt, out=out[fmt], draws=3, seed=7, declared=RATIOS,
                   echo=lambda s: None)  # fmt: skip
    return out


def _on_table(angle_rad, moment, table, tol=1e-12) -> tuple[np.ndarray, np.ndarray]:
    """The model's curve at the table's angles (every table angle is one of the model's)."""
    theta = np.radians(table["device_angle"].to_numpy())
    angle = np.asarray(angle_rad)
    nearest = np.abs(angle[None, :] - theta[:, None]).min(axis=1)
    assert nearest.max() < tol  # the 1 deg grid holds the table's 2 deg angles
    return theta, np.interp(theta, angle, np.asarray(moment))


def test_json_median_model_holds_the_fitted_curve(exported, table):
    data = json.loads((exported["json"] / "model.json").read_text(encoding="utf-8"))
    joint = data["bodies"]["forearm"]["joint"]
    _, got = _on_table(joint["angle"], joint["passive_moment"], table)
    np.testing.assert_allclose(got, table["median"], rtol=1e-9, atol=1e-12)
    _, h = _on_table(joint["angle"], joint["hysteresis"], table)
    np.testing.assert_allclose(h, table["hysteresis"], rtol=1e-9, atol=1e-12)
    assert joint["damping"] == DAMPING[0]
    assert joint["joint_angle_at_zero"] == pytest.approx(math.radians(60.0), abs=1e-15)
    lo, hi = joint["angle"][0], joint["angle"][-1]  # the swept range, its ends included
    assert lo == pytest.approx(math.radians(table["device_angle"].iloc[0]), abs=1e-12)
    assert lo < math.radians(0.6)
    assert math.radians(89.0) < hi < math.radians(90.0)
    assert joint["reference_angle"] == pytest.approx(0.5 * (lo + hi), abs=1e-12)
    # 0 at the middle of the swept range (between two tabulated angles: within the steps' bend)
    at_middle = np.interp(joint["reference_angle"], joint["angle"], joint["passive_moment"])
    assert abs(at_middle) < 1e-3


def test_passive_csv_has_every_model(exported, table):
    rows = pd.read_csv(exported["json"] / "passive.csv")
    assert set(rows["model"].astype(str)) == {"median", "0001", "0002", "0003"}
    median = rows[rows["model"].astype(str) == "median"]
    _, got = _on_table(np.radians(median["device_angle"]), median["passive_moment"], table, 1e-7)
    np.testing.assert_allclose(got, table["median"], rtol=1e-7, atol=1e-7)  # 8 figures
    np.testing.assert_allclose(median["joint_angle"] - median["device_angle"], 60.0)
    draws = rows[rows["model"].astype(str) != "median"]
    assert draws.groupby("model")["damping"].nunique().eq(1).all()
    assert draws["damping"].nunique() == 3  # each draw its own b


def _biorbd(path: Path):
    biorbd = pytest.importorskip("biorbd")
    return biorbd.Model(str(path))


def test_biomod_passive_torque_is_the_closest_line_and_gravity_is_the_posterior(exported, results):
    models = [exported["biomod"] / "model.bioMod"] + [
        exported["biomod"] / "draws" / f"model-000{k}.bioMod" for k in (1, 2, 3)
    ]
    jsons = [exported["json"] / "model.json"] + [
        exported["json"] / "draws" / f"model-000{k}.json" for k in (1, 2, 3)
    ]
    post = open_posterior(results / "posterior.nc")
    mass, arm = (post.draws("forearm", p).reshape(-1) for p in ("mass", "com_distance"))
    fit = post.tree[LIVING_GROUP]["fit"].to_dataset()
    names = [str(n) for n in fit["coefficient"].values]
    a, b = (float(fit["mean"].values[names.index(f"{k}:forearm")]) for k in "AB")
    phase = math.atan2(b, a)  # the joint fit's gravity phase, A sin + B cos = M sin(. + phi)
    assert phase == pytest.approx(PHI, abs=0.05)
    sweep = np.linspace(-math.pi, math.pi, 61)
    for path, doc in zip(models, jsons, strict=True):
        data = json.loads(doc.read_text(encoding="utf-8"))
        joint = data["bodies"]["forearm"]["joint"]
        k, p0 = np.polyfit(joint["angle"], joint["passive_moment"], 1)
        model = _biorbd(path)
        for q in sweep:
            got = model.passiveJointTorque(np.array([q]), np.array([0.3])).to_array()[0]
            assert got == pytest.approx(-(p0 + k * q), rel=1e-9, abs=1e-12)
        tau = np.array([model.InverseDynamics(np.array([q]), np.zeros(1), np.zeros(1))
                        .to_array()[0] for q in sweep])  # fmt: skip
        (s, c), *_ = np.linalg.lstsq(np.column_stack([np.sin(sweep), np.cos(sweep)]), tau,
                                     rcond=None)  # fmt: skip
        draw = data["bodies"]["forearm"].get("posterior_draw")
        m, x = (
            (float(np.median(mass)), float(np.median(arm)))
            if draw is None
            else (mass[draw], arm[draw])
        )
        assert math.hypot(s, c) == pytest.approx(m * G * x, rel=1e-9)
        assert math.atan2(c, s) == pytest.approx(phase, abs=1e-9)
    assert float(np.median(mass * G * arm)) == pytest.approx(GRAVITY_MOMENT, rel=0.05)


_BINARY: dict[type, Callable[[float, float], float]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
}


def _evaluate(expression: str, q: float, qdot: float) -> float:
    """OpenSim's expression (Lepton: + - * /, unary -, max, min, q, qdot), evaluated here."""

    def value(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and isinstance(node.value, int | float):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id in ("q", "qdot"):
            return q if node.id == "q" else qdot
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -value(node.operand)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.Call) and getattr(node.func, "id", "") in ("max", "min"):
            args = [value(a) for a in node.args]
            return max(args) if node.func.id == "max" else min(args)
        raise AssertionError(f"not in OpenSim's expression syntax: {ast.dump(node)}")

    return value(ast.parse(expression, mode="eval").body)


def test_osim_force_is_the_curve_and_the_damping(exported, table):
    rows = pd.read_csv(exported["osim"] / "passive.csv")
    rows["model"] = rows["model"].astype(str)
    files = {"median": exported["osim"] / "model.osim"} | {
        f"000{k}": exported["osim"] / "draws" / f"model-000{k}.osim" for k in (1, 2, 3)
    }
    for label, path in files.items():
        root = ET.parse(path).getroot()
        (force,) = root.iter("ExpressionBasedCoordinateForce")
        assert force.findtext("coordinate") == "forearm_angle"
        expression = force.findtext("expression") or ""
        assert not any(c.isspace() for c in expression)  # OpenSim's parser takes none
        doc = exported["json"] / (
            "model.json" if label == "median" else f"draws/model-{label}.json"
        )
        data = json.loads(doc.read_text(encoding="utf-8"))["bodies"]["forearm"]["joint"]
        angle, moment = np.array(data["angle"]), np.array(data["passive_moment"])
        mine = rows[rows["model"] == label]
        np.testing.assert_allclose(mine["passive_moment"], moment, rtol=1e-7, atol=1e-9)
        b = data["damping"]
        for q, p in zip(angle[::7], moment[::7], strict=True):
            for qdot in (0.0, 2.5):
                assert _evaluate(expression, q, qdot) == pytest.approx(-(p + b * qdot),
                                                                       abs=1e-9)  # fmt: skip
        if label == "median":
            theta, _ = _on_table(angle, moment, table)
            got = [_evaluate(expression, t, 0.0) for t in theta]
            np.testing.assert_allclose(got, -table["median"].to_numpy(), rtol=0, atol=1e-9)
        # beyond the swept range: the end slopes continue
        step = angle[1] - angle[0]
        below = moment[0] - 0.2 * (moment[1] - moment[0]) / step
        assert _evaluate(expression, angle[0] - 0.2, 0.0) == pytest.approx(-below, abs=1e-9)


def test_draws_given_their_gravity_moment_are_the_fit_conditioned_on_it(results, table):
    # The joint fit is one Gaussian over gravity (A, B) and the curve; a draw's curve is drawn
    # given its M_g. Checked two ways against the fit itself: fed M_g from the fit's own
    # Gaussian, the draws give back its marginal curve (the table's median and 95 % band);
    # and the mean curve given M_g = M0 is the mean of the fit's joint draws whose
    # hypot(A, B) falls within 0.05 SE of M0 (conditioning by rejection, no linearisation).
    post = open_posterior(results / "posterior.nc")
    joint = living_joint(post)
    assert joint is not None
    params = living_tables_from_tree(post.tree)["passive_parameters"].set_index("parameter")
    mean, sd = params.loc["gravity_moment:forearm", ["mean", "sd"]]
    rng = np.random.default_rng(11)
    n = 20_000
    theta = np.radians(table["device_angle"].to_numpy())
    curves = joint.passive(
        theta, joint.draws(rng, n, {"forearm": mean + sd * rng.standard_normal(n)})
    )
    band = (table["upper"] - table["lower"]).to_numpy() / (2 * 1.959963984540054)
    np.testing.assert_allclose(curves.mean(axis=0), table["median"], atol=4 * band.max() / n**0.5)
    np.testing.assert_allclose(curves.std(axis=0)[1:-1] / band[1:-1], 1.0, atol=0.03)
    fit = post.tree[LIVING_GROUP]["fit"].to_dataset()
    names = [str(v) for v in fit["coefficient"].values]
    every = rng.multivariate_normal(fit["mean"].values, fit["covariance"].values, 400_000)
    moment = np.hypot(every[:, names.index("A:forearm")], every[:, names.index("B:forearm")])
    ours = [names.index(c) for c in joint.names]
    for m0 in (mean - 1.5 * sd, mean + 1.5 * sd):
        near = np.abs(moment - m0) < 0.05 * sd
        assert near.sum() > 2000
        wanted = joint.passive(theta, every[near][:, ours])
        got = joint.passive(theta, joint.draws(rng, 20_000, {"forearm": np.full(20_000, m0)}))
        error = 4 * np.hypot(wanted.std(axis=0) / near.sum() ** 0.5, got.std(axis=0) / 20_000**0.5)
        assert np.all(np.abs(wanted.mean(axis=0) - got.mean(axis=0)) < error + 1e-3 * band.max())
        # and given M_g the curve is narrower than without: the fit's trade-off
        assert np.all(got.std(axis=0)[1:-1] < band[1:-1])
    # the posterior's own draws: the body's M_g per draw (one body in the condition)
    given = condition_moments(post, joint)["forearm"]
    np.testing.assert_allclose(given, post.draws("forearm", "gravity_moment").reshape(-1))


def test_a_posterior_without_the_curve_geometry_exports_its_bodies_and_says_so(
    results, tmp_path, capsys
):
    post = open_posterior(results / "posterior.nc")
    fit = post.tree[LIVING_GROUP]["fit"]
    for key in ("joint", "stop_range"):
        del fit.attrs[key]
    (tmp_path / "old").mkdir()
    post.save(tmp_path / "old" / "posterior.nc")
    code = main(["export", str(tmp_path / "old"), "--format", "biomod", "--out",
                 str(tmp_path / "out"), "--ratios", "forearm=0.45,1.0"])  # fmt: skip
    assert code == 0
    out = capsys.readouterr().out
    assert "no joint exported: posterior.nc: living/fit: no 'joint'" in out
    assert not (tmp_path / "out" / "passive.csv").exists()
    assert "passivetorque" not in (tmp_path / "out" / "model.bioMod").read_text(encoding="utf-8")
