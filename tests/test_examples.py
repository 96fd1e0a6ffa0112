"""Every script in examples/ runs to the end in a fresh folder and writes only there.

The scripts are the documentation's gallery; they are executed again on every docs build. Here
each runs in its own process (a registered reader or a matplotlib setting cannot leak between
them) with a temporary working directory: a child forked from this one once the libraries the
examples use are imported here, so that each does not import them afresh (2 s of the 4-9 s an
example takes in a new interpreter).
"""

import importlib
import runpy
import warnings
from pathlib import Path

import pytest
from cases import in_fork

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))
#: Imported here before the first example is forked (each example imports them too).
SHARED_IMPORTS = ("inertiafit", "inertiafit.pipeline.study", "matplotlib.pyplot", "corner")


@pytest.fixture(scope="module", autouse=True)
def _shared_imports():
    for name in SHARED_IMPORTS:
        importlib.import_module(name)


def test_there_are_examples():
    assert len(EXAMPLES) >= 4


@pytest.mark.slow
@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_and_writes_only_into_examples_output(script, tmp_path):
    def example():
        import matplotlib

        matplotlib.use("Agg")
        warnings.simplefilter("error", DeprecationWarning)
        runpy.run_path(str(script), run_name="__main__")

    proc = in_fork(example, cwd=tmp_path, imports=SHARED_IMPORTS, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["examples-output"]
    written = [p for p in (tmp_path / "examples-output").rglob("*") if p.is_file()]
    assert written, "an example should leave its results in examples-output/"


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_has_a_gallery_header(script):
    text = script.read_text(encoding="utf-8")
    assert text.startswith('"""\n'), "sphinx-gallery needs the docstring first"
    title, underline = text.splitlines()[1:3]
    assert title
    assert set(underline) == {"="}
    assert len(underline) == len(title)
