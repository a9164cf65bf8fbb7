# Two entry points for a fresh machine (Python 3.11, nothing installed):
#   make demo   set up .venv and run the main job on its embedded default
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

# The main job: I2A (Algorithm 3) on sparse-reward grasping, default profile, a laptop-sized budget.
# It prints where the policy, the metrics and the learning-curve picture are.
demo: $(STAMP)
	$(BIN)/dualsys train --algo i2a --reward sparse --episodes 1500

test: $(STAMP)
	bash scripts/system-packages.sh
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

bench: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[bench]'
	$(BIN)/dualsys bench env --json

clean:
	rm -rf $(VENV) dualsys-runs
