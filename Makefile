# The two commands of the README. Each installs rmdrake as users install it: an
# sdist and a wheel built by `python -m build`, the wheel installed (not editable)
# with its test extra into .venv (Python >= 3.11), rebuilt when a source changes.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out/demo
export OPENBLAS_NUM_THREADS ?= 1
export MPLBACKEND ?= Agg

SOURCES := pyproject.toml README.md $(shell find src -type f -not -path '*/__pycache__/*')

.PHONY: demo test lint install dev smoke browser bench-quick docs
install: $(VENV)/.installed

## The wheel and sdist in dist/, and the wheel installed into $(VENV): created
## fresh the first time, the wheel reinstalled over the old one after a change.
$(VENV)/.installed: $(SOURCES)
	@[ -x $(BIN)/python ] || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip build
	rm -rf dist
	$(BIN)/python -m build -q --outdir dist . >/dev/null
	$(BIN)/python -m pip install -q --force-reinstall --no-deps dist/rmdrake-*.whl
	$(BIN)/python -m pip install -q "$$(ls dist/rmdrake-*.whl)[test]"
	touch $@

## For development: the checkout installed editable into $(VENV) (a change to
## src/ is live at once); `make install` puts the wheel back.
dev:
	@[ -x $(BIN)/python ] || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q -e '.[test]'
	rm -f $(VENV)/.installed

## The main job: the paper's study on the RV-3SB, end to end, into $(OUT).
demo: install
	$(BIN)/rmdrake demo --out $(OUT)

lint: install
	$(BIN)/ruff check src tests examples bench docs
	$(BIN)/ruff format --check src tests examples bench docs

## The installed command, one run of each pipeline stage on shipped robots.
smoke: install
	bash .ci/smoke $(BIN)/rmdrake

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

## The tests: lint, the installed command's smoke run, then every unit, system
## and integration test against the installed package (src/ is not on the path:
## tests/conftest.py checks where rmdrake came from), one pytest worker per
## core (pytest-xdist; each test is independent of the others), at most 4 (each
## worker, and each Dask cluster its tests start, loads its own Drake).
test: lint smoke browser
	RMDRAKE_TEST_INSTALLED=1 $(BIN)/pytest -q -n auto --maxprocesses 4

## Every benchmark in its quick mode: figures printed, never asserted, so that a
## bench the package has moved under fails here instead of rotting.
bench-quick: install
	@for bench in bench/*.py; do \
	    echo "== $$bench --quick"; \
	    $(BIN)/python $$bench --quick || exit 1; \
	done

## The documentation (docs/, Sphinx + MyST, tutorials executed by MyST-NB)
## into docs/_build/html, against the installed wheel with its docs extra;
## any warning fails the build (-W), as does a tutorial cell that raises.
docs: install $(VENV)/.docs
	rm -rf docs/_build/html docs/reference/api
	$(BIN)/python -m sphinx -b html -W --keep-going -q docs docs/_build/html
	@echo "docs: open docs/_build/html/index.html"

$(VENV)/.docs: $(VENV)/.installed
	$(BIN)/python -m pip install -q "$$(ls dist/rmdrake-*.whl)[docs]"
	touch $@
