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

    def fake_synthesize(dut, name, yosys, autoname=True):
        calls.append(name)
        return {"alm_estimate": 2_000, "luts": 3_000, "ffs": 8_000, "m10k": 50 + len(calls),
                "mlab": 1, "tool": "yosys", "levels": len(calls), "depth_ns": float(len(calls))}

    monkeypatch.setattr(hdl.synthesis, "find_yosys", lambda: ["yosys"])
    monkeypatch.setattr(hdl.synthesis, "synthesize", fake_synthesize)
    monkeypatch.setattr(resources, "memory_bits", lambda text: {"a": 1000, "b": 24})
    monkeypatch.setattr("amaranth.back.rtlil.convert", lambda core, name: "")
    report = resources.estimate(64, 48)
    # one yosys run per part, summed
    assert calls == ["pipeline", "frame_buffer", "fifo_slave", "uart_slave", "config_left",
                     "config_right"]
    assert report["estimate"]["alms"] == 12_000 and report["estimate"]["memory_bits"] == 1024
    assert report["estimate"]["m10k"] == 6 * 50 + 21 and report["parts"]["pipeline"]["m10k"] == 51
    assert report["device_use_percent"]["registers"] == round(100 * 48_000 / 128_280, 1)
    assert report["logic_depth"]["lut_levels"] == 6      # the worst part
    assert report["fits"] is True             # 12,000 ALMs, 48,000 registers, 321 M10K
    assert report["thesis_table_23"] == {"alms": 21_941, "registers": 45_819,
                                         "memory_bits": 2_341_913}
    assert report["device"]["name"] == "5CSEMA5F31C6"
