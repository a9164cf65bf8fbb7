# Two entry points for a fresh machine (Python 3.11, nothing installed):
#   make demo   set up .venv, train CACLA on the `seen` grasp and print it beside the level's trivial policies
#   make test   set up .venv and run the test suite
PYTHON ?= python3.11
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: setup demo test lint bench clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# The CPU build of PyTorch, pinned: a loose requirement would pull GBs of CUDA packages.
	$(BIN)/python -m pip install -q torch==2.13.0
	# dev: pytest, ruff, schemathesis; ray: the distributed executor, whose test starts a local Ray;
	# bench: Stable-Baselines3 (accepts the CPU torch above) and rl-zoo3 (RL Zoo's hyperparameters) for the SB3 peer tests;
	# dmc: dm_control through shimmy, so the tests of dm_control tasks run.
	$(BIN)/python -m pip install -q -e '.[dev,ray,bench,dmc]'
	@touch $(STAMP)

setup: $(STAMP)

# The main job: CACLA on the `seen` grasp (dense reward, 10 000 env steps, default profile, seed 0; about 6
# minutes on 2 shared cores), which prints its greedy success on 25 evaluation positions and where the policy,
# the metrics and the learning curve are; then the level's trivial policies (oracle, random, every constant) on
# the same 25 positions (the trainer's evaluation seeds 1 000 000 + k), to read beside it. Kernels pinned to
# AVX2 so that the figures are README's "What `make demo` prints" on any AVX2 machine
# (tests/runs/test_demo_readme.py; docs/results.md, "`make demo` on the seen level (issue 51)").
demo: $(STAMP)
	$(BIN)/dualsys train --algo cacla --reward dense --steps 10000 --set env.level=seen --set run.cpu_isa=avx2
	$(BIN)/dualsys env calibrate --level seen --reward sparse --episodes 25 --seed 1000000

test: $(STAMP)
	bash scripts/system-packages.sh
	$(BIN)/ruff check .
	# --durations: every CI log names its slowest tests (the suite is kept well under 20 minutes on 2 cores).
	$(BIN)/python -m pytest -q --durations=25

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

bench: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[bench]'
	$(BIN)/dualsys bench env --json

clean:
	rm -rf $(VENV) dualsys-runs
