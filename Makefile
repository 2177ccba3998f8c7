# Two set-up commands (README): `make demo` and `make test`. Each creates or reuses .venv/.
PY ?= python3
VENV := .venv
STAMP := $(VENV)/.installed

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PY) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e '.[test]'
	touch $(STAMP)

.PHONY: install demo test bench
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

# Peers (the non-commercial `fringes` package, OpenCV contrib's structured_light) live in a separate
# venv so that opencv-contrib never shadows the package's opencv-python-headless.
BENCH_VENV := .venv-bench
bench: $(STAMP)
	test -d $(BENCH_VENV) || $(PY) -m venv $(BENCH_VENV)
	$(BENCH_VENV)/bin/pip install --quiet fringes "opencv-contrib-python-headless==$$($(VENV)/bin/python -c 'import cv2; print(cv2.__version__)').*"
	FRINGE3D_BENCH_PYTHON=$(BENCH_VENV)/bin/python $(VENV)/bin/python benchmarks/run_all.py
