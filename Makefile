PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out
# src of a tree to alternate reproduce with in `make bench` (issue 24's host-normalised
# figure), e.g. `git worktree add /tmp/base24 3ed6d77` then BASELINE=/tmp/base24/src
BASELINE ?=

.PHONY: demo test test-dask test-all bench lint clean bytecode

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip

# the demo needs only the package; tests add the test and dask extras (CI tests dask too)
$(VENV)/.installed-demo: $(BIN)/python pyproject.toml
	$(BIN)/pip install --quiet -e .
	touch $@

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/pip install --quiet -e ".[test,dask]"
	touch $(STAMP)

# bytecode of the editable sources, as a regular install compiles it: where the
# environment sets PYTHONDONTWRITEBYTECODE, every run would compile the ~200 modules
# again (0.25 s of reproduce's CPU); incremental, 0.04 s when up to date
bytecode: | $(BIN)/python
	$(BIN)/python -m compileall -q src

demo: $(VENV)/.installed-demo bytecode
	MPLBACKEND=Agg $(BIN)/servokit reproduce --out $(OUT)

test: $(STAMP) bytecode
	MPLBACKEND=Agg $(BIN)/python -m pytest
	$(MAKE) test-dask

# the distributed backend against real worker processes (slow-marked, so selected here):
# a local cluster, a scheduler with worker processes, a worker killed mid-sweep, Ctrl-C
test-dask: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -c "import distributed" || \
		(echo "make test-dask: the dask extra is missing (pip install -e '.[dask]')" && exit 1)
	MPLBACKEND=Agg $(BIN)/python -m pytest -m "" tests/test_cli_dask.py \
		tests/test_sweep.py tests/test_cli_interrupts.py -k "dask or distributed"

test-all: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -m ""

bench: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python bench/run.py
	MPLBACKEND=Agg $(BIN)/python bench/robust_seek.py
	MPLBACKEND=Agg $(BIN)/python bench/fit_modal.py
	MPLBACKEND=Agg $(BIN)/python bench/startup.py
	MPLBACKEND=Agg $(BIN)/python bench/reproduce_cpu.py $(if $(BASELINE),--baseline $(BASELINE))

lint: $(STAMP)
	$(BIN)/ruff check src tests bench

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache

# API reference from the numpydoc docstrings (Sphinx); opens at docs/_build/html/index.html
.PHONY: docs
$(VENV)/.installed-docs: $(BIN)/python pyproject.toml
	$(BIN)/pip install --quiet -e ".[docs]"
	touch $@

docs: $(VENV)/.installed-docs
	MPLBACKEND=Agg $(BIN)/sphinx-build -q -W --keep-going -b html docs docs/_build/html
	@echo "API docs: docs/_build/html/index.html"
