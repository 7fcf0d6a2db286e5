# SPDX-License-Identifier: GPL-3.0-or-later
# Hybrid RT: quick start is `make demo` and `make test`; both set up .venv on first use.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help

PYTHON_VENV := .venv/bin/python
PYTEST_ARGS ?=
# Test worker processes (pytest-xdist); 0 runs the suite in this process.
TEST_WORKERS ?= 2

.PHONY: help setup demo test bench pictures light package clean distclean

help:
	@echo "make demo       render the generated Chess scene with Hybrid RT (out/demo*.png, timing report)"
	@echo "make test       run the test suite"
	@echo "make bench      run the benchmark, results in out/bench.json and out/device_report.md"
	@echo "make pictures   render docs/pictures/*.png: each scene in every mode next to EEVEE and Cycles (~11 min)"
	@echo "make light      interiors: Hybrid RT, EEVEE and Cycles side by side (luminance, FLIP), docs/pictures/lighting.json"
	@echo "make package    build the installable extension zips (Linux, Windows) into dist/"
	@echo "make clean      remove build outputs (dist/, wheels/, out/, caches)"
	@echo "make distclean  clean, and remove the virtual environment .venv"

# System libraries, Python 3.11, .venv and the pinned requirements (quick when all present).
setup:
	@bash scripts/bootstrap.sh

demo: setup
	@mkdir -p out
	$(PYTHON_VENV) scripts/demo.py

# pytest's exit status is also written to $PYTEST_STATUS_FILE when set (.ci/run reads it to
# tell "no tests collected" (5) from failures).
test: setup
	@status=0; $(PYTHON_VENV) -m pytest tests -q -n $(TEST_WORKERS) --durations=15 $(PYTEST_ARGS) || status=$$?; \
	if [ -n "$${PYTEST_STATUS_FILE:-}" ]; then echo $$status > "$$PYTEST_STATUS_FILE"; fi; \
	if [ $$status -eq 5 ]; then echo "make test: pytest collected no tests (exit status 5)" >&2; fi; \
	exit $$status

bench: setup
	@mkdir -p out
	$(PYTHON_VENV) -m benchmarks.bench --variants both --json out/bench.json --device-report out/device_report.md

pictures: setup
	$(PYTHON_VENV) scripts/make_pictures.py

light: setup
	$(PYTHON_VENV) scripts/measure_light.py --json docs/pictures/lighting.json

package: setup
	$(PYTHON_VENV) scripts/build_extension.py

clean:
	rm -rf dist wheels out build tests/_failures .pytest_cache
	find . -path ./.venv -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf .venv
