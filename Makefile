# The two commands of the README's Quick start.  Both create .venv with the pinned
# dependencies when it is missing (the stamp file tracks pyproject.toml and the lock).  uv installs
# the lock (12 s against pip's 30 s from empty caches) and byte-compiles it: where
# PYTHONDONTWRITEBYTECODE is set (as on this machine) Python never caches what it compiles, and
# without installed .pyc files every job recompiled pandas, SciPy and Drake's Python on import
# (make figures took 15 min instead of 11).
PY      ?= python3.11
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
CORES   ?= 2
UV      := uv==0.13.9

.PHONY: figures campaign-args test test-slow test-e2e test-all raw-data clean-results venv

venv: $(STAMP)

$(STAMP): pyproject.toml requirements.lock
	@command -v $(PY) >/dev/null 2>&1 || { echo "error: $(PY) not found (roboball needs Python 3.11: drake 1.51.1 has no other wheels here)"; exit 1; }
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q $(UV)
	$(BIN)/uv pip install -q --python $(BIN)/python --compile-bytecode -r requirements.lock
	$(BIN)/uv pip install -q --python $(BIN)/python --compile-bytecode --no-deps -e .
	touch $(STAMP)

# Regenerate every figure and table in paper_figures/ from raw_data/ (or only SNAKEMAKE_TARGETS,
# e.g. make figures SNAKEMAKE_TARGETS=results/identify/shell_regression.csv).  After an
# interrupted run (killed, power cut) roboball.pipeline.runlock clears Snakemake's stale lock and
# --rerun-incomplete redoes the jobs that were cut short, so rerunning `make figures` just works.
# The greedy scheduler: Snakemake's default (an ILP solved before every batch of jobs) costs
# about 0.2 s of a core per job on this DAG and buys nothing with 2 cores (docs/performance.md).
# Your own recordings: make figures RAW=DIR [OUT=DIR2] [NAME="my robot"] [MANIFEST=FILE] runs the same
# DAG on the campaign in DIR (its MANIFEST.csv, or FILE for a folder that must stay as it is:
# roboball manifest DIR [--out FILE]) and writes results/ and figures/ under DIR2 (default
# runs/<DIR's name>/), leaving paper_figures/ and DIR alone.
SNAKEMAKE_TARGETS ?=
RAW  ?=
OUT  ?=
NAME ?=
MANIFEST ?=
# the campaign settings typed on the command line (not from the environment), refused without RAW=
RAW_ONLY_GIVEN := $(strip $(foreach v,OUT NAME MANIFEST,$(if $(filter command line,$(origin $(v))),$(if $(strip $($(v))),$(v)=))))
SMK_FLAGS := --cores $(CORES) --scheduler greedy --rerun-incomplete --rerun-triggers mtime input params code
RUN_DIR := $(abspath $(if $(OUT),$(OUT),runs/$(notdir $(abspath $(RAW)))))
figures: campaign-args $(STAMP)
ifeq ($(strip $(RAW)),)
	$(BIN)/python -m roboball.pipeline.runlock $(BIN)/snakemake $(SNAKEMAKE_TARGETS) $(SMK_FLAGS)
else
	@test -d "$(RAW)" || { echo "error: RAW=$(RAW): not a folder of recordings"; exit 2; }
	@# a run refused before any job (a bad manifest) leaves no output folder it created behind
	@new=; test -d "$(RUN_DIR)" || new=1; mkdir -p "$(RUN_DIR)"; \
	cd "$(RUN_DIR)" && $(abspath $(BIN))/python -m roboball.pipeline.runlock $(abspath $(BIN))/snakemake \
	  -s $(CURDIR)/Snakefile $(SNAKEMAKE_TARGETS) $(SMK_FLAGS) \
	  --config campaign_dir="$(abspath $(RAW))" figures_dir=figures $(if $(NAME),campaign_name="$(NAME)") \
	  $(if $(MANIFEST),campaign_manifest="$(abspath $(MANIFEST))") \
	|| { rc=$$?; if [ -n "$$new" ] && [ ! -d "$(RUN_DIR)/results" ]; then rm -rf "$(RUN_DIR)"; fi; exit $$rc; }
	@echo "results and figures of $(RAW): $(RUN_DIR)/figures, $(RUN_DIR)/results"
endif

# Checked before anything else runs (the environment included).
campaign-args:
	@test -n "$(strip $(RAW))" || test -z "$(RAW_ONLY_GIVEN)" || { echo "error: $(RAW_ONLY_GIVEN) given without RAW=DIR: OUT=, NAME= and MANIFEST= go with your campaign's folder; without it make figures regenerates paper_figures/ from raw_data/"; exit 2; }

# The everyday suite (about 5 minutes on 2 cores); the slow tests (whole campaign regeneration,
# kill-and-resume, the browser, the real logs' diagnoses and friction chains) run in CI after it
# (.ci/run) or with `make test-slow`.  The suite runs on CORES workers (pytest-xdist), a module
# to a worker (--dist loadscope) so that a module's expensive fixture (a friction chain, a
# campaign) is built once, not once per worker.
test: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow" -n $(CORES) --dist loadscope

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m "slow and not e2e"

# The whole pipeline on a copy of the repository, then its incremental behaviour.
test-e2e: $(STAMP)
	$(BIN)/python -m pytest -q -m e2e

test-all: test test-slow test-e2e

# Rebuild the virtual test bed's campaign (raw_data/) bit-for-bit from its seed.
raw-data: $(STAMP)
	$(BIN)/roboball-testbed campaign --out raw_data

clean-results:
	rm -rf results .snakemake
