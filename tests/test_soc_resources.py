"""The resource report of the whole design (soc.resources): its memory count on
small designs, and how it sets our figures beside Table 23 and the device."""
from __future__ import annotations

from amaranth.back import rtlil

from soc import resources
from soc.fifo_slave import FifoSlave
from soc.frame_buffer import FrameBuffer
from soc.vga_timing import VgaMode


def test_memory_bits_counts_width_times_depth():
    from hdl.synthesis import component_ports
    mode = VgaMode(1_000_000, 16, 1, 2, 1, 8, 1, 1, 1, True, True)
    fb = FrameBuffer(12, 6, mode, pixel_bits=3)
    bits = resources.memory_bits(rtlil.convert(fb, name="fb", ports=component_ports(fb)))
    assert sorted(bits.values()) == [12 * 6 * 3]
    fifo = FifoSlave(data_bits=18, depth=8)
    bits = resources.memory_bits(rtlil.convert(fifo, name="fifo", ports=fifo.ports()))
    assert sorted(bits.values()) == [8 * 18, 8 * 18]


def test_estimate_sets_the_figures_beside_table_23_and_the_device(monkeypatch):
    import hdl.synthesis
    calls = []

    def fake_synthesize(dut, name, yosys):
        calls.append((type(dut).__name__, name))
        return {"alm_estimate": 16_035, "luts": 30_000, "ffs": 64_140, "m10k": 400,
                "mlab": 3, "tool": "yosys", "levels": 9, "delay_ns": 9.9}

    monkeypatch.setattr(hdl.synthesis, "find_yosys", lambda: ["yosys"])
    monkeypatch.setattr(hdl.synthesis, "synthesize", fake_synthesize)
    monkeypatch.setattr(resources, "memory_bits", lambda text: {"a": 1000, "b": 24})
    monkeypatch.setattr("amaranth.back.rtlil.convert", lambda core, name: "")
    report = resources.estimate(64, 48)
    assert calls == [("StereogestCore", "stereogest_core")]
    assert report["estimate"]["alms"] == 16_035 and report["estimate"]["memory_bits"] == 1024
    assert report["device_use_percent"]["alms"] == 50.0
    assert report["device_use_percent"]["registers"] == 50.0
    assert report["fits"] is False            # 400 M10K > 397
    assert report["thesis_table_23"] == {"alms": 21_941, "registers": 45_819,
                                         "memory_bits": 2_341_913}
    assert report["device"]["name"] == "5CSEMA5F31C6"
