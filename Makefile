# Two commands set everything up on a fresh machine with Python 3.11 and pip:
#   make demo   -- creates .venv if missing, installs, runs the main job on built-in data
#   make test   -- creates .venv if missing, installs, runs the whole test suite
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.simgap-installed
OUT    ?= demo-output
# pytest workers: the suite is CPU-bound and the machines have 2 cores.
WORKERS ?= 2

.PHONY: demo test install lint bench clean

$(PY):
	$(PYTHON) -m venv $(VENV)

# torch is pinned to the provided CPU wheel (an unpinned torch pulls GBs of CUDA) and must be
# installed before stable-baselines3 (extra "rl") so that pip does not pick another build.
$(STAMP): pyproject.toml setup.py simgap/identifiers/_call.c | $(PY)
	$(PY) -m pip install --upgrade pip setuptools wheel
	$(PY) -m pip install torch==2.13.0
	$(PY) -m pip install -e ".[dev,rl,highway,mujoco,ray]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/simgap demo --out $(OUT)

test: $(STAMP)
	$(PY) -m pytest -n $(WORKERS) --durations=15

lint: $(STAMP)
	$(VENV)/bin/ruff check .

bench: $(STAMP)
	for f in benchmarks/bench_*.py; do $(PY) $$f; done

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
