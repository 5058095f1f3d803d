"""The resource report of the whole design (soc.resources): its memory count on
small designs, the M10K blocks per memory and consumer, and how it sets our
figures beside Table 23 and the device."""
from __future__ import annotations

import tempfile
from pathlib import Path

from amaranth.back import rtlil

from soc import resources
from soc.fifo_slave import FifoSlave
from soc.frame_buffer import FrameBuffer
from soc.vga_timing import VgaMode


def test_memory_bits_counts_width_times_depth():
    from hdl.synthesis import component_ports
    mode = VgaMode(1_000_000, 16, 1, 2, 1, 8, 1, 1, 1, True, True)
    fb = FrameBuffer(12, 6, mode, pixel_bits=3, scale=1)
    bits = resources.memory_bits(rtlil.convert(fb, name="fb", ports=component_ports(fb)))
    assert sorted(bits.values()) == [12 * 6 * 3]
    fifo = FifoSlave(data_bits=18, depth=8)
    bits = resources.memory_bits(rtlil.convert(fifo, name="fifo", ports=fifo.ports()))
    assert sorted(bits.values()) == [8 * 19, 8 * 19]        # 18 data bits and FLAG / PRESENT


def _netlist(cells: dict) -> str:
    """A yosys ``write_json`` netlist holding ``{name: type}`` cells."""
    import json
    return json.dumps({"modules": {"top": {"cells": {
        name: {"hide_name": 0, "type": kind, "connections": {}}
        for name, kind in cells.items()}}}}, indent=2)


def test_mapped_memories_names_each_block_after_its_memory():
    text = _netlist({"matcher.census_left.window.rows_long.mem.0.0.0": "MISTRAL_M10K",
                     "matcher.census_left.window.rows_long.mem.1.0.0": "MISTRAL_M10K",
                     "matcher.shd.windows.ring_3.0.0.0": "MISTRAL_MLAB",
                     "matcher.shd.windows.ring_3.1.0.0": "MISTRAL_M10K",
                     "$auto$alumacc.cc:485$9": "MISTRAL_ALUT6",
                     "some_ff": "MISTRAL_FF"})
    assert resources.mapped_memories(text) == {
        "matcher.census_left.window.rows_long.mem": {"m10k": 2, "mlab": 0},
        "matcher.shd.windows.ring_3": {"m10k": 1, "mlab": 1}}


def test_m10k_consumers_sums_blocks_per_consumer():
    blocks = {"frame_buffer.memory": {"m10k": 38, "mlab": 0},
              "pipeline.matcher.census_left.window.rows_long.mem": {"m10k": 14, "mlab": 0},
              "pipeline.matcher.census_right.window.rows_short.mem": {"m10k": 9, "mlab": 0},
              "pipeline.rectify_left.bank_0": {"m10k": 12, "mlab": 0},
              "pipeline.new_stage.buffer": {"m10k": 3, "mlab": 0},
              "pipeline.spotting.ring": {"m10k": 0, "mlab": 2}}
    use = resources.m10k_consumers(blocks, {"frame_buffer.memory": 307_200})
    assert use["total"] == 76 and use["headroom"] == 397 - 76
    assert use["percent"] == round(100 * 76 / 397, 1)
    assert use["headroom_percent"] == round(100 * 321 / 397, 1)
    assert use["consumers"] == {"frame buffer (VGA view)": 38, "census row buffers": 23,
                                "rectifier (row buffers, grid, lines)": 12,
                                "pipeline.new_stage": 3}      # unknown: its module's path
    assert list(use["consumers"].values()) == sorted(use["consumers"].values(), reverse=True)
    assert use["memories"][0] == {"memory": "frame_buffer.memory", "m10k": 38, "mlab": 0,
                                  "bits": 307_200}
    assert use["memories"][-1]["memory"] == "pipeline.spotting.ring"
    assert sum(m["m10k"] for m in use["memories"]) == use["total"]


def test_frame_buffer_blocks_by_yosys_at_both_scales():
    """A real yosys run: the frame buffer's blocks are found under its memory,
    and half resolution needs fewer of them."""
    from amaranth.hdl import DomainRenamer

    from hdl.synthesis import find_yosys, synthesize
    found = {}
    for scale in (1, 2):
        fb = DomainRenamer({"vga": "sync"})(FrameBuffer(64, 64, scale=scale))
        with tempfile.TemporaryDirectory() as keep:
            report = synthesize(fb, "frame_buffer", find_yosys(), keep=Path(keep),
                                autoname=False)
            blocks = resources.mapped_memories((Path(keep) / "net.json").read_text())
        assert set(blocks) == {"memory"} and blocks["memory"]["m10k"] == report["m10k"]
        found[scale] = report["m10k"]
    assert found[1] > found[2] >= 1


