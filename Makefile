# Two commands set everything up on a fresh machine with Python 3.11 and pip:
#   make demo   -- creates .venv if missing, installs the core only, runs the main job
#   make test   -- creates .venv if missing, installs every extra, runs the whole suite
#                  (tests/test_docs.py builds the docs site with warnings as errors)
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
CORE   := $(VENV)/.simgap-core
STAMP  := $(VENV)/.simgap-installed
OUT    ?= simgap-report/demo
# pytest workers: the suite is CPU-bound and the machines have 2 cores.
WORKERS ?= 2
# torch for the `rl` extra (stable-baselines3). On an ordinary Linux machine a plain
# `pip install torch` resolves the CUDA build (GBs); point TORCH_INDEX at PyTorch's CPU wheel
# index there, e.g. `make test TORCH_INDEX=https://download.pytorch.org/whl/cpu`. Empty (the
# default) takes torch==2.13.0 from the configured index (on the project's machines a local
# CPU wheel).
TORCH_INDEX ?=
TORCH_PIN   := torch==2.13.0

.PHONY: demo test install install-core lint bench docs notebooks clean

$(PY):
	$(PYTHON) -m venv $(VENV)

# The core: what `simgap demo`, `record`, `diagnose` and `reproduce` need (no torch).
$(CORE): pyproject.toml setup.py simgap/identifiers/_call.c | $(PY)
	$(PY) -m pip install --upgrade pip setuptools wheel
	$(PY) -m pip install -e .
	touch $(CORE)

# Everything: torch first (pinned, CPU) so that stable-baselines3 (extra "rl") does not pull
# another build, then the dev, rl, highway, docs and notebooks extras.
$(STAMP): $(CORE)
	$(PY) -m pip install $(TORCH_PIN) $(if $(TORCH_INDEX),--index-url $(TORCH_INDEX))
	$(PY) -m pip install -e ".[dev,rl,highway,docs,notebooks,mujoco,ray]"
	touch $(STAMP)

install-core: $(CORE)

install: $(STAMP)

demo: $(CORE)
	$(VENV)/bin/simgap demo --out $(OUT)

test: $(STAMP)
	$(PY) -m pytest -n $(WORKERS) --durations=15

docs: $(STAMP)
	$(VENV)/bin/mkdocs build --strict --site-dir site

# Notebooks: build notebooks/*.ipynb from the jupytext .py files, then open JupyterLab with
# `.venv/bin/jupyter lab notebooks/` (each notebook finds its files from its own folder).
notebooks: $(STAMP)
	$(VENV)/bin/jupytext --to ipynb notebooks/*.py
	@echo "open them with: $(VENV)/bin/jupyter lab notebooks/"

lint: $(STAMP)
	$(VENV)/bin/ruff check .

bench: $(STAMP)
	for f in benchmarks/bench_*.py; do $(PY) $$f; done

clean:
	rm -rf $(VENV) $(OUT) site .pytest_cache
