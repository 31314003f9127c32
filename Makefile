# Two entry points for a fresh machine: `make run` and `make test` (each creates .venv if missing).
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
# Extras to install (the gym extra runs the Gymnasium tests, ros the original exercise's
# IK_server.py); `make test EXTRAS=test,gym,ros,ray` adds Ray (CI does) so the cluster tests run.
EXTRAS ?= test,gym,ros
STAMP := $(VENV)/.installed-$(EXTRAS)

.PHONY: run test test-perturbed lint bench scene video evaluate docs pictures clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[$(EXTRAS)]'
	touch $(STAMP)

run: $(STAMP)
	$(PY) -m kr210_sim run --cycles 10 $(ARGS)

# PYTHONDONTWRITEBYTECODE= : pytest keeps each test module's assert-rewritten bytecode (an
# environment that sets PYTHONDONTWRITEBYTECODE has every worker rewrite all of them: 2.5 s).
test: $(STAMP)
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -n 2

# The tests of tumbling contact (marked chaotic) again with every initial state nudged by
# +-1e-9 m or rad: another CPU's floating point takes another path, so they must assert what
# holds on any machine, not what one machine happened to do.
test-perturbed: $(STAMP)
	for nudge in 1e-9 -1e-9; do \
	  KR210_SIM_PERTURB=$$nudge PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -n 2 -m chaotic || exit 1; \
	done

lint: $(STAMP)
	$(PY) -m ruff check kr210_sim tests benchmarks examples
	$(PY) -m ruff format --check kr210_sim tests benchmarks examples
	$(PY) -m mypy

bench: $(STAMP)
	for f in benchmarks/*.py; do echo "== $$f"; $(PY) $$f || exit 1; done

scene: $(STAMP)
	$(PY) -m kr210_sim build-meshes
	$(PY) -m kr210_sim build-scene

# The documentation site (Sphinx, MyST Markdown, autodoc, sphinx-argparse) into docs/_build/html;
# warnings are errors (a broken link or reference fails the build).
DOCS_STAMP := $(VENV)/.installed-docs-$(EXTRAS)
$(DOCS_STAMP): $(STAMP)
	$(PY) -m pip install --quiet -e '.[$(EXTRAS),docs]'
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	$(PY) -m sphinx -E -W --keep-going -q -b html docs docs/_build/html
	@echo "the site: docs/_build/html/index.html"

# The README's and the site's pictures, made by the project.
pictures: $(STAMP)
	$(PY) -m kr210_sim.media.pictures
	$(PY) -m kr210_sim snapshot --camera overview --out docs/cell.png

video: $(STAMP)
	$(PY) -m kr210_sim run --cycles 10 --video videos/run.mp4

evaluate: $(STAMP)
	$(PY) -m kr210_sim evaluate --episodes 1000 --workers 2 --randomize $(ARGS)

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache *.egg-info docs/_build
