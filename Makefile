# demcal: `make demo` runs the main job on the embedded defaults, `make test` the suite.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
# numba's cache of the engine: demcal itself picks $(VENV)/numba-cache/engine-<hash of its sources>
# (sys.prefix/numba-cache) unless NUMBA_CACHE_DIR is set, so `make` and a bare .venv/bin/demcal share it.

.PHONY: demo test test-slow bench clean

# pip byte-compiles every installed module in one process (about 30 of its 45 s on 2
# cores); compileall does the same work on all cores, less the packages' own test folders
# (a third of the files, never imported by demcal). A module that does not compile (pip's
# own compile skips it too) is compiled at import or never: it does not stop make.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q --no-compile -e '.[test]'
	$(PY) -m compileall -qq -j 0 -x '/tests?/' $(VENV)/lib || true
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/demcal demo --out demo-output

test: $(STAMP)
	$(PY) -m pytest -q -m "not slow" -p no:cacheprovider

test-slow: $(STAMP)
	$(PY) -m pytest -q -m slow -p no:cacheprovider

bench: $(STAMP)
	$(PY) benchmarks/throughput.py --particles 5000 --threads 1
	$(PY) benchmarks/throughput.py --particles 5000 --threads 2

clean:
	rm -rf $(VENV) demo-output build dist src/*.egg-info
