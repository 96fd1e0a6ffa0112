"""Each kind of trial has its own handler in one registry (issue 32, item 7).

The registry covers exactly the manifest's kinds, each handler is its own module, and a new
kind is one module: a handler registered (here a test's, replacing the rest hold's for one
study) is the one ``process_study`` calls, in both of its passes.
"""

import importlib

import pytest

from inertiafit.io.manifest import KINDS as MANIFEST_KINDS
from inertiafit.processing import kinds
from inertiafit.processing.kinds import KINDS, Stage, register_kind
from inertiafit.processing.kinds.base import KINDS as BASE_KINDS
from inertiafit.processing.study import process_study
from inertiafit.simulate import simulate_living_study


def test_the_registry_covers_the_manifest_s_kinds():
    assert set(KINDS) == set(MANIFEST_KINDS)
    assert KINDS is BASE_KINDS
    for name, handler in KINDS.items():
        assert handler.name == name
        module = importlib.import_module(type(handler).__module__)
        assert module.__name__.startswith("inertiafit.processing.kinds.")
        assert module.__name__.rsplit(".", 1)[1] == name.replace("-", "_")
    assert {"fast", "mvc", "quasi_static", "rest"} <= set(dir(kinds))


def test_a_kind_has_one_handler():
    with pytest.raises(ValueError, match="kind 'rest' has a handler already"):
        register_kind(KINDS["rest"])


def test_process_study_calls_the_registered_handler(tmp_path, monkeypatch):
    # a living study's rest holds go to whatever handler "rest" has: here one that counts
    # them and hands them on, then sees the gravity models in its second pass
    manifest = simulate_living_study(tmp_path / "s", seed=2, postures="one", trials_per_speed=2)
    seen: dict[str, list] = {"read": [], "after": []}
    real = KINDS["rest"]

    class Counting:
        name = "rest"

        def read(self, stage: Stage, spec, ds) -> None:
            seen["read"].append(spec.file.name)
            real.read(stage, spec, ds)

        def after_gravity(self, stage: Stage, trials) -> None:
            seen["after"].append((len(trials), sorted(stage.gravity)))

    monkeypatch.setitem(KINDS, "rest", Counting())
    processed = process_study(manifest)
    rests = [t.file.name for t in processed.study.trials if t.kind == "rest"]
    assert seen["read"] == rests
    assert seen["after"] == [(len(rests), sorted(processed.study.conditions))]
    assert (processed.trials["kind"] == "rest").sum() == len(rests)
