# Each target installs what it needs into .venv on a fresh machine.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow bench screenshots clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[all,dev]'
	$(VENV)/bin/nlid-lab warmup
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/nlid-lab demo --out demo-out --force

# The suite runs on every core (pytest-xdist): `worksteal` hands each worker a contiguous half
# (a module's tests and its module-scoped fixtures stay on one worker) and moves work from the
# busy worker to the idle one at the end, so both cores finish together. The cases asserting
# a wall-clock deadline of the hardware path (`realtime`: watchdogs, pacing) cannot share the
# cores with it: they run afterwards on their own, on an unloaded machine, collected only from
# the files that hold them (collecting the whole suite again costs seconds).
# One BLAS thread per worker: the workers already fill the cores (threads would only spin).
REALTIME_FILES = $(shell grep -rl --include='test_*.py' 'mark.realtime' tests)
# Bytecode is written even where the environment says not to (PYTHONDONTWRITEBYTECODE; empty
# means unset): every worker and every CLI subprocess would otherwise compile the sources and
# rewrite the test modules' asserts again (`pytest --collect-only`: 13 CPU s without, 6.7 with).
test test-slow: export PYTHONDONTWRITEBYTECODE :=

test: $(STAMP)
	QT_QPA_PLATFORM=offscreen OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 \
	    $(PY) -m pytest -q -n auto --dist worksteal -m "not slow and not realtime"
	QT_QPA_PLATFORM=offscreen $(PY) -m pytest -q -m "realtime and not slow" $(REALTIME_FILES)

test-slow: $(STAMP)
	QT_QPA_PLATFORM=offscreen OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 \
	    $(PY) -m pytest -q -n auto --dist worksteal -m slow

bench: $(STAMP)
	for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

screenshots: $(STAMP)   # docs/img/*.png; needs chromium and Xvfb (apt install chromium xvfb)
	$(PY) tools/screenshots.py --force

clean:
	rm -rf $(VENV) demo-out .pytest_cache
