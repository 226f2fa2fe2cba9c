# hyper-nav: two commands. `make run` sets up and flies the default scenario;
# `make test` sets up and runs the whole suite.
SHELL := /bin/bash
SCENARIO ?= default
RUN_NAME ?= $(notdir $(basename $(SCENARIO)))_$(shell date +%Y%m%d-%H%M%S)
ENV := source tools/env.sh &&

.PHONY: setup run test clean bench help seed003

help:
	@echo "make run   - set up, run the node graph on SCENARIO=$(SCENARIO), record bags/$(RUN_NAME), report"
	@echo "make test  - set up and run the whole test suite"
	@echo "make bench - print performance figures"
	@echo "make seed003 - reproduce seed 003 Table 3 / Figs. 6-9 with the PCRB (results/seed003; SEEDS=20 WORKERS=1)"
	@echo "make clean - remove build outputs (build/ install/ log/); .venv stays"

setup:
	@bash tools/setup.sh

run: setup
	@$(ENV) ros2run hyper_nav_sim run_graph --scenario $(SCENARIO) --record bags/$(RUN_NAME) --report

test: setup
	@$(ENV) python -m pytest -c pytest.ini

bench: setup
	@$(ENV) python benchmarks/run_all.py

SEEDS ?= 20
WORKERS ?= 1
seed003: setup
	@$(ENV) ros2run hyper_nav_aiding reproduce_seed003 --seeds $(SEEDS) --workers $(WORKERS) --out results/seed003

clean:
	rm -rf build install log
