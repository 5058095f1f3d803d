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

.PHONY: docs
docs: $(STAMP)
	$(BIN)/sphinx-build -W --keep-going -q -b html docs build/docs

demo: $(STAMP)
	$(BIN)/stereogest demo --output demo-out

# One pytest worker per core (pytest-xdist), a test file per worker (order:
# tests/conftest.py); Verilated builds are shared through a lock per build.
JOBS ?= auto

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(JOBS) --dist loadfile

# Every recorded figure with its command and commit (docs/figures/), then the
# quick benchmarks measured again on this machine; the others take minutes to
# hours each (their commands are in the figures).
bench: $(STAMP)
	$(BIN)/python benchmarks/figures.py
	$(BIN)/python benchmarks/bench_model.py
	$(BIN)/python benchmarks/stereo_quality.py

# Routed timing on an ECP5 (nextpnr): every block, the whole matcher, the whole
# pipeline with three placer seeds, thesis parameters and with the default rig's
# calibration and hand tracking (hours on this 2-core machine; figures in
# docs/figures/fpga.md). PR_JOBS placements at a time. The two pipeline runs become the
# record hdl/timing_pipeline.json and the table in docs/figures/fpga.md, which make test
# checks against the hardware (a failed seed still writes them: the table says it).
PR_JOBS ?= 2
timing: $(STAMP)
	mkdir -p build
	$(BIN)/stereogest timing --block all -o build/timing_blocks.json
	$(BIN)/stereogest timing --block matcher -o build/timing_matcher.json
	-$(BIN)/stereogest timing --block pipeline --seeds 1,2,3 --jobs $(PR_JOBS) \
		-o build/timing_pipeline.json
	$(BIN)/stereogest chessboards --count 1 -o build/chessboards --truth build/rig_calibration.json
	-$(BIN)/stereogest timing --block pipeline --seeds 1,2,3 --jobs $(PR_JOBS) \
		--calibration build/rig_calibration.json --hand-tracking \
		-o build/timing_pipeline_calibrated.json
	$(BIN)/python -m hdl.timing_record build/timing_pipeline.json \
		build/timing_pipeline_calibrated.json -o hdl/timing_pipeline.json --page docs/figures/fpga.md

# The HPS application and its trained model, as deployed to the board: the
# default recogniser (Gaussian, with rejection); thesis7.json is the thesis'
# discrete recogniser (§9.4), kept for comparison; continuous7.json is for
# --spotting continuous (gestures one after another); posture.json names the
# posture of the rendered people's hands (docs/design/posture.md).
MODEL  ?= sw_hps/models/gestures7.json
# The continuous model's posture commands (docs/design/posture.md, "Posture commands"): chosen
# on development seeds by benchmarks/command_postures.py (docs/figures/posture.md).
COMMAND_POSTURES := asl1,asl2,asl3,asl4
COMMAND_SHARE    := 0.5
STOP_POSTURE     := fist
STOP_FRAMES      := 6
RELEASE_FRAMES   := 5
NEUTRAL_POSTURES := asl0
BUNDLE := build/stereogest-hps.tar.gz

model: $(STAMP)
	mkdir -p build
	$(BIN)/stereogest gestures -o build/corpus.npz --per-class 180 --people 3 --seed 1
	$(BIN)/stereogest train build/corpus.npz -o sw_hps/models/gestures7.json --seed 0
	$(BIN)/stereogest train build/corpus.npz -o sw_hps/models/thesis7.json --seed 0 \
		--emission discrete \
		--states 5 --no-reject
	$(BIN)/stereogest train build/corpus.npz -o sw_hps/models/continuous7.json --seed 0 \
		--emission discrete --continuous --verifier sw_hps/models/gestures7.json
	$(BIN)/stereogest posture-commands sw_hps/models/continuous7.json \
		--command $(COMMAND_POSTURES) --share $(COMMAND_SHARE) --stop $(STOP_POSTURE) \
		--stop-frames $(STOP_FRAMES) --release-frames $(RELEASE_FRAMES) \
		--neutral $(NEUTRAL_POSTURES) --power fingers
	$(BIN)/stereogest postures -o build/postures_easy.npz --people 100 --seed 1000 --quiet
	$(BIN)/stereogest postures -o build/postures_hard.npz --people 200 --seed 2000 \
		--scene hard --quiet
	$(BIN)/stereogest train-posture build/postures_easy.npz build/postures_hard.npz \
		-o sw_hps/models/posture.json --groups subject --copies 0 --seed 0

# The standard library is enough to pack the bundle (the system Python; the
# model is fully checked when numpy is importable, else on the board at start).
hps-bundle:
	$(PYTHON) -m sw_hps.bundle --model $(MODEL) -o $(BUNDLE)

# make deploy HPS=user@host [HPS_DIR=stereogest]: upload the bundle to the
# login's home, then the bundle's install.sh swaps a fresh tree in at HPS_DIR
# (relative to that home, or absolute). OpenSSH 9+ scp speaks SFTP, which
# dropbear-based images lack: then it retries with the legacy protocol (-O).
HPS_DIR ?= stereogest
HPS_TARBALL := stereogest-hps.tar.gz

deploy:
	@test -n "$(HPS)" || { echo "make deploy: HPS=user@host is required (the board's ssh login, e.g. HPS=root@de1soc)" >&2; exit 2; }
	@case "$(HPS_DIR)" in ''|*[!A-Za-z0-9._/+-]*) echo "make deploy: HPS_DIR must be a path of letters, digits and . _ / + -, got '$(HPS_DIR)'" >&2; exit 2;; esac
	@$(MAKE) --no-print-directory hps-bundle
	scp $(BUNDLE) $(HPS):$(HPS_TARBALL) || { echo "scp failed; retrying with scp -O (servers without SFTP, e.g. dropbear)" >&2; scp -O $(BUNDLE) $(HPS):$(HPS_TARBALL); }
	ssh $(HPS) 't=$$(mktemp "$${TMPDIR:-/tmp}/stereogest-install.XXXXXX") && tar -xzOf $(HPS_TARBALL) install.sh >"$$t" && sh "$$t" $(HPS_TARBALL) $(HPS_DIR); s=$$?; rm -f "$$t"; exit $$s'
	@$(PYTHON) -m sw_hps.bundle --next-steps $(HPS) --dir $(HPS_DIR)

clean:
	rm -rf $(VENV) demo-out build .pytest_cache *.egg-info
