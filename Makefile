# soilbin: `make run` solves the default scene, `make test` runs the test suite.
# Both install what is missing first (Debian packages, the venv, soilbin itself).
VENV    := .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.soilbin-installed
SCENE   ?= scenes/tine-2in-90deg.toml
export OMP_NUM_THREADS := 1

.PHONY: run test test-slow bench bench-quick setup system clean

run: setup
	$(VENV)/bin/soilbin run $(SCENE)

test: setup
	$(PY) -m pytest -q -m "not slow" tests

# the slow tests (larger meshes, MPI, long load paths); CI runs both
test-slow: setup
	$(PY) -m pytest -q -m slow tests

# run time against error; results in runs/benchmark/ (README: python scripts/benchmark.py --readme README.md)
bench: setup
	$(PY) scripts/benchmark.py

bench-quick: setup
	$(PY) scripts/benchmark.py --quick

setup: system $(STAMP)

system:
	@sh scripts/install-system.sh

# pip may add what Debian lacks (pyvista, vtk; for the tests hypothesis, meshio), with
# numpy held at Debian's (DOLFINx is built against it).
$(STAMP): pyproject.toml
	/usr/bin/python3 -m venv --system-site-packages $(VENV)
	/usr/bin/python3 -c "import numpy; print('numpy==' + numpy.__version__)" > $(VENV)/constraints.txt
	$(PY) -m pip install --quiet --no-build-isolation -c $(VENV)/constraints.txt -e ".[test]"
	touch $@

clean:
	rm -rf $(VENV) runs .pytest_cache
