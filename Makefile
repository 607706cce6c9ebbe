# Two commands for a newcomer: `make demo` and `make test`. Every target sets up what it needs.
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
ENV := source scripts/env.sh &&

EVAL_GRAPH_EPISODES ?= 2
# make eval: episodes per method and scenario on the default palette (the paper's protocol: 20), each counted
# by truth and by perception; clean scenes (no impurity) per method and scenario, counted by perception; and
# episodes per non-default palette group (tuning, held-out; generalisation table). 13 rows (6 networks x 2
# rules presets + the heuristic).
EVAL_EPISODES ?= 20
EVAL_CLEAN_SCENES ?= 10
EVAL_GROUP_EPISODES ?= 4
SOAK_EPISODES ?= 200
# make test: pytest-xdist workers, each on a ROS domain of its own (tests/conftest.py), whole files per
# worker (--dist loadfile: a module's fixture runs once). The suite mostly waits on node graphs, so two
# workers on two cores finish sooner; PYTEST_WORKERS=0 runs it in one process.
PYTEST_WORKERS ?= 2

.PHONY: setup test test-fast lint pytest demo train train-baselines eval bench soak test-bag clean help

help:
	@echo "make demo   - set up if needed, start the node graph, run one picking episode"
	@echo "make test   - set up if needed, lint (ruff, hadolint), run every test"
	@echo "make test-fast - the same without the slow acceptance tier (pytest -m 'not acceptance')"
	@echo "make train  - train the push-grasp policy in the fast sim (resumable)"
	@echo "make train-baselines - VPG, No-TSD, No-OI, No-T at once (BASELINE_HOURS=1.3, resumable)"
	@echo "make eval   - paper's evaluation: methods x scenarios (fast sim), table and chart, then a few"
	@echo "              episodes through the node graph, generalisation table per palette group"
	@echo "              (EVAL_EPISODES=20 counted by truth and by perception, EVAL_CLEAN_SCENES=10,"
	@echo "              EVAL_GROUP_EPISODES=4, EVAL_ARGS=..., EVAL_GRAPH_EPISODES=2)"
	@echo "make bench  - latency and throughput figures"
	@echo "make soak   - N picking episodes back to back through the node graph, memory per node (SOAK_EPISODES=200)"
	@echo "make setup  - .venv + pinned requirements + colcon build (idempotent; CPython 3.11, 3.12: runtime only)"
	@echo "make test-bag - re-record tests/data/episode_bag and known_product_bag (after a checkpoint or perception change)"

setup:
	@bash scripts/setup.sh

lint: setup
	@$(ENV) ruff check src tests benchmarks scripts bringup
	@$(ENV) hadolint Dockerfile
	@$(ENV) python scripts/node_reference.py --check README.md
	@echo "lint: ok"

pytest: setup
	@$(ENV) bash scripts/run_pytest.sh -n $(PYTEST_WORKERS) --dist loadfile tests

test: lint pytest

# Every test but the slow acceptance tier (pytest marker `acceptance`: real-cell-mode episodes, the Ray
# cluster, attention on a rendered scene set).
test-fast: lint
	@$(ENV) bash scripts/run_pytest.sh -n $(PYTEST_WORKERS) --dist loadfile -m "not acceptance" tests

demo: setup
	@$(ENV) python -m impurity_bringup.demo

train: setup
	@$(ENV) python -m impurity_learning.train_cli $(TRAIN_ARGS)

train-baselines: setup
	@$(ENV) scripts/train_baselines.sh

eval: setup
	@$(ENV) python -m impurity_learning.eval_cli --rules cell none --episodes $(EVAL_EPISODES) --count both \
		--clean-scenes $(EVAL_CLEAN_SCENES) --group-episodes $(EVAL_GROUP_EPISODES) $(EVAL_ARGS)
	@$(ENV) python -m impurity_bringup.eval_graph --episodes $(EVAL_GRAPH_EPISODES)

soak: setup
	@$(ENV) python benchmarks/soak_graph.py --episodes $(SOAK_EPISODES)

bench: setup
	@$(ENV) for b in benchmarks/bench_*.py; do echo "== $$b"; python "$$b"; done

test-bag: setup
	@$(ENV) if [ -n "$(BAG_ARGS)" ]; then python scripts/record_test_bag.py $(BAG_ARGS); \
	else python scripts/record_test_bag.py && python scripts/record_test_bag.py --known-product; fi

clean:
	rm -rf ros2_ws/build ros2_ws/install ros2_ws/log ros2_ws/colcon-build.log
