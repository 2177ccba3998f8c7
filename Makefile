# Two set-up commands (README): `make demo` and `make test`. Each creates or reuses .venv/.
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PY) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e '.[test]'
	touch $(STAMP)

.PHONY: install demo test bench bench-check help
install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/fringe3d demo --overwrite  # demo-out/ is the demo's own output: replaced as a whole
	$(VENV)/bin/fringe3d warmup -q  # the fused 3-step path's kernels too: the first real 3D frame compiles nothing

# The checks CI runs (.ci/run): layer contracts, lint, types, then the tests and docstring examples,
# on one worker process per core (pytest-xdist, whole files per worker) with numba's compiled kernels
# carried over from the last run on the same package source (scripts/numba_cache.py).
test: $(STAMP)
	bash scripts/ensure-system-packages.sh
	$(VENV)/bin/lint-imports
	$(VENV)/bin/ruff check .
	$(VENV)/bin/mypy
	$(VENV)/bin/python scripts/numba_cache.py -- $(VENV)/bin/python -m pytest -q -n auto --dist loadfile

# Benchmarks (not tests: timings need a quiet machine; docs/benchmarks.md).
# `make bench` runs every benchmarks/bench_*.py and prints ONE summary table (min / median / max over
# alternated rounds, ratios to the fused kernel and the copy bound of the same run, speed-up over the
# peers, wrap errors of each scene); BENCH_ARGS go to benchmarks/run_all.py (e.g. BENCH_ARGS='--repeat 3
# --quick'). It exits 0 without a GPU (bench_cuda.py is skipped) and without the peers: the non-commercial
# `fringes` package and OpenCV contrib's structured_light live in a separate venv (so that opencv-contrib
# never shadows the package's opencv-python-headless); where it cannot be installed (offline), their rows
# read "peer not installed".
BENCH_VENV := .venv-bench
BENCH_ARGS ?=
bench: $(STAMP)
	test -d $(BENCH_VENV) || $(PY) -m venv $(BENCH_VENV) || true
	$(BENCH_VENV)/bin/pip install --quiet fringes "opencv-contrib-python-headless==$$($(VENV)/bin/python -c 'import cv2; print(cv2.__version__)').*" \
		|| echo "bench: the peers could not be installed into $(BENCH_VENV); their rows will read 'peer not installed'"
	FRINGE3D_BENCH_PYTHON=$(BENCH_VENV)/bin/python $(VENV)/bin/python benchmarks/run_all.py $(BENCH_ARGS)

# `make bench-check`, before stopping work: HEAD against the last release in one ABBA run
# (benchmarks/compare_revisions.py; decode and reconstruct figures); fails when a figure of fringe3d's
# own code is more than 20 % slower (B/A > 1.2 for a time, < 1/1.2 for a rate). The base is the newest
# git tag reachable from HEAD; without tags, BENCH_BASE's default HEAD~20 (set it: make bench-check
# BENCH_BASE=v0.3.0). Commit first: HEAD is compared, not the working tree.
BENCH_BASE ?= $(shell git describe --tags --abbrev=0 2>/dev/null || echo HEAD~20)
BENCH_ROUNDS ?= 3
bench-check: $(STAMP)
	$(VENV)/bin/python benchmarks/compare_revisions.py $(BENCH_BASE) HEAD --rounds $(BENCH_ROUNDS) --fail-above 1.2

help:
	@echo "make install      .venv/ from pyproject.toml"
	@echo "make demo         the main job on the virtual rig"
	@echo "make test         import contracts, ruff, mypy, pytest (what CI runs)"
	@echo "make bench        every benchmark, one summary table (BENCH_ARGS='--quick --repeat 2' for a quick check)"
	@echo "make bench-check  HEAD vs the last release (BENCH_BASE=$(BENCH_BASE)); fails on a > 20 % regression"
