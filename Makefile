# One entry point for people and CI. `make demo` and `make test` each create or reuse .venv
# (Python >= 3.12 found by tools/find-python) and install the project into it first.
VENV     := .venv
PY       := $(VENV)/bin/python
STAMP    := $(VENV)/.installed
DEMO_OUT ?= demo-output
PYTEST_ARGS ?=
# `make fuzz FUZZ_ARGS=--hypothesis-seed=N` repeats one fuzz run exactly (CI does).
FUZZ_ARGS ?=

.PHONY: demo test test-fast lint fuzz bench bench-quick docs clean

$(PY):
	@PYTHON=$$(tools/find-python) && echo "creating $(VENV) with $$PYTHON" && "$$PYTHON" -m venv $(VENV)

$(STAMP): pyproject.toml $(PY)
	$(PY) -m pip install --quiet --upgrade "pip>=25.1"
	$(PY) -m pip install --quiet -e . --group dev
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/inertiafit demo --out $(DEMO_OUT)

test: $(STAMP)
	$(PY) -m pytest -n 2 --dist worksteal $(PYTEST_ARGS)

test-fast: $(STAMP)
	$(PY) -m pytest -n 2 --dist worksteal -m "not slow" $(PYTEST_ARGS)

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
	$(PY) -m pip install --quiet --group docs
	@touch $@

docs: $(VENV)/.docs-installed
	$(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

clean:
	rm -rf $(VENV) $(DEMO_OUT) build dist .pytest_cache
