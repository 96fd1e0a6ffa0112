"""``inertiafit export``: model files read back by biorbd and biobuddy, every number compared.

One small posterior (a forearm with a de Leva prior, sampled once for the module) is exported
in each format; the expected numbers are computed here from the posterior's draws and de
Leva's radii as printed in his Table 4 (male forearm: sagittal 27.6 %, transverse 26.5 %,
longitudinal 12.1 % of the segment length), not through the exporter's own code.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from inertiafit import SamplerSettings, fit_body
from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.inference.anthropometric import principal_radius_ratios
from inertiafit.inference.priors import anthropometric_prior
from inertiafit.pipeline.export import run_export
from inertiafit.posterior import open_posterior
from inertiafit.report.export import (
    Frame,
    available_formats,
    declared_radii,
    load_declarations,
)

SAG, LONG = 0.276 / 0.265, 0.121 / 0.265  # de Leva (1996) male forearm, over the transverse


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    """A results folder holding the posterior.nc of a de Leva forearm (about 1 s)."""
    folder = tmp_path_factory.mktemp("results")
    prior = anthropometric_prior("de-leva-male", "forearm", 75.0, 0.27, name="forearm")
    post = fit_body(
        prior,
        inertia=0.025,
        inertia_se=0.0005,
        gravity_moment=1.5,
        gravity_moment_se=0.02,
        seed=3,
        settings=SamplerSettings(ess_min=100, chunk=100),
    )
    post.save(folder / "posterior.nc")
    return folder


@pytest.fixture(scope="module")
def boxed(results, tmp_path_factory) -> Path:
    """The same posterior with its prior's anthropometric segment forgotten (a box prior)."""
    folder = tmp_path_factory.mktemp("boxed")
    post = open_posterior(results / "posterior.nc")
    about = json.loads(post.tree.attrs["priors"])
    about["forearm"].pop("anthropometric")
    post.tree.attrs["priors"] = json.dumps(about)
    post.save(folder / "posterior.nc")
    return folder


@pytest.fixture(scope="module")
def draws(results) -> dict[str, np.ndarray]:
    """The posterior's draws of the forearm, flattened (read once)."""
    post = open_posterior(results / "posterior.nc")
    return {
        p: post.draws("forearm", p).reshape(-1)
        for p in ("mass", "com_distance", "radius_of_gyration")
    }


def _medians(draws) -> tuple[float, float, float]:
    return tuple(  # type: ignore[return-value]
        float(np.median(draws[p])) for p in ("mass", "com_distance", "radius_of_gyration")
    )


def test_de_leva_ratios_are_the_table_ratios():
    sag, long, _ = principal_radius_ratios("de-leva-male", "forearm")
    assert sag == pytest.approx(SAG, rel=1e-12)
    assert long == pytest.approx(LONG, rel=1e-12)
    sag, long, _ = principal_radius_ratios("de-leva-female", "thigh")
    assert sag == pytest.approx(0.369 / 0.364)
    assert long == pytest.approx(0.162 / 0.364)
    # forearm + hand: the hand's radii and the parts' CoM offsets raise the transverse and
    # sagittal radii over the forearm's, not the longitudinal one as much
    sag_c, long_c, _ = principal_radius_ratios("de-leva-male", "forearm+hand")
    assert 1.0 < sag_c < SAG
    assert long_c < LONG


