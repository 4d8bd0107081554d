# The two commands of the README, and the steps under them.
#   make demo   set up, build, and run a scenario on the default virtual board, with a report
#   make test   set up, build, and run every test (unit, native C, HIL on simavr and QEMU),
#               one pytest-xdist worker per core, each with its own boards, each taking
#               the next test as it is done with one (the long ones first: tests/conftest.py)

VEHIL := .venv/bin/vehil

.PHONY: setup build demo test lint clean

setup:
	@scripts/setup

build: setup
	$(VEHIL) build

demo: build
	$(VEHIL) run sine --board simavr

test: build lint
	.venv/bin/pytest -n auto

lint: setup
	.venv/bin/ruff check host tests platform firmware/build_id.py
	.venv/bin/mypy

clean:
	rm -rf build .pio sim/build
