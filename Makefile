# Two commands for a new user (see README.md):
#   make run   - set up .venv and run the default scenario (L24 swarm, CT model, latency fused at its time stamps)
#   make test  - set up .venv and run the test suite
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

.PHONY: run test setup bench bench-large clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

setup: $(STAMP)

run: $(STAMP)
	$(VENV)/bin/swarmtrack run l24-ct-refilter --out runs/l24-ct-refilter --overwrite
	@echo "L24's exact filter (its latency fused as if current; NEES far above its band): $(VENV)/bin/swarmtrack run l24-ct --out runs/l24-ct"

# one test worker more than the machine has cores: the live tests wait on the wall clock much of the time (their
# two groups each run on one worker, in turn), and the spare worker keeps the cores busy meanwhile
WORKERS ?= $(shell $(PY) -c "import os; print((os.cpu_count() or 1) + 1)")

test: $(STAMP)
	$(VENV)/bin/python -m pytest -n $(WORKERS) --dist loadgroup

# bench: the default speed figures (about 5 min); bench-large adds 10,000 UAVs and the peak-memory runs
# (tens of minutes, see benchmarks/bench_sim.py). All scripts take --json and --quick.
bench: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_filters.py
	$(VENV)/bin/python benchmarks/bench_fusion.py
	$(VENV)/bin/python benchmarks/bench_sweep.py
	$(VENV)/bin/python benchmarks/bench_batch.py
	$(VENV)/bin/python benchmarks/bench_sim.py
	$(VENV)/bin/python benchmarks/bench_mpc.py
	$(VENV)/bin/python benchmarks/bench_setmembership.py
	$(VENV)/bin/python benchmarks/bench_mtt.py
	$(VENV)/bin/python benchmarks/bench_cli.py

bench-large: $(STAMP)
	$(VENV)/bin/python benchmarks/bench_filters.py
	$(VENV)/bin/python benchmarks/bench_fusion.py
	$(VENV)/bin/python benchmarks/bench_sweep.py
	$(VENV)/bin/python benchmarks/bench_batch.py
	$(VENV)/bin/python benchmarks/bench_sim.py --large
	$(VENV)/bin/python benchmarks/bench_mpc.py
	$(VENV)/bin/python benchmarks/bench_setmembership.py --large
	$(VENV)/bin/python benchmarks/bench_cli.py

clean:
	rm -rf $(VENV) runs
