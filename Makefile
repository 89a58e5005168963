# dpiil_rl: the two commands are `make train` and `make test`; both set up .venv when needed.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

ENV ?= aperture
METHOD ?= dpiil_ucb
SEED ?= 0
ARGS ?=

.PHONY: setup train test bench evaluate clean-runs

setup: $(STAMP)

# torch first and pinned, so pip takes the CPU build from this machine's disk and never a CUDA build.
$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

train: $(STAMP)
	$(PY) trainers/train.py env=$(ENV) method=$(METHOD) seed=$(SEED) $(ARGS)

evaluate: $(STAMP)
	$(PY) trainers/evaluate.py run_dir=$(RUN) $(ARGS)

test: $(STAMP)
	$(PY) -m pytest -q tests $(ARGS)

bench: $(STAMP)
	$(PY) bench/run_benchmarks.py $(ARGS)

clean-runs:
	rm -rf runs
