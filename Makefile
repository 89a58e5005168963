# dpiil_rl: the two commands are `make train` and `make test`; both set up .venv when needed.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
BIN := $(VENV)/bin

ENV ?= aperture
METHOD ?= dpiil_ucb
SEED ?= 0
ARGS ?=
JOBS ?= 2
# `make test`: test files run on this many processes (pytest-xdist); CI has 2 cores
TEST_JOBS ?= 2
SEEDS ?= 0 1 2 3 4 5 6 7 8 9
# a single number N means seeds 0..N-1 (make paper ENV=ring SEEDS=3)
SEED_LIST = $(if $(filter 1,$(words $(SEEDS))),$(shell seq 0 $$(( $(SEEDS) - 1 ))),$(SEEDS))
METHODS ?= dpiil_ucb dpiil_mu
STUDY ?= paper_protocol
# `make paper`: every method x seed of the paper's study, then the chi sensitivity sweep, then the report
# Table I (the real-robot tasks, rebuilt in simulation) compares four methods
PAPER_METHODS_shaft = bc ensemble_dagger dpiil_mu dpiil_ucb
PAPER_METHODS_ring_real = $(PAPER_METHODS_shaft)
PAPER_METHODS ?= $(or $(PAPER_METHODS_$(ENV)),bc dagger ensemble_dagger thrifty_dagger hg_dagger dpiil_mu dpiil_ucb)
PAPER_SEEDS ?= $(SEED_LIST)
CHI_METHODS ?= ensemble_dagger dpiil_ucb
CHI_GRID ?= 1e-5 3.16e-5 1e-4 3.16e-4 1e-3
# the chi sensitivity sweep (Fig. 3d) belongs to the aperture study; an empty CHI_SEEDS skips it
CHI_SEEDS ?= $(if $(filter aperture,$(ENV)),0 1 2,)
# Hydra launcher: lockstep (the seeds of each setting batched in one process, JOBS processes at a time; records as
# if each ran alone), joblib (one process per run, JOBS at a time), submitit_local, or cluster_slurm (configs/hydra/launcher)
LAUNCHER ?= lockstep
LAUNCH_ARGS ?= $(if $(filter joblib lockstep,$(LAUNCHER)),hydra.launcher.n_jobs=$(JOBS),)
# per-task study settings. aperture: 8 scripted robots side by side per run during interaction (a person
# would be one). ring: simulations in each run's own process (JOBS runs already fill the cores), 10 test
# episodes at k = 0 and after the last iteration (a third of a ring run's time was spent on intermediate
# tests). aperture runs log to offline wandb (group = study, job type = method; ~5 s per run to start it),
# ring runs to CSV (the ring study was started that way).
PAPER_ARGS_aperture = protocol.interactive_envs=8 logger=wandb
PAPER_ARGS_ring = env.workers=0 protocol.eval_episodes=10 protocol.eval_every=5 logger=csv
# shaft / ring_real (Table I): the protocol files already hold the paper's settings; dashboards in offline wandb
PAPER_ARGS_shaft = logger=wandb
PAPER_ARGS_ring_real = logger=wandb
PAPER_ARGS ?= $(PAPER_ARGS_$(ENV))
PAPER_STUDY ?= paper
comma := ,
empty :=
space := $(empty) $(empty)
csv = $(subst $(space),$(comma),$(strip $(1)))

.PHONY: setup train test lint bench evaluate seeds paper collapse frontier faults report headlines docs archive dashboard sync teleop demo clean-runs

setup: $(STAMP)

# torch first and pinned, so pip takes the CPU build from this machine's disk and never a CUDA build.
$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

train: $(STAMP)
	$(BIN)/dpiil-train env=$(ENV) method=$(METHOD) seed=$(SEED) $(ARGS)

evaluate: $(STAMP)
	$(BIN)/dpiil-evaluate $(if $(RUNS),runs=$(RUNS),$(if $(RUN),run_dir=$(RUN))) $(ARGS)

test: $(STAMP)
	$(PY) -m pytest -q -n $(TEST_JOBS) --dist loadscope tests $(ARGS)

# ruff (lint and format) and pyright (basic mode, [tool.pyright] in pyproject.toml), the versions pinned in the
# test extra; PYRIGHT_PYTHON_IGNORE_WARNINGS: no look-up of a newer pyright on PyPI (nothing here needs a network)
lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	PYRIGHT_PYTHON_IGNORE_WARNINGS=1 $(BIN)/pyright

bench: $(STAMP)
	$(BIN)/dpiil-bench $(ARGS)

# Every (method, seed) of the paper protocol as a Hydra multirun; finished runs are skipped, crashed ones resume.
seeds: $(STAMP)
	$(BIN)/dpiil-train -m env=$(ENV) method=$(call csv,$(METHODS)) seed=$(call csv,$(SEED_LIST)) study=$(STUDY) \
	  progress=false hydra/launcher=$(LAUNCHER) $(LAUNCH_ARGS) $(ARGS)
	$(BIN)/dpiil-report runs=runs/$(STUDY)/$(ENV)

# The paper's study on ENV (Fig. 3): all methods x PAPER_SEEDS, the fixed-chi sweep, then the report.
# RESUME_FROM=<study records> (e.g. docs/results/paper_ring): the committed records of finished runs are copied
# into the run root first (nothing there is overwritten), so a study started on another machine skips them.
seed_runs = $(if $(RESUME_FROM),mkdir -p $(1) && cp -rn $(RESUME_FROM)/. $(1)/,true)

