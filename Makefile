# Two commands for a new user (see README.md):
#   make run   - set up .venv and run the default scenario (L24 swarm, CT model)
#   make test  - set up .venv and run the test suite
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

.PHONY: run test setup bench clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

run: $(STAMP)
	$(VENV)/bin/swarmtrack run l24-ct --out runs/l24-ct

test: $(STAMP)
	$(VENV)/bin/python -m pytest

bench: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_filters.py
	$(VENV)/bin/python benchmarks/bench_sim.py

clean:
	rm -rf $(VENV) runs
