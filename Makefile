# helixd — two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: all venv test lint typecheck unit demo bench bench-loop soak clean

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
	$(BIN)/mypy helixd tools

# the suite on every core (pytest-xdist; TEST_WORKERS=1 for one process): the flights run on
# a simulated clock, so parallel workers change how long they take, never what they measure
TEST_WORKERS ?= auto
test: lint typecheck
	$(BIN)/pytest -q -n $(TEST_WORKERS) --durations=10

# the fast part: everything but the daemon-against-simulator flights and the opt-in SITL suite
unit: $(STAMP)
	$(BIN)/pytest -q --ignore=tests/integration --ignore=tests/sitl

# the console: the live progress line (on a terminal), warnings, the result table, and the
# plain `helixd: RESULT` line last; every event is in the run directory's events.jsonl
demo: $(STAMP)
	$(BIN)/helixd run --sim --sim-speedup 4 --mission config/missions/square.yaml --config config/helixd.yaml --run-dir runs --log-level warning

# The benchmarks write into bench/results/latest.json and latest.md (sections navigation,
# control_loop, planning, amphibious, survey and ground); each runs even if one before had a
# failed run, the exit status reports them all.
# e.g. make bench NAV_ARGS="--only square --runs 1" LOOP_ARGS="--seconds 10"
# The control loop alone (about a minute): make bench-loop [LOOP_ARGS="--seconds 10 --rate-hz 50"]
NAV_ARGS  ?=
LOOP_ARGS ?= --rate-hz 50 --rate-hz 200
PLAN_ARGS ?=
AMPH_ARGS ?=
SURVEY_ARGS ?=
GROUND_ARGS ?=
bench: $(STAMP)
	@status=0; \
	$(BIN)/python tools/bench_navigation.py $(NAV_ARGS) || status=1; \
	$(BIN)/python tools/bench_control_loop.py $(LOOP_ARGS) || status=1; \
	$(BIN)/python tools/bench_planning.py $(PLAN_ARGS) || status=1; \
	$(BIN)/python tools/bench_amphibious.py $(AMPH_ARGS) || status=1; \
	$(BIN)/python tools/bench_survey.py $(SURVEY_ARGS) || status=1; \
	$(BIN)/python tools/bench_ground.py $(GROUND_ARGS) || status=1; \
	echo "results: bench/results/latest.json, bench/results/latest.md"; \
	exit $$status

bench-loop: $(STAMP)
	$(BIN)/python tools/bench_control_loop.py $(LOOP_ARGS)

# The soak (tools/soak.py): seeded crew days of `helixd serve` against the simulator on the
# simulated clock, every safety rule checked at every step; its `soak` section goes into
# bench/results/latest.json. The goal is SOAK_ARGS="--days 1000 --day-hours 2" (see
# tools/README.md for what it costs here); replay one day: tools/soak.py --seed N --days 1
SOAK_ARGS ?= --days 100 --day-hours 0.1 --jobs 2
soak: $(STAMP)
	$(BIN)/python tools/soak.py $(SOAK_ARGS) --results-dir bench/results

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache runs