def test_biomod_read_back_by_biorbd(results, draws, tmp_path):
    biorbd = pytest.importorskip("biorbd")
    _median, sampled = run_export(
        results, fmt="biomod", out=tmp_path / "out", draws=3, seed=5, echo=lambda s: None
    )
    m, x, rho = _medians(draws)
    model = biorbd.Model(str(tmp_path / "out" / "model.bioMod"))
    assert model.nbSegment() == 1
    assert model.nbQ() == 1
    seg = model.segment(0)
    assert seg.name().to_string() == "forearm"
    c = seg.characteristics()
    assert c.mass() == pytest.approx(m, rel=1e-14)
    np.testing.assert_allclose(c.CoM().to_array(), [x, 0, 0], rtol=1e-14)
    expected = np.diag([m * (LONG * rho) ** 2, m * (SAG * rho) ** 2, m * rho**2])
    np.testing.assert_allclose(c.inertia().to_array(), expected, rtol=1e-12, atol=0)
    # the draws: posterior draws by index, de Leva's ratios drawn around the table's
    masses, coms, rhos = (draws[p] for p in ("mass", "com_distance", "radius_of_gyration"))
    files = sorted((tmp_path / "out" / "draws").glob("*.bioMod"))
    assert [f.name for f in files] == [f"model-000{k}.bioMod" for k in (1, 2, 3)]
    ratios = []
    for path, bodies in zip(files, sampled, strict=True):
        (body,) = bodies
        c = biorbd.Model(str(path)).segment(0).characteristics()
        i = body.draw
        assert c.mass() == pytest.approx(masses[i], rel=1e-14)
        np.testing.assert_allclose(c.CoM().to_array(), [coms[i], 0, 0], rtol=1e-14)
        tensor = c.inertia().to_array()
        assert tensor[2, 2] == pytest.approx(masses[i] * rhos[i] ** 2, rel=1e-12)
        np.testing.assert_allclose(tensor, np.array(body.inertia), rtol=1e-12)
        a, b, cc = np.diag(tensor)
        assert a <= b + cc
        assert b <= a + cc
        assert cc <= a + b
        ratios.append(math.sqrt(a / tensor[2, 2]))
    assert len({round(r, 6) for r in ratios}) == 3  # each draw its own longitudinal ratio
    assert all(0.5 * LONG < r < 2 * LONG for r in ratios)
    table = (tmp_path / "out" / "export.csv").read_text(encoding="utf-8").splitlines()
    assert table[0].startswith("model,body,mass")
    assert len(table) == 1 + 4


def test_same_seed_same_draws(results, tmp_path):
    _, first = run_export(results, fmt="json", out=tmp_path / "a", draws=2, seed=9,
                          echo=lambda s: None)  # fmt: skip
    _, again = run_export(results, fmt="json", out=tmp_path / "b", draws=2, seed=9,
                          echo=lambda s: None)  # fmt: skip
    assert [b[0].draw for b in first] == [b[0].draw for b in again]
    assert [b[0].inertia for b in first] == [b[0].inertia for b in again]


def test_osim_read_back_by_biobuddy(results, draws, tmp_path):
    biobuddy = pytest.importorskip("biobuddy")
    run_export(results, fmt="osim", out=tmp_path / "out", long_axis="-y", joint_axis="z",
               echo=lambda s: None)  # fmt: skip
    m, x, rho = _medians(draws)
    model = biobuddy.BiomechanicalModelReal().from_osim(str(tmp_path / "out" / "model.osim"))
    params = model.segments["forearm"].inertia_parameters
    assert params.mass == pytest.approx(m, rel=1e-14)
    np.testing.assert_allclose(params.center_of_mass.ravel()[:3], [0, -x, 0], rtol=1e-14)
    expected = np.diag([m * (SAG * rho) ** 2, m * (LONG * rho) ** 2, m * rho**2])
    np.testing.assert_allclose(np.asarray(params.inertia)[:3, :3], expected, rtol=1e-12)
    # one degree of freedom, turning about the joint axis
    dofs = [d for s in model.segments for d in s.dof_names]
    assert dofs == ["ground_offset_forearm_angle"]


def test_json_every_number(results, draws, tmp_path):
    run_export(results, fmt="json", out=tmp_path / "out", joint_axis="y", echo=lambda s: None)
    data = json.loads((tmp_path / "out" / "model.json").read_text(encoding="utf-8"))
    m, x, rho = _medians(draws)
    body = data["bodies"]["forearm"]
    assert body["mass"] == m
    assert body["com"] == [x, 0.0, 0.0]
    expected = np.diag([m * (LONG * rho) ** 2, m * rho**2, m * (SAG * rho) ** 2])
    np.testing.assert_allclose(body["inertia"], expected, rtol=1e-12)
    assert data["frame"]["joint_axis"].startswith("y")
    assert data["gravity"] == 9.81
    other = body["other_radii"]
    assert other["kind"] == "ratio"
    assert other["sd_log"] == 0.1  # de Leva's table spread of the radius of gyration
    assert (other["long"], other["cross"]) == pytest.approx((LONG, SAG), rel=1e-12)


