# thermoswarm: two commands (`make run`, `make test`) work on a fresh machine with Python 3.11+.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out
# Numba compiles once per machine and keeps the result beside the sources.
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba-cache

.PHONY: install run test test-slow test-all bench lint clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || \
	  { echo "error: Python 3.11+ is required (PYTHON=$(PYTHON))" >&2; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	# The CPU build of PyTorch; an unpinned torch would pull GBs of CUDA packages.
	$(PY) -m pip install -q torch==2.13.0 || echo "note: torch==2.13.0 not installable here; the trained-detector tests will be skipped"
	$(PY) -m pip install -q -e '.[io,track,video,bench,dev]'
	touch $(STAMP)

install: $(STAMP)

run: install
	$(PY) -m thermoswarm reproduce --quick --out $(OUT)

test: install
	$(PY) -m pytest -q -m "not slow" -n 2 --dist loadfile

test-slow: install
	$(PY) -m pytest -q -m slow

test-all: install
	$(PY) -m pytest -q

bench: install
	$(PY) benchmarks/run_all.py

lint: install
	$(PY) -m ruff check src tests benchmarks
	$(PY) -m ruff format --check src tests benchmarks

clean:
	rm -rf $(VENV) .numba-cache .pytest_cache out
