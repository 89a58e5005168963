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
JOBS ?= 2
SEEDS ?= 0 1 2 3 4 5 6 7 8 9
METHODS ?= dpiil_ucb dpiil_mu
STUDY ?= paper_protocol

.PHONY: setup train test bench evaluate seeds report clean-runs

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

# Every (method, seed) of the paper protocol, JOBS at a time; finished runs are skipped, crashed ones resume.
seeds: $(STAMP)
	for m in $(METHODS); do for s in $(SEEDS); do echo "$$m $$s"; done; done | \
	  xargs -P $(JOBS) -n 2 sh -c '$(PY) trainers/train.py env=$(ENV) method=$$0 seed=$$1 study=$(STUDY) progress=false $(ARGS) > /dev/null && echo "done: $$0 seed $$1"'
	$(PY) trainers/report.py runs=runs/$(STUDY)

report: $(STAMP)
	$(PY) trainers/report.py runs=$(or $(RUNS),runs/$(STUDY))

clean-runs:
	rm -rf runs
