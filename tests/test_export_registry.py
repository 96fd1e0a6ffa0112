"""Export formats are registered like trial readers: a new format is one module (issue 35).

The recipe of docs/architecture.md ("An export format") is followed here for a toy format: one
module, written to a temporary folder, whose writer is decorated by ``register_format``;
importing it registers the format, and ``inertiafit export --format toy`` then writes its
files end to end. Nothing here counts the shipped formats: an added one changes no test.
"""

from __future__ import annotations

import importlib.util
import inspect
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from inertiafit.cli import main
from inertiafit.errors import InputError
from inertiafit.posterior import open_posterior
from inertiafit.report import export
from inertiafit.report.export import available_formats, export_format, register_format

ROOT = Path(__file__).resolve().parents[1]

TOY = '''"""A toy export format: a line per body, its mass, centre of mass and the model's phase."""

from inertiafit.report.export import ExportModel, register_format

__all__ = ["write_toy"]


@register_format("toy", suffix=".toy", description="a line per body")
def write_toy(model: ExportModel) -> str:
    lines = [f"# {model.title}"]
    for body in model.bodies:
        com = " ".join(repr(v) for v in body.com)
        lines.append(f"{body.name} {body.mass!r} {com} {model.phase!r}")
    return "\\n".join(lines) + "\\n"
'''


@pytest.fixture
def results(disk_fit) -> Path:
    """conftest's ``disk_fit``: ``inertiafit fit`` on the paper's disk (read only)."""
    return disk_fit


@pytest.fixture
def toy(tmp_path) -> Iterator[str]:
    """The toy format's module, imported from a file (registering it), then removed."""
    path = tmp_path / "toy_format.py"
    path.write_text(TOY, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("toy_format", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["toy_format"] = module
    spec.loader.exec_module(module)
    try:
        yield "toy"
    finally:
        export.EXPORT_FORMATS.pop("toy", None)
        sys.modules.pop("toy_format", None)


def test_a_new_format_is_one_module_and_runs_end_to_end(results, toy, tmp_path, capsys):
    assert toy in available_formats()
    out = tmp_path / "out"
    code = main(["export", str(results), "--format", toy, "--out", str(out), "--draws", "2",
                 "--seed", "3", "--phase", "30", "--radii", "disk-3kg=0.04,0.04"])  # fmt: skip
    assert code == 0
    assert "model.toy (posterior medians)" in capsys.readouterr().out
    post = open_posterior(results / "posterior.nc")
    mass = post.draws("disk-3kg", "mass").reshape(-1)
    x = post.draws("disk-3kg", "com_distance").reshape(-1)
    name, m, cx, cy, cz, phase = (
        (out / "model.toy").read_text(encoding="utf-8").split("\n")[1].split()
    )
    assert name == "disk-3kg"
    assert float(m) == float(np.median(mass))
    assert (float(cx), float(cy), float(cz)) == (float(np.median(x)), 0.0, 0.0)
    assert float(phase) == pytest.approx(np.radians(30.0), abs=1e-15)
    table = pd.read_csv(out / "export.csv")
    for k in (1, 2):
        line = (out / "draws" / f"model-000{k}.toy").read_text(encoding="utf-8").split("\n")[1]
        draw = int(table.loc[table["model"].astype(str) == f"{k:04d}", "posterior_draw"].iloc[0])
        assert float(line.split()[1]) == mass[draw]


def test_the_registry_refuses_what_it_does_not_know(toy):
    known = ", ".join(available_formats())
    with pytest.raises(InputError, match=f"format: expected one of {known}, got 'fbx'") as err:
        export_format("fbx")
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="lower-case"):
        register_format("Bad Name", suffix=".x")
    with pytest.raises(ValueError, match="suffix"):
        register_format("fine", suffix="x")


def test_every_shipped_format_is_its_own_module():
    package = ROOT / "src" / "inertiafit" / "report" / "export"
    imported = (package / "__init__.py").read_text(encoding="utf-8")
    for name in available_formats():
        module = inspect.getmodule(export_format(name).write)
        assert module is not None
        stem = module.__name__.rpartition(".")[2]
        assert module.__name__ == f"inertiafit.report.export.{stem}"
        assert (package / f"{stem}.py").is_file()
        assert f"from inertiafit.report.export.{stem} import" in imported  # importing registers
        assert export_format(name).suffix.startswith(".")


def test_the_recipe_is_on_the_architecture_page():
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    recipe = page.split("- **An export format**")[1].split("\n- **")[0]
    for words in ("src/inertiafit/report/export/<format>.py", "@register_format",
                  "report/export/__init__.py", "tests/test_export_registry.py"):  # fmt: skip
        assert words in recipe
