# mitsar: two commands on a fresh Debian machine (as root, or with sudo):
#   make demo   set everything up and run the paper's point-target demo (outputs in demo-output/)
#   make test   set everything up and run the test suite
VENV ?= .venv
PY := $(VENV)/bin/python
PYTEST_ARGS ?=

.PHONY: setup test demo examples lint bench clean fuzz docs wheel

setup:
	bash scripts/setup.sh $(VENV)

test: setup
	$(PY) -m pytest -q $(PYTEST_ARGS)

demo: setup
	$(VENV)/bin/mitsar demo -o demo-output --overwrite

# Every bundled example: ray-traced scenes, the paper's 2D/3D multipath cases, ambiguity maps,
# a short Monte Carlo, a walking person (moving shapes), a small sweep on Dask, the ablation
# figures and real flight (navigation errors, autofocus)
# (a few minutes; outputs in demo-output/examples).
examples: setup
	mkdir -p demo-output/examples
	$(VENV)/bin/mitsar simulate examples/scene_point_target.toml -o demo-output/examples/scene_raw.nc --overwrite
	$(VENV)/bin/mitsar focus demo-output/examples/scene_raw.nc -o demo-output/examples/scene_image.nc --overwrite
	$(VENV)/bin/mitsar metrics demo-output/examples/scene_image.nc
	for case in case1_2d case2_2d dihedral_3d trihedral_3d; do \
	  $(VENV)/bin/mitsar rays examples/$$case.toml -o demo-output/examples/$$case --overwrite || exit 1; done
	for case in dihedral_3d trihedral_3d; do \
	  $(VENV)/bin/mitsar simulate examples/$$case.toml -o demo-output/examples/$$case/raw.nc --overwrite && \
	  $(VENV)/bin/mitsar focus demo-output/examples/$$case/raw.nc -o demo-output/examples/$$case/image.nc --overwrite && \
	  $(VENV)/bin/mitsar plot demo-output/examples/$$case/raw.nc -o demo-output/examples/$$case/range_compressed.png --overwrite && \
	  $(VENV)/bin/mitsar plot demo-output/examples/$$case/image.nc -o demo-output/examples/$$case/image.png --overwrite || exit 1; done
	$(VENV)/bin/mitsar ambiguity examples/ambiguity_control_volume.toml -o demo-output/examples/ambiguity --overwrite
	$(VENV)/bin/mitsar run examples/walking_person.toml -o demo-output/examples/walking_person --overwrite
	$(VENV)/bin/mitsar sweep examples/campaign_tiny.toml --vary look.off_nadir_deg=54:57:1.5 \
	  --vary trajectory.speed=0.5,1.0 -n 2 -o demo-output/examples/sweep
	$(VENV)/bin/mitsar montecarlo examples/paper_point_target.toml -n 5 -o demo-output/examples/montecarlo --restart
	$(PY) examples/ablations.py -o demo-output/examples/ablations --overwrite
	$(PY) examples/real_flight.py -o demo-output/examples/real_flight --overwrite

# The sdist and the wheel in dist/ (examples and scenes inside). `make test` checks them:
# tests/test_wheel.py builds both in a temporary folder, installs the wheel in a fresh venv
# there and runs the CLI (every --help, demo, run, preview) from outside the checkout.
wheel: setup
	$(PY) -m build --no-isolation --outdir dist .

# The fuzz campaign of the input checks (docs/reliability.md): >= 1,000 bad inputs over every
# family, the table of verdicts; fails on a traceback, a silent acceptance, a hang or a crash.
fuzz: setup
	$(PY) scripts/fuzz.py --cases 1100

# The documentation site (mkdocs.yml): guides, API reference, plugin tables, tutorials executed
# with their outputs; --strict fails on a broken link or reference. Output in site/.
docs: setup
	$(PY) -c "import mkdocs, mkdocstrings, material, jupytext" 2>/dev/null || \
	  $(PY) -m pip install -q -e ".[docs]"
	NO_MKDOCS_2_WARNING=1 MPLBACKEND=Agg $(PY) -m mkdocs build --strict

lint: setup
	$(VENV)/bin/ruff check .

bench: setup
	$(PY) -m pip install -q -e ".[test,bench]" || echo "bench: FastSAR could not be installed; its benchmark skips"
	# Sionna RT pins exact mitsuba/drjit releases: its own venv, so it never moves mitsar's
	test -x .venv-sionna/bin/python || (python3 -m venv .venv-sionna && \
	  .venv-sionna/bin/python -m pip install -q sionna-rt==2.2.0) || \
	  echo "bench: Sionna RT could not be installed; bench_speed.py states the skip"
	MITSAR_SIONNA_PYTHON=$(CURDIR)/.venv-sionna/bin/python $(PY) benchmarks/run_all.py

clean:
	rm -rf demo-output .pytest_cache build dist *.egg-info
