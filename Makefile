# The two commands of the README. Each creates .venv (Python >= 3.11) on first use
# and installs rmdrake into it with its test extra.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out/demo
export OPENBLAS_NUM_THREADS ?= 1
export MPLBACKEND ?= Agg

.PHONY: demo test lint install
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
	$(BIN)/ruff check rmdrake systems tests examples bench
	$(BIN)/ruff format --check rmdrake systems tests examples bench

## The tests: lint, then every unit, system and integration test.
test: lint
	$(BIN)/pytest -q
