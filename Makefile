# hyper-nav: two commands. `make run` sets up and flies the default scenario;
# `make test` sets up and runs the whole suite.
SHELL := /bin/bash
SCENARIO ?= default
RUN_NAME ?= $(notdir $(basename $(SCENARIO)))_$(shell date +%Y%m%d-%H%M%S)
ENV := source tools/env.sh &&

.PHONY: setup run test clean bench help reproduce-seed000

help:
	@echo "make run   - set up, run the node graph on SCENARIO=$(SCENARIO), record bags/$(RUN_NAME), report"
	@echo "make test  - set up and run the whole test suite"
	@echo "make bench - print performance figures"
	@echo "make reproduce-seed000 - seed 000 RL-DLAC: bound, reward surface, Table 5 over 10 seeds, identifiers, Figs. 10-11"
	@echo "make clean - remove build outputs (build/ install/ log/); .venv stays"

setup:
	@bash tools/setup.sh

run: setup
	@$(ENV) ros2run hyper_nav_sim run_graph --scenario $(SCENARIO) --record bags/$(RUN_NAME) --report

test: setup
	@$(ENV) python -m pytest -c pytest.ini

bench: setup
	@$(ENV) python benchmarks/run_all.py

reproduce-seed000: setup
	@$(ENV) ros2run hyper_nav_aiding reproduce_seed000 --out results/seed000_rl_dlac

clean:
	rm -rf build install log
