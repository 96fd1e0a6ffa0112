"""The package's shape: imports point one way, private names stay home, the API is visible.

import-linter (``make lint``) holds the layer contract; these tests check the same promises
from the source itself, so a broken promise fails the test suite too: no import cycle
(function-level imports included), no private name imported from another module, an
``__all__`` in every module, and a public API that type checkers see and that still imports.
"""

from __future__ import annotations

import ast
import importlib
import re
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "inertiafit"

#: ``inertiafit.__all__`` before the package was layered (issue 10): every name must still work.
PUBLIC_BEFORE = {
    "__version__",
    "Prior",
    "load_prior",
    "available_priors",
    "Observation",
    "Condition",
    "Model",
    "fit",
    "fit_body",
    "sample",
    "SamplerSettings",
    "analyse_study",
    "run_study",
    "run_many",
    "Posterior",
    "open_posterior",
    "reference_posterior",
    "paper_baseline",
    "read_trial",
    "load_study",
    "InputError",
    "ConvergenceWarning",
}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC.parent).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    inside = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            inside.update(id(n) for b in node.body for n in ast.walk(b))
    return inside


def _imports(name: str, typing: bool = False) -> list[tuple[str, str]]:
    """``(module imported, name imported)`` for every runtime import of ``name``'s source
    (with ``typing``, the imports for type checkers only too)."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = set() if typing else _type_checking_nodes(tree)
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - node.level + 1]
                base = ".".join([*parts, *([node.module] if node.module else [])])
            if base.split(".")[0] == "inertiafit":
                out.extend((base, alias.name) for alias in node.names)
        elif isinstance(node, ast.Import):
            out.extend(
                (alias.name, "")
                for alias in node.names
                if alias.name.split(".")[0] == "inertiafit"
            )
    return out


def _target(base: str, imported: str) -> str:
    """The module an import loads: ``from a import b`` loads ``a.b`` when that is a module."""
    full = f"{base}.{imported}" if imported else base
    return full if full in MODULES else base


def _graph(typing: bool = False) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for name in MODULES:
        targets = {_target(b, i) for b, i in _imports(name, typing)}
        # A package's __init__ only re-exports; the import of its submodule is the edge.
        graph[name] = {t for t in targets if t in MODULES and t != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    counter = 0
    for root, edges in graph.items():
        if root in index:
            continue
        work = [(root, iter(sorted(edges)))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        top = stack.pop()
                        on_stack.discard(top)
                        component.append(top)
                        if top == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


@pytest.mark.parametrize("typing", [False, True], ids=["runtime", "type-checking too"])
def test_no_import_cycle_not_even_through_function_level_imports(typing):
    """Type checkers' imports count too (issue 35): a module that names another's class for
    its annotations while that one imports it is a circle all the same; a Protocol of what it
    reads breaks it (``inference.terms.base.ModelView``, ``posterior.display.PosteriorView``)."""
    graph = {
        m: {t for t in targets if MODULES[t].name != "__init__.py"}
        for m, targets in _graph(typing).items()
        if MODULES[m].name != "__init__.py"
    }
    assert _cycles(graph) == []


def test_the_cycle_check_finds_a_cycle():  # negative control of the check itself
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_private_name_is_imported_from_another_module():
    private = [
        f"{name} imports {base}.{imported}"
        for name in MODULES
        for base, imported in _imports(name)
        if imported.startswith("_")
        and not imported.startswith("__")
        and f"{base}.{imported}" not in MODULES
        and base != name
    ]
    assert private == []


def test_every_module_declares_its_public_names():
    missing = []
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        names = {
            name.id
            for node in tree.body
            if isinstance(node, ast.Assign | ast.AnnAssign)
            for target in (node.targets if isinstance(node, ast.Assign) else [node.target])
            for name in ast.walk(target)  # also `a, b, __all__ = ...`
            if isinstance(name, ast.Name)
        }
        if "__all__" not in names:
            missing.append(name)
    assert missing == []


def test_layers_in_the_contract_are_the_layers_in_the_architecture_page():
    contract = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"][
        "importlinter"
    ]
    layers = next(c for c in contract["contracts"] if c["type"] == "layers")["layers"]
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    diagram = page.split("```text", 1)[1].split("```", 1)[0]
    rows = [line.split("#")[0].strip() for line in diagram.splitlines()]
    rows = [r for r in rows if r and not set(r) <= set("│↓|v ")]
    assert [" | ".join(sorted(r.split(" | "))) for r in rows] == [
        " | ".join(sorted(layer.split(" | "))) for layer in layers
    ]
    for layer in layers:
        for module in layer.split(" | "):
            assert f"inertiafit.{module}" in MODULES, module


def test_public_api_still_imports_and_the_stub_lists_it():
    import inertiafit

    assert set(inertiafit.__all__) >= PUBLIC_BEFORE
    for name in inertiafit.__all__:
        assert getattr(inertiafit, name) is not None, name
    stub = ast.parse((SRC / "__init__.pyi").read_text(encoding="utf-8"))
    stubbed = {
        a.asname or a.name for n in stub.body if isinstance(n, ast.ImportFrom) for a in n.names
    }
    assert stubbed | {"__version__"} == set(inertiafit.__all__)
    with pytest.raises(AttributeError):
        inertiafit.no_such_name  # noqa: B018


def test_import_inertiafit_loads_no_heavy_module():
    code = (
        "import sys, inertiafit; inertiafit.InputError; "
        "print(sorted(m for m in ('emcee', 'arviz', 'matplotlib', 'corner', 'scipy') "
        "if m in sys.modules))"
    )
    import subprocess

    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        encoding="utf-8",
        check=True,
        cwd=ROOT,
    ).stdout
    assert out.strip() == "[]"


def test_every_warning_is_an_inertiafit_warning():
    from inertiafit import errors

    warnings = [
        obj
        for obj in vars(errors).values()
        if isinstance(obj, type) and issubclass(obj, Warning) and obj.__module__ == errors.__name__
    ]
    assert warnings
    assert all(issubclass(w, errors.InertiafitWarning) for w in warnings)
    assert importlib.import_module("inertiafit").ConvergenceWarning is errors.ConvergenceWarning


def _names_on_page(page: str) -> set[str]:
    """Every backticked name on ``page`` as a dotted module name below ``inertiafit``.

    ``inertiafit.io.units``, ``io.units``, ``src/inertiafit/io/units.py`` and ``io/units.py``
    all read as ``io.units``; a package may also be written as its folder (``io/``).
    """
    out = set()
    for token in re.findall(r"`([^`\n]+)`", page):
        name = token.strip().removeprefix("src/").removeprefix("inertiafit/")
        name = name.removeprefix("inertiafit.").removesuffix("/").removesuffix(".py")
        out.add(name.replace("/", "."))
    return out


def _modules_missing_from(page: str) -> list[str]:
    named = _names_on_page(page)
    return [
        name
        for name in MODULES
        if name != "inertiafit" and name.removeprefix("inertiafit.") not in named
    ]


def test_every_module_is_named_on_the_architecture_page():
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert _modules_missing_from(page) == []


def test_the_page_check_finds_a_module_that_is_not_named():  # negative control
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert "`mounting`" in page
    without = page.replace("`mounting`", "mounting").replace("`mounting.py`", "mounting.py")
    without = without.replace("`mounting.Mounting`", "Mounting")
    assert _modules_missing_from(without) == ["inertiafit.mounting"]
    assert _names_on_page("`src/inertiafit/io/readers/csv.py` `inertiafit.report.html` `io/`") == {
        "io.readers.csv",
        "report.html",
        "io",
    }
