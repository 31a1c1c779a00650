# The two commands of the README. Each creates .venv (Python >= 3.11) on first use
# and installs rmdrake into it with its test extra.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out/demo
export OPENBLAS_NUM_THREADS ?= 1
export MPLBACKEND ?= Agg

.PHONY: demo test lint install browser bench-quick
install: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $@

## The main job: the paper's study on the RV-3SB, end to end, into $(OUT).
demo: install
	$(BIN)/rmdrake demo --out $(OUT)

lint: install
	$(BIN)/ruff check src tests examples bench
	$(BIN)/ruff format --check src tests examples bench

## The browser of the rendering test (tests/studies/test_html_render.py):
## Debian's chromium, driven by Playwright from PyPI (no `playwright install`).
## Installed with apt-get when it is missing and we may; else one line says how.
browser:
	@if [ -x /usr/bin/chromium ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "make: installing chromium (apt-get) for the rendering test"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install \
	        -y -qq --no-install-recommends chromium >/dev/null; \
	else \
	    echo "make: /usr/bin/chromium missing: the rendering test will fail;" \
	         "install it: sudo apt-get install --no-install-recommends chromium"; \
	fi

## The tests: lint, then every unit, system and integration test, one pytest
## worker per core (pytest-xdist; each test is independent of the others), at
## most 4 (each worker, and each Dask cluster its tests start, loads its own Drake).
test: lint browser
	$(BIN)/pytest -q -n auto --maxprocesses 4

## Every benchmark in its quick mode: figures printed, never asserted, so that a
## bench the package has moved under fails here instead of rotting.
bench-quick: install
	@for bench in bench/*.py; do \
	    echo "== $$bench --quick"; \
	    $(BIN)/python $$bench --quick || exit 1; \
	done
