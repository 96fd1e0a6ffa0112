# One entry point for people and CI. `make demo` and `make test` each create or reuse .venv
# (Python >= 3.12 found by tools/find-python) and install the project into it first, at the
# exact versions CI tested (constraints.txt; `make lock` refreshes it from pyproject.toml).
VENV     := .venv
PY       := $(VENV)/bin/python
STAMP    := $(VENV)/.installed
DEMO_OUT ?= demo-output
PYTEST_ARGS ?=
# `make fuzz FUZZ_ARGS=--hypothesis-seed=N` repeats one fuzz run exactly (CI does).
FUZZ_ARGS ?=
# NumPy's SIMD kernels newer than x86-64-v2 (AVX2, AVX-512), switched off for `make repro-check`.
OLD_CPU  := NPY_DISABLE_CPU_FEATURES="X86_V3 X86_V4 AVX512_ICL AVX512_SPR"

.PHONY: demo test tutorials test-fast repro-check lint fuzz bench bench-quick docs lock clean

$(PY):
	@PYTHON=$$(tools/find-python) && echo "creating $(VENV) with $$PYTHON" && "$$PYTHON" -m venv $(VENV)

$(STAMP): pyproject.toml constraints.txt $(PY)
	$(PY) -m pip install --quiet --upgrade "pip>=25.1"
	$(PY) -m pip install --quiet -c constraints.txt -e . --group dev
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/inertiafit demo --out $(DEMO_OUT)

# The test targets keep Python's bytecode and pytest's rewritten test modules in __pycache__
# (git ignores it) even where the environment turns that off (PYTHONDONTWRITEBYTECODE, set on
# the development machine): each of the suite's two processes otherwise compiles and rewrites
# every test module again on every run (measured: collecting took 11.5 s, and 5.7 s cached).
test tutorials test-fast repro-check fuzz: export PYTHONDONTWRITEBYTECODE :=

test: $(STAMP)
	$(PY) -m pytest -n 2 --dist worksteal $(PYTEST_ARGS)

tutorials: $(STAMP)
	INERTIAFIT_TUTORIALS=1 $(PY) -m pytest -n 2 --dist worksteal tests/test_tutorial_population.py $(PYTEST_ARGS)

test-fast: $(STAMP)
	$(PY) -m pytest -n 2 --dist worksteal -m "not slow" $(PYTEST_ARGS)

# Results must not hang on the CPU (CI runs this after `make test`): the reproducibility and
# sampler tests again with NumPy's newest SIMD kernels off, and the demo run twice, both ways,
# its tables compared byte for byte.
repro-check: $(STAMP)
	$(OLD_CPU) $(PY) -m pytest -n 2 --dist worksteal -m reproducibility $(PYTEST_ARGS)
	tools/demo-twice
	$(OLD_CPU) tools/demo-twice

# The readers and the manifest parser under many random inputs (hypothesis, ~3 min): every
# input gives a valid trial or one InputError line, never another exception.
fuzz: $(STAMP)
	$(PY) -m pytest -q -p no:cacheprovider tests/test_io_properties.py --hypothesis-profile=fuzz $(FUZZ_ARGS)

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests examples benchmarks docs/conf.py docs/_ext
	$(VENV)/bin/ruff format --check src tests examples benchmarks docs/conf.py docs/_ext
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

bench: $(STAMP)
	$(PY) benchmarks/run.py --json bench-results.json

bench-quick: $(STAMP)
	$(PY) benchmarks/run.py --quick

$(VENV)/.docs-installed: pyproject.toml $(STAMP)
	$(PY) -m pip install --quiet -c constraints.txt --group docs
	@touch $@

docs: $(VENV)/.docs-installed
	$(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

# Refresh constraints.txt from pyproject.toml's ranges (CONTRIBUTING.md, "The locked environment").
lock:
	tools/lock

clean:
	rm -rf $(VENV) $(DEMO_OUT) build dist .pytest_cache
