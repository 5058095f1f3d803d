# amaranth: UnusedElaboratable=no
"""The shared pieces of verif/: the build cache's place and lock, the one
clock description and camera drive, the hardware progress line."""
from __future__ import annotations

import multiprocessing
import re
import time

import numpy as np
import pytest

from verif.clocks import LEFT_START_DELAY, RIGHT_LAG, Clocks, camera_waveforms, clip_timing
from verif.end_to_end import hardware_progress
from verif.verilator import EMISSIONS, build_lock, build_root, simulation_verilog


def test_build_root_follows_the_environment_then_the_current_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("STEREOGEST_BUILD_DIR", str(tmp_path / "cache"))
    assert build_root() == tmp_path / "cache" / "verilator"
    assert build_root("cocotb") == tmp_path / "cache" / "cocotb"
    monkeypatch.delenv("STEREOGEST_BUILD_DIR")
    monkeypatch.chdir(tmp_path)
    assert build_root() == tmp_path / "build" / "verilator"


def _hold(folder, log, delay):
    with build_lock(folder):
        with open(log, "a") as f:
            f.write("in\n")
        time.sleep(delay)
        with open(log, "a") as f:
            f.write("out\n")


def test_build_lock_lets_one_process_in_at_a_time(tmp_path):
    folder, log = tmp_path / "verilator" / "key", tmp_path / "log"
    ctx = multiprocessing.get_context("fork")
    procs = [ctx.Process(target=_hold, args=(folder, log, 0.3)) for _ in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(timeout=30)
        assert p.exitcode == 0
    assert log.read_text().split() == ["in", "out"] * 3


def test_clocks_are_passed_to_the_harnesses_in_one_order():
    c = Clocks(sync_ps=8_000, left_ps=4_000, left_phase_ps=100, right_ps=6_000,
               right_phase_ps=2_000)
    assert c.camera_args() == ["8000", "4000", "100", "6000", "2000"]
    assert c.sync_hz == pytest.approx(125e6)


def test_right_camera_starts_its_lag_after_the_left():
    frames = np.zeros((1, 4, 16), np.uint8)
    timing = clip_timing(8, 4, flush=10)
    left, right = camera_waveforms(frames, frames, timing)
    assert left.start_delay == LEFT_START_DELAY
    assert right.start_delay == LEFT_START_DELAY + RIGHT_LAG
    # vertical blanking covers the pipeline's flush in camera cycles (2 per pipeline cycle)
    assert timing.front_porch + timing.back_porch >= 2 * 10


def test_simulation_verilog_refuses_an_unknown_emission():
    from amaranth.hdl import Module, Signal
    with pytest.raises(ValueError, match=re.escape(f"emission must be one of {list(EMISSIONS)}")):
        simulation_verilog(Module(), "top", [Signal()], "iverilog")


def test_builders_refuse_an_unknown_emission():
    # before anything is elaborated (a 64x32 core would take seconds)
    from verif import pipeline, system
    for build in (pipeline.build_pipeline, system.build_system):
        with pytest.raises(ValueError, match="emission must be one of"):
            build(64, 32, emission="iverilog")


def test_hardware_progress_line():
    line = hardware_progress(10, 100, 3_500_000, 35.0)
    assert line == ("  hardware: frame 10/100, 3,500,000 cycles, 100,000 cycles/s, "
                    "315 s left")
    assert "time left unknown" in hardware_progress(0, 100, 0, 0.0)
