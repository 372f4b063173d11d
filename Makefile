# Set-up is part of every target: a fresh machine needs only python3 (>= 3.10) and make.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
# torch: 2.13.0 takes a local CPU wheel where pip finds one; elsewhere pass e.g.
#   make demo TORCH="torch --index-url https://download.pytorch.org/whl/cpu"
TORCH ?= torch==2.13.0

.PHONY: setup demo test test-fast conformance lint

$(BIN)/shoulder-bench: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip "setuptools>=69" wheel  # the wheel test builds without isolation
	$(BIN)/pip install -q $(TORCH)
	$(BIN)/pip install -q -e ".[test]"
	touch $@

setup: $(BIN)/shoulder-bench

demo: setup  ## the main job: a quick demo on CPU
	$(BIN)/shoulder-bench demo

test: setup  ## the whole test suite (what CI runs)
	$(BIN)/python -m pytest -q

test-fast: setup
	$(BIN)/python -m pytest -q -m "not slow"

conformance: setup  ## the independent API checks in ../shared/conformance
	$(BIN)/python ../shared/conformance/check_tasks.py
	$(BIN)/python ../shared/conformance/check_dm_env.py

lint: setup
	$(BIN)/ruff check shoulder_bench tasks train eval tests benchmarks
