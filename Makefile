# soilbin: `make run` solves the default scene, `make test` runs the test suite,
# `make docs` builds the documentation site into docs/_build/html.
# Each installs what is missing first (Debian packages, the venv, soilbin itself).
VENV    := .venv
PY      := $(VENV)/bin/python
STAMP   := $(VENV)/.soilbin-installed
KERNELS := $(VENV)/.kernels-compiled
SCENE   ?= scenes/tine-2in-108lb.toml
export OMP_NUM_THREADS := 1

.PHONY: run test test-slow docs bench bench-quick setup system system-docs clean

run: setup
	$(VENV)/bin/soilbin run $(SCENE)

test: setup
	$(PY) -m pytest -q -m "not slow" tests

# the slow tests (larger meshes, MPI, long load paths); CI runs both
test-slow: setup
	$(PY) -m pytest -q -m slow tests

# the documentation site (Sphinx + MyST, Debian's); warnings are errors. The API pages
# import soilbin, so the venv's python runs Sphinx.
docs: setup system-docs
	$(PY) -m sphinx -W --keep-going -q -b html docs docs/_build/html

# run time against error: results in runs/benchmark/, tables into docs/performance.md
# (bench-quick writes no page)
bench: setup
	$(PY) scripts/benchmark.py

bench-quick: setup
	$(PY) scripts/benchmark.py --quick

setup: system $(STAMP) $(KERNELS)

system:
	@sh scripts/install-system.sh

system-docs:
	@sh scripts/install-system.sh docs

# pip may add what Debian lacks (pyvista, vtk; for the tests hypothesis, meshio), with
# numpy held at Debian's (DOLFINx is built against it) and markdown-it-py below 3 (pyvista's
# rich wants >= 2.2, Debian's myst-parser 0.18 < 3).
$(STAMP): pyproject.toml
	/usr/bin/python3 -m venv --system-site-packages $(VENV)
	/usr/bin/python3 -c "import numpy; print('numpy==' + numpy.__version__)" > $(VENV)/constraints.txt
	echo "markdown-it-py>=2.2,<3" >> $(VENV)/constraints.txt
	$(PY) -m pip install --quiet --no-build-isolation -c $(VENV)/constraints.txt -e ".[test]"
	touch $@

# the constitutive kernels and the assembler's loops, compiled by numba into its disk cache
# once (not at a run's start); afresh: numba's cache knows each function's source, not the
# flags of models/jit.py
$(KERNELS): $(STAMP) $(wildcard soilbin/models/*.py) soilbin/solver/assembly.py
	rm -f soilbin/models/__pycache__/*.nb[ic] soilbin/solver/__pycache__/*.nb[ic]
	$(PY) -m soilbin.models
	$(PY) -m soilbin.solver
	touch $@

clean:
	rm -rf $(VENV) runs .pytest_cache docs/_build
