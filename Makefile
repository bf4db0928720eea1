# helixd — two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: all venv test lint typecheck unit demo bench clean

all: test

# Create the virtualenv and install helixd with its dev extras; re-runs only when
# pyproject.toml changes, so a second `make test` starts straight away.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

venv: $(STAMP)

lint: $(STAMP)
	$(BIN)/ruff check helixd tests tools

typecheck: $(STAMP)
	$(BIN)/mypy helixd

test: lint typecheck
	$(BIN)/pytest -q

unit: $(STAMP)
	$(BIN)/pytest -q tests/unit

demo: $(STAMP)
	$(BIN)/helixd run --sim --sim-speedup 4 --mission config/missions/square.yaml --config config/helixd.yaml --run-dir runs

bench: $(STAMP)
	$(BIN)/python tools/bench_navigation.py
	$(BIN)/python tools/bench_control_loop.py

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache runs
