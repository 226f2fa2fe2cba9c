# hyper-nav: two commands. `make run` sets up and flies the default scenario;
# `make test` sets up and runs the whole suite.
SHELL := /bin/bash
SCENARIO ?= default
RUN_ARGS ?=
RUN_NAME ?= $(notdir $(basename $(SCENARIO)))_$(shell date +%Y%m%d-%H%M%S)
ENV := source tools/env.sh &&

.PHONY: setup run load-run test clean bench help train-lekf repro-guidance repro-seed000 repro-seed001 repro-seed002 repro-seed003 repro-seed004 repro-aided-tracking repro-walk study-lincov study-lincov-mc \
	seed003 seed004 reproduce-seed000

help:
	@echo "make run   - set up, run the node graph on SCENARIO=$(SCENARIO), record bags/$(RUN_NAME), report"
	@echo "             (RUN_ARGS=\"--set duration_s=60\" passes more run_graph arguments; exits 1 if the report fails)"
	@echo "make load-run - make run under load: a busy process per core (nice 0), every node frozen 5 s in turn"
	@echo "             (LOAD_ARGS=\"--freeze-each 5\" passes load_flight options, e.g. --cores 0; PASS = nothing lost)"
	@echo "make test  - set up and run the whole test suite"
	@echo "make bench - print performance figures"
	@echo "make clean - remove build outputs (build/ install/ log/); .venv stays"
	@echo "make train-lekf    - fly the seed 002 data set and train the L-EKF (writes the shipped parameter set)"
	@echo "paper reproductions (our numbers beside the paper's; JSON and PNGs in results/<seed>/; ARGS=... passes options):"
	@echo "make repro-seed000 - seed 000 RL-DLAC: bound, reward surface, Table 5 over 10 seeds, identifiers, Figs. 10-11"
	@echo "make repro-seed001 - seed 001 HWIL figures (per-axis error bounds): Monte Carlo over 10 seeds on the LCI filter"
	@echo "make repro-seed002 - seed 002 Table 2 / Figs. 6-8 over Monte Carlo radar noise"
	@echo "make repro-seed003 - seed 003 Table 3 / Figs. 6-9 with the PCRB (SEEDS=20 WORKERS=1)"
	@echo "make repro-seed004 - seed 004 Tables 4-5 / Figs. 5-6: virtual GNSS under lock loss, both worlds (3 seeds)"
	@echo "make repro-aided-tracking - issue 23: unaided vs INS-aided receiver through a plasma blackout (10 seeds),"
	@echo "                            then the filter in the loop: 5 cases beside seed 004 (10 seeds), and the"
	@echo "                            pull-up flight with aiding 0.1 s and 0.02 s old (10 seeds each)"
	@echo "make repro-guidance - issue 36: guidance in the loop, miss distance on truth / delayed nav / blackout / INS (10 seeds)"
	@echo "design studies (issue 39; JSON and PNGs in results/lincov*/; ARGS=... passes options):"
	@echo "make study-lincov    - LinCov error budget by source (ARGS=\"--scenario seed004 --blackout 100:220 --sweep imu\")"
	@echo "make study-lincov-mc - LinCov vs Monte Carlo of the filter (ARGS=\"--runs 200 --workers 2 --split\")"
	@echo "make repro-walk    - the walk_0827 recording (u-blox + MEMS IMU): TC / LC / SPP against RTK, outages"

setup:
	@bash tools/setup.sh

run: setup
	@$(ENV) ros2run hyper_nav_workbench run_graph --scenario $(SCENARIO) --record bags/$(RUN_NAME) --report $(RUN_ARGS)

LOAD_ARGS ?= --freeze-each 5
load-run: setup
	@$(ENV) ros2run hyper_nav_workbench load_flight $(LOAD_ARGS) -- --scenario $(SCENARIO) --record bags/load_$(RUN_NAME) --report $(RUN_ARGS)

# the node-graph tests one at a time and, beside them at nice 19, the unit tests on
# two workers (tools/run_tests.sh); TEST_ARGS go to both pytest runs
test: setup
	@bash tools/run_tests.sh $(TEST_ARGS)

bench: setup
	@$(ENV) python benchmarks/run_all.py

train-lekf: setup
	@$(ENV) ros2run hyper_nav_repro train_lekf --epochs 12

repro-seed002: setup
	@$(ENV) ros2run hyper_nav_repro repro_seed002 --out results/seed002 $(ARGS)

repro-seed001: setup
	@$(ENV) ros2run hyper_nav_repro repro_seed001 --out results/seed001 $(ARGS)

repro-seed000: setup
	@$(ENV) ros2run hyper_nav_repro repro_seed000 --out results/seed000_rl_dlac $(ARGS)

SEEDS ?= 20
WORKERS ?= 1
repro-seed003: setup
	@$(ENV) ros2run hyper_nav_repro repro_seed003 --seeds $(SEEDS) --workers $(WORKERS) --out results/seed003 $(ARGS)

repro-seed004: setup
	@$(ENV) ros2run hyper_nav_repro repro_seed004 --out results/seed004 $(ARGS)

repro-aided-tracking: setup
	@$(ENV) ros2run hyper_nav_repro repro_aided_tracking --out results/aided_tracking $(ARGS)
	@$(ENV) ros2run hyper_nav_repro repro_aided_blackout --out results/aided_tracking
	@$(ENV) ros2run hyper_nav_repro repro_aided_blackout --pullup --out results/aided_tracking_pullup
	@$(ENV) ros2run hyper_nav_repro repro_aided_blackout --pullup --aiding-delay 0.02 --out results/aided_tracking_pullup_fresh
repro-guidance: setup
	@$(ENV) ros2run hyper_nav_guidance repro_guidance --out results/guidance $(ARGS)
repro-walk: setup
	@$(ENV) ros2run hyper_nav_repro repro_walk --out results/walk $(ARGS)

study-lincov: setup
	@$(ENV) ros2run hyper_nav_repro study_lincov --out results/lincov $(ARGS)

study-lincov-mc: setup
	@$(ENV) ros2run hyper_nav_repro study_lincov_mc --out results/lincov_mc $(ARGS)

# earlier names
reproduce-seed000: repro-seed000
seed003: repro-seed003
seed004: repro-seed004

clean:
	rm -rf build install log