paper: $(STAMP)
	$(call seed_runs,runs/$(PAPER_STUDY)/$(ENV))
	$(BIN)/dpiil-train -m env=$(ENV) method=$(call csv,$(PAPER_METHODS)) seed=$(call csv,$(PAPER_SEEDS)) \
	  study=$(PAPER_STUDY) progress=false hydra/launcher=$(LAUNCHER) $(LAUNCH_ARGS) $(PAPER_ARGS) $(ARGS)
ifneq ($(strip $(CHI_SEEDS)),)
	$(BIN)/dpiil-train -m env=$(ENV) method=$(call csv,$(CHI_METHODS)) chi=$(call csv,$(CHI_GRID)) \
	  seed=$(call csv,$(CHI_SEEDS)) 'run_name=$${method.name}-chi$${chi}' study=$(PAPER_STUDY)_chi progress=false \
	  hydra/launcher=$(LAUNCHER) $(LAUNCH_ARGS) $(PAPER_ARGS) $(ARGS)
	$(BIN)/dpiil-report runs=[runs/$(PAPER_STUDY)/$(ENV),runs/$(PAPER_STUDY)_chi/$(ENV)] out=runs/$(PAPER_STUDY)/$(ENV)/report
else
	$(BIN)/dpiil-report runs=[runs/$(PAPER_STUDY)/$(ENV)] out=runs/$(PAPER_STUDY)/$(ENV)/report
endif

# Collapses of the learner on other geometries (experiment overlays): COLLAPSE_METHODS x GEOMETRIES x SEEDS, then the report
GEOMETRIES ?= aperture_narrow aperture_far aperture_near
COLLAPSE_METHODS ?= bc dagger ensemble_dagger thrifty_dagger dpiil_ucb
collapse: $(STAMP)
	$(BIN)/dpiil-train -m experiment=$(call csv,$(GEOMETRIES)) method=$(call csv,$(COLLAPSE_METHODS)) \
	  seed=$(call csv,$(SEED_LIST)) study=collapse progress=false plots=false logger=none protocol.interactive_envs=8 \
	  hydra/launcher=$(LAUNCHER) $(LAUNCH_ARGS) $(ARGS)
	$(BIN)/dpiil-report runs=runs/collapse out=runs/collapse/report

# The safety–effort frontier (every method over its own knob, the paper's geometry and GEOMETRIES), then its report
# 40 seeds per knob value: what a paired t-test needs (38) to resolve the one gap seen that seeds can resolve (the
# narrow geometry's area under the frontier, at 20 seeds) at the Holm-corrected level; docs/results/frontier_aperture
FRONTIER_SEEDS ?= 40
frontier: $(STAMP)
	$(call seed_runs,runs/frontier)
	$(BIN)/dpiil-frontier seeds=$(FRONTIER_SEEDS) jobs=$(JOBS) $(ARGS)
	$(BIN)/dpiil-report runs=runs/frontier out=runs/frontier/report

# The fault-injection campaign at length: FAULTS SIGKILLs per method at seeded random write points (the suite injects one)
FAULTS ?= 5
faults: $(STAMP)
	rm -f faults.log
	DPIIL_FAULTS=$(FAULTS) DPIIL_FAULTS_REPORT=$(CURDIR)/faults.log $(PY) -m pytest -q -n $(TEST_JOBS) tests/training/test_faults.py $(ARGS)
	sort faults.log; awk '{k += $$3; r += $$(NF-3)} END {print "in all: " k " kills injected, " r " runs recovered identical"}' faults.log

report: $(STAMP)
	$(BIN)/dpiil-report runs=$(or $(RUNS),runs/$(STUDY)) $(ARGS)

# The documentation site from docs/ (mkdocs-material, strict: a broken link or a missing page fails)
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

# Recompute every headline table (README.md, docs/results/*/README.md) from the committed records
headlines: $(STAMP)
	$(BIN)/dpiil-headlines $(ARGS)

# Copy a study's records (episodes.jsonl.gz, metrics, summary, config) for a results page: make archive RUNS=... OUT=...
archive: $(STAMP)
	$(BIN)/dpiil-archive runs=$(RUNS) out=$(OUT) $(ARGS)

# A person is the expert: an interactive training session (one robot) with EXPERT=mouse (aperture) or
# EXPERT=gamepad (ring); the run directory is the same as a scripted run's, under runs/teleop/.
EXPERT ?= mouse
DEMOS ?= 3
teleop: $(STAMP)
	$(BIN)/dpiil-train env=$(ENV) expert=$(EXPERT) method=$(METHOD) seed=$(SEED) study=teleop protocol.interactive_envs=1 $(ARGS)

# Record demonstrations only (DEMOS episodes by the person, then the initial fit and test): runs/demos/.
demo: $(STAMP)
	$(BIN)/dpiil-train env=$(ENV) expert=$(EXPERT) method=bc seed=$(SEED) study=demos protocol.iterations=0 \
	  protocol.demo_episodes=$(DEMOS) protocol.interactive_envs=1 $(ARGS)

# Upload offline wandb runs (RUNS, default runs/) where a server and an API key are available; otherwise
# list them and say how to sync later. Nothing else ever needs a network.
# Offline wandb runs from finished runs' records (runs logged to CSV, or records copied without wandb/).
dashboard: $(STAMP)
	$(BIN)/dpiil-dashboard runs=$(or $(RUNS),runs) $(ARGS)

sync: $(STAMP)
	$(BIN)/dpiil-sync $(or $(RUNS),runs) $(ARGS)

clean-runs:
	rm -rf runs
