# coordarm: `make demo` and `make test` work on a fresh machine (Python 3.11+, gcc).
# make install pins every package to the tested versions of constraints.txt (pyproject.toml has ranges).
VENV   ?= .venv
PY     := $(VENV)/bin/python
PYTHON ?= python3

.PHONY: install demo test lint bench clean docs viewer

install: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[test]'
	touch $@

demo: install
	$(VENV)/bin/coordarm run line --out logs/line.mcap --overwrite

test: install
	$(PY) -m pytest -q

lint: install
	$(VENV)/bin/lint-imports

# The documentation site: installs the docs extra, then builds docs/_build/html with warnings as errors.
docs: $(VENV)/.docs-installed
	$(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

$(VENV)/.docs-installed: $(VENV)/.installed
	$(PY) -m pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[test,docs]'
	touch $@

# The viewer check: every preset's log and a live run opened in the open-source Foxglove Studio 1.48
# (installed from npm into build/viewer, pinned by tools/viewer/package-lock.json) in headless Chromium;
# screenshots into docs/figures/foxglove_*.png, exit 1 on a listed problem. Needs node/npm and chromium.
viewer: install
	$(PY) tools/viewer/screenshots.py --out docs/figures

bench: install
	$(PY) benchmarks/performance.py

clean:
	rm -rf $(VENV) logs/*.mcap logs/*.png logs/*.gif docs/_build docs/api docs/reference docs/auto_examples examples/logs
