# coordarm: `make demo` and `make test` work on a fresh machine (Python 3.10+, gcc).
VENV   ?= .venv
PY     := $(VENV)/bin/python
PYTHON ?= python3

.PHONY: install demo test bench clean

install: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	touch $@

demo: install
	$(VENV)/bin/coordarm run line --out logs/line.mcap --overwrite

test: install
	$(PY) -m pytest -q

bench: install
	$(PY) benchmarks/run_benchmarks.py

clean:
	rm -rf $(VENV) logs/*.mcap logs/*.png logs/*.gif
