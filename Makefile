# rangeproc: two commands on a fresh machine -> `make demo` and `make test`.
PY ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)
SEEDS ?= 1 2 3 4 5 6
MULTI_SEEDS ?= 1 2 3 4 5
REG_SEEDS ?= 1 2 3 4 5
HARBOUR_SEEDS ?= 1 2 3 4 5 6 7 8 9 10
FILTERS ?= ekf
SIGMA_FACTOR ?= 1
FUZZ_CASES ?= 2000
FUZZ_SEED ?= 1

.PHONY: install demo test docs fuzz bench bench-quick bench-campaign reproduce accuracy registration calibration-mc plan-check range-rate multi harbour autoferry sample-data lint clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,bench,docs]'
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

install: $(STAMP)

## demo: install and run the main job on the bundled sample data, then score it against truth.
demo: $(STAMP)
	$(BIN)/rangeproc run configs/sample.toml
	$(BIN)/rangeproc evaluate out/sample sample_data/truth.csv

## test: the test suite.
test: $(STAMP)
	$(BIN)/python -m pytest

## docs: the documentation site (mkdocs.yml, docs/) -> site/, every warning an error.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict --site-dir site

## fuzz: a fuzz campaign of FUZZ_CASES mutated runs in two processes; prints a table of outcomes.
fuzz: $(STAMP)
	$(BIN)/python bench/fuzz.py --cases $(FUZZ_CASES) --seed $(FUZZ_SEED)

## bench: time the pipeline and filter kernels against FilterPy / Stone Soup
## -> docs/measurements/bench.json (the speed page of the docs is generated from it).
bench: $(STAMP)
	$(BIN)/python bench/bench.py --out docs/measurements/bench.json

bench-quick: $(STAMP)
	$(BIN)/python bench/bench.py --quick

## bench-campaign: 20 sample-sized sorties serially and on a 1- and 2-worker local Dask cluster
bench-campaign: $(STAMP)
	$(BIN)/python bench/campaign.py

## reproduce: each source document's experiment (bench/reproduction/) -> reproduction/README.md
## (claim vs our figure table) and PNGs; ONLY="002 004" runs a subset.
reproduce: $(STAMP)
	$(BIN)/python -m bench.reproduction $(if $(ONLY),--only $(ONLY))

## accuracy: simulate several seeds, run, evaluate (with and without MISTRAM + theodolite),
## for each filter of FILTERS, the stated sigmas scaled by SIGMA_FACTOR -> docs/measurements/accuracy.json.
accuracy: $(STAMP)
	$(BIN)/python bench/reproduce.py --seeds $(SEEDS) --filters $(FILTERS) --sigma-factor $(SIGMA_FACTOR) \
		--out docs/measurements/accuracy.json

## registration: the registration sweep (simulator faults with truth, calibration on/off), REG_SEEDS
## -> docs/measurements/registration.json.
registration: $(STAMP)
	$(BIN)/python bench/registration.py --seeds $(REG_SEEDS) --out docs/measurements/registration.json

## range-rate: MISTRAM alone from a given state, default config against smoothers told the
## true noise and wild points -> docs/measurements/range_rate.json
range-rate: $(STAMP)
	$(BIN)/python bench/range_rate.py --out docs/measurements/range_rate.json

## plan-check: rangeproc plan's predicted sigma against what runs of the same flights
## achieve -> docs/measurements/plan_check.json, bench/plan_check.png
plan-check: $(STAMP)
	$(BIN)/python bench/plan_check.py --out docs/measurements/plan_check.json

## calibration-mc: the trajectory's sigma with drawn sensor biases, seeded Monte Carlo on
## simulated and recorded (A310 zero-g, ADS-B) flights -> docs/measurements/calibration_mc.json
calibration-mc: $(STAMP)
	$(BIN)/python bench/calibration_mc.py --out docs/measurements/calibration_mc.json

## multi: the several-objects sweep (simulator kinds x MULTI_SEEDS, against the true assignment)
## -> docs/measurements/multi.json.
multi: $(STAMP)
	$(BIN)/python bench/multi.py --seeds $(MULTI_SEEDS) --out docs/measurements/multi.json

## harbour: the simulator's harbour kind over HARBOUR_SEEDS, rangeproc and Stone Soup's GNN scored on
## each object's moving span (bench/harbour.py) -> docs/measurements/harbour.json.
harbour: $(STAMP)
	$(BIN)/python bench/harbour.py --gnn --seeds $(HARBOUR_SEEDS) --out docs/measurements/harbour.json

## autoferry: the real Autoferry data (../shared/realdata/autoferry, tools/autoferry.py) through
## rangeproc (with and without the camera bearings) and Stone Soup's GNN and JPDA trackers (the
## JPDA limited to 10 min a scenario), scored vs GNSS truth, with the acceptance block
## -> docs/measurements/autoferry.json.
autoferry: $(STAMP)
	$(BIN)/python bench/autoferry.py --json docs/measurements/autoferry.json

## sample-data: regenerate sample_data/ (seed 1, 120 s) and configs/sample.toml.
sample-data: $(STAMP)
	rm -rf sample_data && $(BIN)/rangeproc simulate sample_data --seed 1 --duration 120
	$(BIN)/python bench/make_sample_config.py sample_data/scenario.toml configs/sample.toml

lint: $(STAMP)
	$(BIN)/python -m pip install --quiet ruff
	$(BIN)/ruff check rangeproc tests

## clean: outputs, and numba cache files an older version left in the source tree (the
## kernels are cached outside it, keyed to their source: nothing to clean after an edit).
clean:
	rm -rf out bench/results.json .pytest_cache
	find rangeproc -name '*.nbi' -delete -o -name '*.nbc' -delete
