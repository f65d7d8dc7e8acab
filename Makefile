# coordarm: `make demo` and `make test` work on a fresh machine (Python 3.11+, gcc).
# make install pins every package to the tested versions of constraints.txt (pyproject.toml has ranges).
VENV   ?= .venv
PY     := $(VENV)/bin/python
PYTHON ?= python3

.PHONY: install demo test lint bench clean

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

bench: install
	$(PY) benchmarks/performance.py

clean:
	rm -rf $(VENV) logs/*.mcap logs/*.png logs/*.gif
