# make test runs the suite in two processes (pytest-xdist), each test file in one of them, so
# the tests of a file keep their order (the README's commands read what earlier ones wrote);
# the longest files start first (tests/conftest.py, LONGEST_FILES); one BLAS thread per
# process, two processes on two cores.
# Every target creates .venv and installs the package with its test tools and the
# optional extras (docs: Sphinx and Playwright; lmi: cvxpy; dask; parquet: pyarrow; compiled: numba;
# robots: Pinocchio; mujoco; app: Bokeh) on first use,
# so their tests run (robot-data, the 130-MB example-robot-data, is not installed: its tests skip).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: test test-slow test-clarabel compare lint bench notebooks docs docs-figures clean

# what no process of the package imports: the packages' own test suites, pip's and setuptools' code,
# PyOpenGL (MuJoCo's viewer: 2 877 files) and debugpy; skipping them takes compileall from 54 s to 34 s
NOT_IMPORTED := /(OpenGL|pip|setuptools|debugpy)/|/tests?/

# pip installs without compiling (one process), then compileall byte-compiles the environment and the
# package on every core: where PYTHONDONTWRITEBYTECODE is set, no import ever writes a .pyc, and every
# process (each CLI call, test worker and subprocess test) would compile scipy, pandas and
# python-control from source again (docs/performance.md: start-up)
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --no-compile -e ".[test,docs,lmi,dask,parquet,compiled,robots,mujoco,app]"
	$(BIN)/python -m compileall -q -j 0 -x '$(NOT_IMPORTED)' $(VENV)/lib scara_robust > /dev/null
	touch $(STAMP)

# ruff and mypy run inside the suite (tests/test_lint.py), beside the other tests
test: $(STAMP)
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 SCARA_ROBUST_REQUIRE_EXTRAS=1 \
		$(BIN)/python -m pytest -q -m "not slow" -n 2 --dist loadfile --no-loadscope-reorder --durations=30

# the full-size cross-checks (200-scenario campaigns on both engines: about 10 min on 2 cores)
test-slow: $(STAMP)
	SCARA_ROBUST_REQUIRE_EXTRAS=1 $(BIN)/python -m pytest -q -m slow

# every LMI test again with cvxpy + Clarabel, the reference, as the default solver (sr.use_lmi_solver)
test-clarabel: $(STAMP)
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 SCARA_ROBUST_REQUIRE_EXTRAS=1 \
		$(BIN)/python -m pytest -q -m "lmi and not slow" --lmi-solver CLARABEL -n 2 --dist loadfile

compare: $(STAMP)
	$(BIN)/python -m scara_robust.compare

lint: $(STAMP)
	$(BIN)/ruff check scara_robust tests benchmarks docs
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/python -m pytest benchmarks --benchmark-enable --benchmark-json=benchmark.json -q
	$(BIN)/python benchmarks/report.py benchmark.json

# The documentation site, warnings as errors; the gallery's notebooks are executed and cached in
# docs/_build/.jupyter_cache (a rebuild without changes executes nothing). Open docs/_build/html/index.html.
docs: $(STAMP)
	$(BIN)/sphinx-build -b html -W --keep-going docs docs/_build/html

# Executes every notebook (outputs are not saved); PNGs land in notebooks/figures/.
notebooks: $(STAMP)
	cd notebooks && ../$(BIN)/jupyter execute --timeout=600 *.ipynb

# The README's figures, regenerated from the notebooks.
docs-figures: notebooks
	mkdir -p docs
	cp notebooks/figures/figure2_surface_published_all.png notebooks/figures/figure3_pid_large_ic.png \
	   notebooks/figures/anti_windup.png docs/

clean:
	rm -rf $(VENV) .pytest_cache benchmark.json docs/_build docs/api/generated
