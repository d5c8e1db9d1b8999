# mitsar: two commands on a fresh Debian machine (as root, or with sudo):
#   make demo   set everything up and run the paper's point-target demo (outputs in demo-output/)
#   make test   set everything up and run the test suite
VENV ?= .venv
PY := $(VENV)/bin/python
PYTEST_ARGS ?=

.PHONY: setup test demo lint bench clean

setup:
	bash scripts/setup.sh $(VENV)

test: setup
	$(PY) -m pytest -q $(PYTEST_ARGS)

demo: setup
	$(VENV)/bin/mitsar demo -o demo-output --overwrite

lint: setup
	$(VENV)/bin/ruff check .

bench: setup
	$(PY) benchmarks/run_all.py

clean:
	rm -rf demo-output .pytest_cache build *.egg-info
