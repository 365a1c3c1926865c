# lerobot_forcemap — two commands on a fresh machine: `make demo`, `make test`.
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
# python3.12 from PATH, else a pyenv install (the `python3.12` shim may exist without being active).
PYTHON312 ?= $(shell for p in python3.12 $$HOME/.pyenv/versions/3.12*/bin/python3.12 /usr/bin/python3.12 /usr/local/bin/python3.12; do \
	if $$p -c 'import sys; sys.exit(sys.version_info[:2] != (3, 12))' >/dev/null 2>&1; then echo $$p; break; fi; done)
# Small numerical problems: multithreaded BLAS on 2 cores was 5-20x slower (SPEC §0).
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export MUJOCO_GL ?= egl
# `make test` runs on PYTEST_WORKERS pytest-xdist workers (0: one process). `--dist loadfile` keeps a
# test module on one worker, so its module-scoped fixtures (a recorded dataset, a fitted checkpoint) are
# built once; the slow modules are spread over both cores.
PYTEST_WORKERS ?= 2
PYTEST_ARGS ?=
XDIST := -n $(PYTEST_WORKERS) --dist loadfile

.PHONY: venv test test-fast demo bench experiments learned-baselines datasets segmentation-experiment lint clean

venv: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml constraints.txt setup.py lerobot_forcemap/elmap/_emkernel.c lerobot_forcemap/envs/_stepkernel.c
	@if [ -z "$(PYTHON312)" ]; then echo "error: python3.12 not found (set PYTHON312=/path/to/python3.12)" >&2; exit 1; fi
	@[ -x $(PY) ] || $(PYTHON312) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade "pip>=24"
	$(PY) -m pip install -q -c constraints.txt -e ".[dev,bench,viz,ray]"
	@touch $@

# Tests never touch the network (HF_HUB_OFFLINE=1). pytest's exit code 5 (no tests collected)
# is a failure here: a test run that found nothing must not look green.
test: venv
	@HF_HUB_OFFLINE=1 HF_DATASETS_OFFLINE=1 $(PY) -m pytest -q $(XDIST) $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "error: pytest collected no tests" >&2; exit 1; fi; exit $$rc

test-fast: venv
	@HF_HUB_OFFLINE=1 $(PY) -m pytest -q -m "not slow" $(XDIST) $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "error: pytest collected no tests" >&2; exit 1; fi; exit $$rc

demo: venv
	HF_HUB_OFFLINE=1 $(PY) -m lerobot_forcemap.cli.demo --out outputs/demo

BENCHMARKS := bench_elmap bench_clarabel_polish bench_segmentation bench_envs bench_env_step bench_policy_fit bench_fit_e2e
# The 1,000-episode synthetic dataset is written once (LeRobot's per-episode save: tens of minutes) and kept.
bench: venv
	for b in $(BENCHMARKS); do $(PY) -m benchmarks.$$b || exit 1; done
	$(PY) -m benchmarks.bench_dataset_fit --fit 200 --keep outputs/bench/synthetic_1000

# Paper experiments (8-16 min on 2 cores from an empty cache; cached re-runs only re-aggregate).
experiments: venv
	HF_HUB_OFFLINE=1 $(PY) -m experiments.paper

# ACT and Diffusion trained with lerobot-train on CPU (1-1.5 h); `make experiments` merges results/learned/.
learned-baselines: venv
	HF_HUB_OFFLINE=1 $(PY) -m experiments.learned --out results/learned

# Regenerate the shipped datasets of scripted demonstrations (10 episodes each, seed 0).
DATASET_TASKS ?= press erase peg_in_hole grasp_push grasp_flip
datasets: venv
	for t in $(DATASET_TASKS); do \
		$(VENV)/bin/forcemap record --task $$t --episodes 10 --seed 0 --out datasets/$$t --overwrite || exit 1; \
	done

# The GBTI segmentation experiment (needs the real recordings: found next to the checkout, or FORCEMAP_SHARED_DATA).
segmentation-experiment: venv
	$(PY) -m experiments.gbti_segmentation

lint: venv
	$(PY) -m ruff check lerobot_forcemap lerobot_policy_forcemap lerobot_env_forcemap experiments benchmarks tests
	$(PY) -m ruff format --check .

clean:
	rm -rf outputs .pytest_cache
