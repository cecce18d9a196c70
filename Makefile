# camsim: `make serve` and `make test` do all set-up on a fresh machine.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
PORT   ?= 5006

.PHONY: install chromium bytecode kernels collected serve test test-fast bench clean

# Python writes the bytecode of the modules it imports (into .venv/ and the checkout's __pycache__ folders) in every
# command below, whatever the environment says: CI machines set PYTHONDONTWRITEBYTECODE, and every process (each
# server, test worker, upload reader) would compile numpy, SciPy, Panel, Bokeh and camsim from source each time it
# imported them. Written on first import, it is made for the ~1,000 modules the explorer imports (the kernels step
# below imports them first), not for the 9,700 files of the dependencies (pip's and uv's --compile-bytecode:
# 20 s of the set-up).
unexport PYTHONDONTWRITEBYTECODE

# uv (from PyPI) installs the dependencies: 7 s against pip's 64 s in a new environment with no download cache
# (2026-11-29), the same versions; pip does it where uv cannot be had or fails. The environment is made without
# pip and the machine's pip puts uv into it (`pip --python`, pip 22.3 and later): venv's own copy of pip took 3.9 s
# of the set-up, uv installs it in 0.5 s. The environment keeps pip (the wheel test builds camsim's wheel with it).
UV_VERSION ?= 0.13.9

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv --without-pip $(VENV)
	{ $(PYTHON) -m pip --python $(PY) install --quiet "uv==$(UV_VERSION)" && \
	  $(VENV)/bin/uv pip install --quiet --python $(PY) pip -e ".[app,test,detect]"; } || { \
	  echo "uv could not install the dependencies: installing them with pip"; \
	  $(PY) -m ensurepip --upgrade --default-pip >/dev/null && $(PY) -m pip install --quiet -e ".[app,test,detect]"; }
	touch $@

install: $(VENV)/.installed

# Chromium for the browser tests comes from Debian (Playwright must not download its own); so does exiftool,
# which reads camsim's DNGs back as a user's raw tools do.
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
	  echo "installing Debian's chromium for the browser tests"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; }
	@command -v exiftool >/dev/null 2>&1 || { \
	  echo "installing Debian's exiftool for the DNG tests"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libimage-exiftool-perl >/dev/null; }

# Python's compiled bytecode of camsim's own modules and tests, written once here before the test workers start
# (three of them would otherwise compile the same files at once; 2.5 s of CPU for the explorer, 4.7 s -> 2.1 s to
# import it). Up-to-date files are skipped.
bytecode: install
	$(PY) -m compileall -q -j 0 camsim_core app tests benchmarks >/dev/null

# The engine's compiled kernels (numba keeps them beside the sources, in __pycache__), made once here before the
# tests: in a clean clone every process of the run's first minute (three workers, their servers) compiled them at
# once, about 14 s of CPU each, where a process that finds them made loads them in under a second. Made again
# after a change to the engine's sources (numba compiles only what changed).
$(VENV)/.kernels: $(VENV)/.installed $(shell find camsim_core -name '*.py')
	OPENBLAS_NUM_THREADS=1 $(PY) -c "from camsim_explorer.main import warm_up; warm_up()"
	touch $@

kernels: $(VENV)/.kernels

# pytest's rewritten test modules (its assertion rewriting, cached in the tests' __pycache__ folders), made once
# before the test workers start: three workers collecting at once each rewrote every test file, 10 s of CPU each
# against 5 s when they are cached. `make test` makes them beside the kernels, on the core that the kernels'
# compilation leaves idle. A file that cannot be collected is reported by the test run itself.
$(VENV)/.collected: $(VENV)/.installed $(shell find tests -name '*.py')
	$(PY) -m pytest --collect-only -q -p no:cacheprovider >/dev/null || true
	touch $@

collected: $(VENV)/.collected

# One BLAS thread per process: the explorer's matrices are small, and threads only contend.
serve: install bytecode
	OPENBLAS_NUM_THREADS=1 $(VENV)/bin/camsim serve --port $(PORT)

# Three workers (pytest-xdist) on two cores, each test file on one of them, the longest files first
# (tests/conftest.py): a browser test's worker waits on its server and its browser much of the time, which a third
# worker fills. A worker starts one server, a file one browser.
test: install chromium bytecode
	$(MAKE) --no-print-directory -j2 kernels collected
	$(PY) -m pytest -q -rfEs -n 3 --dist loadfile --no-loadscope-reorder

# The development loop: the engine and the explorer's state and server, no browser (about three minutes on two cores).
test-fast: install bytecode
	$(MAKE) --no-print-directory -j2 kernels collected
	$(PY) -m pytest -q -rs -n 2 --dist loadfile tests/engine tests/app

bench: install
	for b in pipeline processing metrics explorer experiments measures review; do $(PY) benchmarks/$$b.py || exit 1; done

clean:
	rm -rf $(VENV) test-artifacts .pytest_cache
