# Two commands do all set-up on a fresh clone: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test bench timing clean model hps-bundle deploy

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/stereogest demo --output demo-out

# One pytest worker per core (pytest-xdist), a test file per worker (order:
# tests/conftest.py); Verilated builds are shared through a lock per build.
JOBS ?= auto

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(JOBS) --dist loadfile

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_model.py
	$(BIN)/python benchmarks/stereo_quality.py

# Routed timing on an ECP5 (nextpnr): every block, the whole matcher, the whole
# pipeline with three placer seeds, thesis parameters and with the default rig's
# calibration and hand tracking (hours on this 2-core machine; figures in
# hdl/README.md). PR_JOBS placements at a time.
PR_JOBS ?= 2
timing: $(STAMP)
	mkdir -p build
	$(BIN)/stereogest timing --block all -o build/timing_blocks.json
	$(BIN)/stereogest timing --block matcher -o build/timing_matcher.json
	$(BIN)/stereogest timing --block pipeline --seeds 1,2,3 --jobs $(PR_JOBS) \
		-o build/timing_pipeline.json
	$(BIN)/stereogest chessboards --count 1 -o build/chessboards --truth build/rig_calibration.json
	$(BIN)/stereogest timing --block pipeline --seeds 1,2,3 --jobs $(PR_JOBS) \
		--calibration build/rig_calibration.json --hand-tracking \
		-o build/timing_pipeline_calibrated.json

# The HPS application and its trained model, as deployed to the board: the
# default recogniser (Gaussian, with rejection); thesis7.json is the thesis'
# discrete recogniser (§9.4), kept for comparison; continuous7.json is for
# --spotting continuous (gestures one after another).
MODEL  ?= sw_hps/models/gestures7.json
BUNDLE := build/stereogest-hps.tar.gz

model: $(STAMP)
	mkdir -p build
	$(BIN)/stereogest gestures -o build/corpus.npz --per-class 180 --people 3 --seed 1
	$(BIN)/stereogest train build/corpus.npz -o sw_hps/models/gestures7.json --seed 0
	$(BIN)/stereogest train build/corpus.npz -o sw_hps/models/thesis7.json --seed 0 \
		--emission discrete \
		--states 5 --no-reject
	$(BIN)/stereogest train build/corpus.npz -o sw_hps/models/continuous7.json --seed 0 \
		--emission discrete --continuous

hps-bundle: $(STAMP)
	$(BIN)/python -m sw_hps.bundle --model $(MODEL) -o $(BUNDLE)

deploy: hps-bundle
	@test -n "$(HPS)" || { echo "usage: make deploy HPS=user@host" >&2; exit 2; }
	scp $(BUNDLE) $(HPS):stereogest-hps.tar.gz
	ssh $(HPS) 'mkdir -p stereogest && tar xzf stereogest-hps.tar.gz -C stereogest'
	@echo "Start it on the board:"
	@echo "  ssh $(HPS) 'cd stereogest && sudo python3 -m sw_hps --model model.json --bus devmem --robot serial:/dev/ttyUSB0'"

clean:
	rm -rf $(VENV) demo-out build .pytest_cache *.egg-info