def _elaborated(design, name):
    """``rtlil.convert`` (and synthesis) faked: the design is elaborated, but no
    RTLIL is written."""
    from amaranth.hdl import Fragment
    Fragment.get(design, None)
    return ""


def test_estimate_sets_the_figures_beside_table_23_and_the_device(monkeypatch):
    import hdl.synthesis
    calls = []

    def fake_synthesize(dut, name, yosys, keep=None, autoname=True):
        _elaborated(dut, name)
        calls.append(name)
        (keep / "net.json").write_text(_netlist(
            {f"mem_{k}.{k}.0.0": "MISTRAL_M10K" for k in range(50 + len(calls))}))
        return {"alm_estimate": 2_000, "luts": 3_000, "ffs": 8_000, "m10k": 50 + len(calls),
                "mlab": 1, "tool": "yosys", "levels": len(calls), "depth_ns": float(len(calls))}

    monkeypatch.setattr(hdl.synthesis, "find_yosys", lambda: ["yosys"])
    monkeypatch.setattr(hdl.synthesis, "synthesize", fake_synthesize)
    monkeypatch.setattr(resources, "memory_bits", lambda text: {"a": 1000, "b": 24})
    monkeypatch.setattr("amaranth.back.rtlil.convert", _elaborated)
    report = resources.estimate(64, 48)
    # one yosys run per part, summed; the posture path's two stages alone beside them
    assert calls == ["pipeline", "frame_buffer", "fifo_slave", "uart_slave", "posture_slave",
                     "config_left", "config_right", "posture_opening", "posture"]
    assert report["estimate"]["alms"] == 14_000 and report["estimate"]["memory_bits"] == 1024
    assert report["estimate"]["m10k"] == 7 * 50 + 28 and report["parts"]["pipeline"]["m10k"] == 51
    assert report["posture_path"]["alms"] == 4_000 and report["posture_path"]["m10k"] == 117
    assert report["device_use_percent"]["registers"] == round(100 * 56_000 / 128_280, 1)
    assert report["logic_depth"]["lut_levels"] == 7      # the worst part
    assert report["fits"] is True             # 14,000 ALMs, 56,000 registers, 378 M10K
    assert report["thesis_table_23"] == {"alms": 21_941, "registers": 45_819,
                                         "memory_bits": 2_341_913}
    assert report["device"]["name"] == "5CSEMA5F31C6"
    # the blocks per memory add up to the parts' counts; the default core
    use = report["m10k_consumers"]
    assert use["total"] == report["estimate"]["m10k"] and use["headroom"] == 397 - 378
    assert use["consumers"]["frame buffer (VGA view)"] == 52
    assert use["consumers"]["pipeline"] == 51       # a memory of no known consumer
    assert report["vga_scale"] == 2 and report["rectification"] is False
    assert report["hand_tracking"] == {"track_gate": 0, "hand_rows": 0, "posture_gate": 0}


def test_estimate_builds_the_core_it_is_asked_for(monkeypatch):
    """--hand-tracking and --vga-scale reach the core that is synthesized."""
    import dataclasses

    import hdl.synthesis
    import soc.core
    from sim.model.pipeline import PipelineParams, hand_tracking_for
    cores = []
    real = soc.core.StereogestCore

    def spy(*args, **kwargs):
        cores.append(real(*args, **kwargs))
        return cores[-1]

    def fake_synthesize(dut, name, yosys, keep=None, autoname=True):
        _elaborated(dut, name)
        return {"alm_estimate": 0, "luts": 0, "ffs": 0, "m10k": 0, "mlab": 0,
                "tool": "yosys", "levels": 0, "depth_ns": 0.0}
    monkeypatch.setattr(soc.core, "StereogestCore", spy)
    monkeypatch.setattr(hdl.synthesis, "find_yosys", lambda: ["yosys"])
    monkeypatch.setattr(hdl.synthesis, "synthesize", fake_synthesize)
    monkeypatch.setattr(resources, "memory_bits", lambda text: {})
    monkeypatch.setattr("amaranth.back.rtlil.convert", _elaborated)
    params = dataclasses.replace(PipelineParams(), **hand_tracking_for(64))
    report = resources.estimate(64, 48, params=params, vga_scale=1)
    assert cores and all(c.params == params and c.frame_buffer.scale == 1 for c in cores)
    assert report["hand_tracking"] == hand_tracking_for(64) and report["vga_scale"] == 1
