# Two entry points on a fresh clone: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test docs lint format models gaits cycles walk-tables bench bench-accuracy studies wheel-check clean

$(STAMP): pyproject.toml setup.py humanoid/kernels.c
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	mkdir -p results
	$(PY) -m humanoid build --height 1.75 --mass 75 --sex male -o results/adult_male.urdf
	$(PY) -m humanoid build --height 1.62 --mass 62 --sex female -o results/adult_female.urdf
	$(PY) -m humanoid info results/adult_male.urdf | tee results/adult_male.txt
	$(PY) -m humanoid info results/adult_female.urdf | tee results/adult_female.txt
	$(PY) -m humanoid simulate push -o results/push.npz
	$(PY) -m humanoid view results/push.npz --html results/push.html
	$(PY) -m humanoid walk --steps 20 -o results/walk.npz --html results/walk.html --report results/gait_report.png
	$(PY) -m humanoid walk --gait welded -o results/welded.npz --html results/welded.html --figure results/welded.png
	@echo "demo: results in results/: walk.npz, walk.html, gait_report.png (the person's walk), welded.npz, welded.png, welded.html (open the HTML in a browser)"

# pytest-xdist: a worker per core (at most 4); the optimal-control checks run in chunks of
# their own processes, which the workers share out (tests/conftest.py). One BLAS/OpenMP thread
# per worker: a worker's second thread only fights the other worker for its core (the library
# runs its own steps on one thread whatever the environment says; the tests' own algebra and
# the solvers outside the steps do not; the tests of the thread limits set their own pools)
test: $(STAMP) lint
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 \
	$(PY) -m pytest -q -n auto --maxprocesses 4 --dist worksteal

# The documentation site (docs/*.md, MyST, and the API reference from the docstrings), warnings
# as errors: docs/_build/html/index.html
docs: $(STAMP)
	$(VENV)/bin/sphinx-build -W --keep-going -b html docs docs/_build/html

lint: $(STAMP)
	$(VENV)/bin/ruff check humanoid tests scripts
	$(VENV)/bin/ruff format --check humanoid tests scripts
	$(VENV)/bin/mypy

format: $(STAMP)
	$(VENV)/bin/ruff format humanoid tests scripts
	$(VENV)/bin/ruff check --fix humanoid tests scripts

# The optimised gait cycles shipped as package data (a few minutes per body and objective).
gaits: $(STAMP)
	$(PY) scripts/make_gaits.py

# The fitted walking cycles shipped as package data (about 3 minutes; tests/test_cache.py says
# when the fitting code changed and they must be fitted again).
cycles: $(STAMP)
	$(PY) scripts/make_cycles.py

# The walking guide's tables of the person's walks (docs/walking.md) (about 10 minutes on 2 cores).
walk-tables: $(STAMP)
	$(PY) scripts/walk_tables.py
	$(PY) scripts/readme_tables.py

bench: $(STAMP)
	$(PY) -m humanoid bench step -o docs/bench
	$(PY) -m humanoid bench walk -o docs/bench
	$(PY) -m humanoid bench scaling -o docs/bench
	$(PY) -m humanoid bench track -o docs/bench
	$(PY) scripts/readme_tables.py

studies: $(STAMP)
	mkdir -p docs/studies
	for s in push_standing walk_speed; do \
		$(PY) -m humanoid sweep $$s --quiet && \
		cp results/studies/$$s/figure.png docs/studies/$$s.png && \
		cp results/studies/$$s/result.md docs/studies/$$s.md && \
		cp results/studies/$$s/results.parquet docs/studies/$$s.parquet || exit 1; \
	done
	$(PY) scripts/readme_tables.py

bench-accuracy: $(STAMP)
	$(PY) -m humanoid bench accuracy -o docs/bench

wheel-check: $(STAMP)
	bash scripts/wheel_check.sh $(PY)

models: $(STAMP)
	$(PY) scripts/make_models.py

clean:
	rm -rf $(VENV) results .pytest_cache docs/_build