def test_declared_radii_win_over_the_prior(results, draws, tmp_path):
    declarations = tmp_path / "radii.toml"
    declarations.write_text("[bodies.forearm]\nradius_long = 0.03\nradius_cross = 0.065\n")
    (median,), _ = run_export(results, fmt="json", out=tmp_path / "out",
                              declarations=declarations, echo=lambda s: None)  # fmt: skip
    m, _, rho = _medians(draws)
    assert median.inertia[0][0] == pytest.approx(m * 0.03**2, rel=1e-14)
    assert median.inertia[1][1] == pytest.approx(m * 0.065**2, rel=1e-14)
    assert median.inertia[2][2] == pytest.approx(m * rho**2, rel=1e-14)


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"radius_long": 0.03}, "give radius_long and radius_cross"),
        ({"radius_long": 0.03, "ratio_cross": 1.0}, "give radius_long and radius_cross"),
        ({"radius_long": -1, "radius_cross": 0.1}, "radius_long"),
        ({"segment": "forearm"}, "'table' is missing"),
        ({"segment": "forearm", "table": "dempster"}, "gives one radius of gyration"),
        ({"ratio_long": 1, "ratio_cross": 1, "sd_log": 2}, "'sd_log' must be"),
        ({"mass": 1}, "unknown key 'mass'"),
    ],
)
def test_bad_declarations(entry, message):
    with pytest.raises(InputError, match=message) as err:
        declared_radii("forearm", entry, where="radii.toml")
    assert "\n" not in str(err.value)


def test_bad_declaration_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[bodies.forearm\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_declarations(path)
    path.write_text("[frame]\nlong_axis = 'x'\n")
    with pytest.raises(InputError, match="unknown key 'frame'"):
        load_declarations(path)
    path.write_text("")
    with pytest.raises(InputError, match=r"no \[bodies.<name>\] table"):
        load_declarations(path)
    with pytest.raises(InputError, match="long_axis"):
        Frame(long_axis="w")


def test_bad_inputs(results, boxed, tmp_path):
    quiet = {"echo": lambda s: None}
    cases = [
        (lambda: run_export(tmp_path, fmt="biomod", out=tmp_path / "o", **quiet), "no posterior.nc"),
        (lambda: run_export(results, fmt="fbx", out=tmp_path / "o", **quiet), "format: expected"),
        (lambda: run_export(results, fmt="osim", out=tmp_path / "o", draws=0, **quiet), "draws"),
        (lambda: run_export(boxed, fmt="osim", out=tmp_path / "o", **quiet),
         "body 'forearm': the dynamometer measures one radius"),
        (lambda: run_export(results, fmt="osim", out=results, **quiet), "out"),
    ]  # fmt: skip
    for call, message in cases:
        with pytest.raises(InputError, match=message) as err:
            call()
        assert "\n" not in str(err.value)
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="out"):
        run_export(results, fmt="osim", out=blocker / "out", **quiet)
    # a folder holding a user's file is never replaced
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    with pytest.raises(InputError):
        run_export(results, fmt="osim", out=mine, **quiet)
    assert (mine / "notes.txt").read_text(encoding="utf-8") == "keep me"
    assert not (tmp_path / "o").exists()
    # a declaration for a body the posterior does not have
    with pytest.raises(InputError, match="no body 'shank'"):
        run_export(results, fmt="osim", out=tmp_path / "o", **quiet,
                   declared={"shank": declared_radii(
                       "shank", {"ratio_long": 0.4, "ratio_cross": 1.0}, where="t")})  # fmt: skip
    # radii that cannot be a rigid body's
    with pytest.raises(InputError, match="triangle inequality"):
        run_export(results, fmt="osim", out=tmp_path / "o", **quiet,
                   declared={"forearm": declared_radii(
                       "forearm", {"radius_long": 0.3, "radius_cross": 0.01}, where="t")})  # fmt: skip


def test_command_line(results, tmp_path, capsys):
    out = tmp_path / "cli"
    code = main(["export", str(results), "--format", "biomod", "--out", str(out), "--draws", "2",
                 "--ratios", "forearm=0.5,1.0"])  # fmt: skip
    assert code == 0
    assert (out / "draws" / "model-0002.bioMod").is_file()
    assert "declared (--ratios)" in capsys.readouterr().out
    for argv, message in (
        (["--draws", "0"], "--draws: expected a whole number >= 1"),
        (["--radii", "forearm=0.1"], "--radii: expected BODY=LONG,CROSS"),
        (["--segment", "forearm=forearm"], "--segment: expected BODY=TABLE:SEGMENT"),
    ):
        code = main(["export", str(results), "--format", "json", "--out", str(tmp_path / "x"),
                     *argv])  # fmt: skip
        err = capsys.readouterr().err
        assert code == 2
        assert message in err
        assert err.count("\n") == 1
    code = main(["export", str(results), "--format", "fbx", "--out", str(tmp_path / "x")])
    assert code == 2
    known = ", ".join(available_formats())  # the registry's, whatever an extension adds
    assert f"--format: expected one of {known}, got 'fbx'" in capsys.readouterr().err
