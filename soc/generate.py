"""Write the Quartus/Platform Designer bundle of the recogniser for the DE1-SoC
(``stereogest generate --out DIR``).

The bundle holds:

==============================  ===================================================
``stereogest.v``                board top (:class:`soc.board_top.BoardTop`), Amaranth
``stereogest.qsf`` / ``.qpf``   Quartus project: device, every pin, the system's QIP
``stereogest.sdc``              clocks, clock groups, AsyncFIFO pointer skew, I/O delays
``stereogest.srf``              suppressed Quartus messages (Amaranth's list)
``stereogest_core.v``           the core (:class:`soc.core.StereogestCore`)
``stereogest_core_hw.tcl``      its Platform Designer component
``soc_system.tcl``              qsys-script building ``soc_system.qsys`` (HPS + core)
``quartus_build.sh``            the whole Quartus flow, in order
``README.md``                   the steps, the address map and the board functions
``stereogest-bundle.json``      what generated the bundle (marks it as one)
==============================  ===================================================

Nothing is written in place: the bundle is built in a temporary directory
beside ``DIR`` and renamed, so an error leaves no half-written ``DIR``.
"""
from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import tempfile
import time
from pathlib import Path

from boards.de1_soc import CAMERA_HEADERS
from sim.model.validation import check_number

from .clocks import CONFIG_HZ, PCLK_HZ, SYNC_HZ, VGA_HZ, XCLK_HZ
from .hps_interface import LIGHTWEIGHT_BRIDGE_BASE, SLAVE_BASES
from .ov5642_config import SCL_FREQ_RANGE
from .platform_designer import CORE_INSTANCE, DEVICE, SYSTEM_NAME, core_interfaces, hw_tcl, \
    system_tcl, verilog_ports

__all__ = ["generate", "check_out_dir", "BundleInfo", "MARKER", "PROJECT", "CORE_FILE", "HW_TCL", "SYSTEM_TCL",
           "RBF", "RBF_COMPRESSED", "CONFIGURATION_SCHEME", "HANDOFF",
           "is_bundle", "GrayCrossing", "async_fifo_crossings", "sdc_constraints",
           "pll_clock_name", "OV5642_DVP", "ADV7123", "SYSTEM_INSTANCE"]

#: Quartus project (and top-level module) name.
PROJECT = "stereogest"
CORE_FILE = "stereogest_core.v"
HW_TCL = "stereogest_core_hw.tcl"
SYSTEM_TCL = "soc_system.tcl"
BUILD_SCRIPT = "quartus_build.sh"
#: Configuration scheme of the project: the HPS's FPGA manager feeds the bitstream
#: by fast passive parallel (x16 or x32, as the MSEL pins say; the .rbf is the same).
CONFIGURATION_SCHEME = "PASSIVE PARALLEL X16"
#: The bitstreams for the HPS: ``quartus_asm`` writes the uncompressed one (the
#: .qsf's GENERATE_RBF_FILE), the build script converts the .sof to the compressed
#: one (``quartus_cpf -o bitstream_compression=on``); which one loads depends on
#: the MSEL pins (docs/bring-up.md).
RBF = f"{PROJECT}.rbf"
RBF_COMPRESSED = f"{PROJECT}_compressed.rbf"
#: Where Quartus writes the HPS handoff while it compiles the project (the
#: preloader and U-Boot are built from it).
HANDOFF = f"hps_isw_handoff/{SYSTEM_NAME}_hps_0"
#: File that marks a directory as a stereogest bundle.
MARKER = "stereogest-bundle.json"
#: Amaranth's build scripts (they run only quartus_map..sta, not the whole flow) and its
#: debug Verilog (empty: debug Verilog generation is off).
_AMARANTH_SCRIPTS = ("build_stereogest.sh", "build_stereogest.bat", "build_stereogest.json",
                     "stereogest.debug.v")


@dataclasses.dataclass(frozen=True)
class BundleInfo:
    """What :func:`generate` wrote.

    Attributes
    ----------
    out_dir : pathlib.Path
        The bundle directory.
    files : tuple of str
        File names in it.
    core_ports : tuple of (name, direction, width)
        The core's Verilog ports.
    seconds : float
        Wall time of the generation.
    """

    out_dir: Path
    files: tuple
    core_ports: tuple
    seconds: float


def is_bundle(path) -> bool:
    """True if ``path`` is a directory written by :func:`generate`."""
    marker = Path(path) / MARKER
    try:
        return json.loads(marker.read_text()).get("generator") == "stereogest generate"
    except (OSError, ValueError, AttributeError):
        return False


def check_out_dir(out_dir) -> Path:
    """``out_dir`` as :func:`generate` accepts it (new, empty or a previous
    bundle), checked before any work; ``ValueError`` otherwise."""
    if not isinstance(out_dir, (str, os.PathLike)) or not str(out_dir):
        raise ValueError(f"out_dir must be a path, got {out_dir!r}")
    out = Path(out_dir)
    if out.exists() or out.is_symlink():
        if not out.is_dir() or out.is_symlink():
            raise ValueError(f"out_dir {str(out)!r} exists and is not a directory "
                             "(or is a symlink)")
        if any(out.iterdir()) and not is_bundle(out):
            raise ValueError(f"out_dir {str(out)!r} is not empty and not a stereogest bundle "
                             f"(no {MARKER}); choose a new or empty directory")
    return out


def generate(out_dir, width: int = 640, height: int = 480, *, sync_hz: float = SYNC_HZ,
             vga_hz: float = VGA_HZ, xclk_hz: float = XCLK_HZ, rectification=None,
             hand_tracking: bool = False, vga_scale: int | None = None,
             scl_hz: float = SCL_FREQ_RANGE[1], progress=None) -> BundleInfo:
    """Write the Quartus project and Platform Designer pieces into ``out_dir``.

    Parameters
    ----------
    out_dir : str or path
        New, empty, or a previous bundle (replaced as a whole); parents are
        created.
    width, height : int
        Frame size of the pipeline (the cameras' registers set 640 x 480).
    sync_hz, vga_hz, xclk_hz : float
        PLL outputs: pipeline/bus clock, VGA pixel clock, camera XCLK
        (defaults from :mod:`soc.clocks`: 100, 25 and 24 MHz).
    rectification : sim.model.rectify.StereoRectification, optional
        The calibration's maps, built into the rectification stages.
    hand_tracking : bool
        The centroid's hand tracking (:func:`sim.model.pipeline.hand_tracking_for`
        the width) on top of the thesis parameters.
    vga_scale : int in [1, 2], optional
        Resolution of the VGA debug view's frame buffer (None: the core's
        default, :data:`soc.frame_buffer.VGA_SCALE`).
    scl_hz : float in (0, 400e3]
        Highest SCL frequency of the cameras' I2C (400 kHz; lower for cameras
        without their own pull-ups, boards/README.md).
    progress : callable, optional
        Called with one-line progress messages.

    Returns
    -------
    BundleInfo

    Raises
    ------
    ValueError
        For a bad parameter (naming it) or an ``out_dir`` that exists and is
        neither empty nor a previous bundle. Nothing is written then.
    """
    start = time.perf_counter()
    say = progress or (lambda message: None)
    out = check_out_dir(out_dir)
    sync_hz = check_number("sync_hz", sync_hz, 10e6, 200e6, unit="Hz")
    vga_hz = check_number("vga_hz", vga_hz, 10e6, 100e6, unit="Hz")
    xclk_hz = check_number("xclk_hz", xclk_hz, 6e6, 27e6, unit="Hz")
    scl_hz = check_number("scl_hz", scl_hz, *SCL_FREQ_RANGE, unit="Hz", lo_open=True)
    from sim.model.validation import check_int
    from sim.model.vga import SCALE_RANGE

    from .frame_buffer import VGA_SCALE
    vga_scale = check_int("vga_scale", VGA_SCALE if vga_scale is None else vga_scale,
                          *SCALE_RANGE)

    from boards.de1_soc import StereogestDE1SoCPlatform

    from sim.model.pipeline import PipelineParams, hand_tracking_for

    from .board_top import BoardTop
    from .core import CORE_NAME, StereogestCore, core_ports, emit_core_verilog
    from .vga_timing import VGA_640x480_60

    # the raster is the 640x480 one; the pixel clock is what the PLL makes
    vga_mode = dataclasses.replace(VGA_640x480_60, pixel_clock=int(round(vga_hz)))
    params = PipelineParams()
    if hand_tracking:           # after the checks: the width's range is the pipeline's
        params.validate(width, height)
        params = dataclasses.replace(params, **hand_tracking_for(width))
    # the core's checks of the frame and the pipeline's first: a core is built to
    # be elaborated
    from hdl._util import check_geometry
    from hdl.gesture_pipeline import pipeline_timing
    pipeline_timing(*check_geometry(width, height), params, rectification)
    core = StereogestCore(width, height, params, rectification=rectification,
                          sync_freq=sync_hz, vga_mode=vga_mode, vga_scale=vga_scale,
                          scl_freq=scl_hz)
    say(f"elaborating the core ({width}x{height}) ...")
    core_v = emit_core_verilog(core)
    ports = core_ports(core)
    bases = dict(SLAVE_BASES)
    hw = hw_tcl(ports, module=CORE_NAME, verilog_file=CORE_FILE)
    system = system_tcl(ports, bases, clock_hz=sync_hz, core_module=CORE_NAME)

    say("elaborating the board top ...")
    top = BoardTop(ports, sync_hz=sync_hz, vga_hz=vga_hz, xclk_hz=xclk_hz)
    platform = StereogestDE1SoCPlatform()
    plan = platform.build(top, name=PROJECT, do_build=False, add_settings=_qsf_settings())
    for name in _AMARANTH_SCRIPTS:
        plan.files.pop(name, None)

    files = dict(plan.files)
    # the constraints need the top's ports and the core's FIFOs, known only now
    top_ports = verilog_ports(files[f"{PROJECT}.v"], PROJECT)
    files[f"{PROJECT}.sdc"] = files[f"{PROJECT}.sdc"].rstrip() + "\n" + sdc_constraints(
        top_ports, async_fifo_crossings(core_v), sync_hz=sync_hz, vga_hz=vga_hz,
        xclk_hz=xclk_hz)
    files[CORE_FILE] = core_v
    files[HW_TCL] = hw
    files[SYSTEM_TCL] = system
    files[f"{PROJECT}.qpf"] = _qpf()
    files[BUILD_SCRIPT] = _build_script()
    refresh = vga_hz / (vga_mode.h_total * vga_mode.v_total)
    files["README.md"] = _readme(width, height, sync_hz, vga_hz, xclk_hz, refresh, ports,
                                 bases, vga_scale, scl_hz)
    files[MARKER] = json.dumps({
        "generator": "stereogest generate", "width": width, "height": height,
        "sync_hz": sync_hz, "vga_hz": vga_hz, "xclk_hz": xclk_hz,
        "hand_tracking": {"track_gate": params.track_gate, "hand_rows": params.hand_rows},
        "vga_scale": vga_scale, "scl_hz": scl_hz,
        "device": DEVICE, "files": sorted([*files, MARKER]),
    }, indent=2) + "\n"

    say(f"writing {out} ...")
    out_abs = out.resolve()
    out_abs.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_abs.name}.", dir=out_abs.parent))
    try:
        for name, content in files.items():
            path = tmp / name
            if isinstance(content, str):
                path.write_text(content)
            else:
                path.write_bytes(content)
        tmp.chmod(0o755)            # mkdtemp makes it private
        (tmp / BUILD_SCRIPT).chmod(0o755)
        _replace(tmp, out_abs)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return BundleInfo(out, tuple(sorted(files)), tuple(ports), time.perf_counter() - start)


def _replace(new: Path, out: Path) -> None:
    """Rename ``new`` to ``out``; an existing ``out`` (empty, or a bundle) is
    moved aside first and removed after."""
    if not out.exists():
        new.rename(out)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
    old.rmdir()
    out.rename(old)
    try:
        new.rename(out)
    except BaseException:
        old.rename(out)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _qsf_settings() -> str:
    lines = [
        'set_global_assignment -name FAMILY "Cyclone V"',
        f"set_global_assignment -name SDC_FILE {PROJECT}.sdc",
        "# the HPS system from soc_system.tcl (qsys-generate writes the QIP); the QIP",
        f"# also brings in {CORE_FILE}, the core, through its _hw.tcl fileset, so the",
        "# core is not listed here again (a second copy would define the module twice)",
        f"set_global_assignment -name QIP_FILE {SYSTEM_NAME}/synthesis/{SYSTEM_NAME}.qip",
        "# HPS DDR3 termination and I/O settings come from the script qsys-generate",
        f"# writes: quartus_sta -t {SYSTEM_NAME}/synthesis/submodules/"
        f"hps_sdram_p0_pin_assignments.tcl {PROJECT}",
        "set_global_assignment -name OPTIMIZE_MULTI_CORNER_TIMING ON",
        "# metastability report for the synchronisers between the unrelated clocks",
        "set_global_assignment -name SYNCHRONIZER_IDENTIFICATION AUTO",
        "# the HPS configures the FPGA (U-Boot 'fpga load', Linux's FPGA manager) by fast",
        "# passive parallel; quartus_asm writes the uncompressed .rbf (GENERATE_RBF_FILE,",
        f"# above) for the MSEL settings without compression, {BUILD_SCRIPT} also a",
        f"# compressed one, {RBF_COMPRESSED}, for those with (the DE1-SoC's SW10)",
        f'set_global_assignment -name STRATIXV_CONFIGURATION_SCHEME "{CONFIGURATION_SCHEME}"',
        "set_global_assignment -name ON_CHIP_BITSTREAM_DECOMPRESSION OFF",
        "set_global_assignment -name USE_CONFIGURATION_DEVICE OFF",
        "# the camera PCLK pins are not dedicated clock inputs: put each PCLK on a",
        "# global clock network (the fitter warns about the non-dedicated pin)",
    ]
    for number in sorted(CAMERA_HEADERS):
        lines.append('set_instance_assignment -name GLOBAL_SIGNAL "GLOBAL CLOCK" '
                     f"-to {_camera_port(number, 'pclk')}")
    return "\n".join([*lines, ""])


# ---- timing constraints ---------------------------------------------------------------

#: Instance of ``soc_system`` in the board top (the core is
#: ``SYSTEM_INSTANCE|stereogest_core_0|...`` in Quartus' hierarchy).
SYSTEM_INSTANCE = "soc"
#: OV5642 digital video port (ns): data, HREF and VSYNC change after PCLK's
#: falling edge, valid at most ``pclk_to_data_max`` later (OmniVision's DVP
#: timing table, tPDV <= 5 ns, tPHH/tPHL 0-5 ns); the board top samples them
#: on the rising edge. Source and caveat in docs/design/soc.md.
OV5642_DVP = {"pclk_to_data_min": 0.0, "pclk_to_data_max": 5.0}
#: ADV7123 video DAC (ns): data and control setup and hold to the rising edge
#: of its CLOCK input (datasheet, 3.3 V: t6 = 0.2, t7 = 1.5).
ADV7123 = {"setup": 0.2, "hold": 1.5}
#: Name of the VGA DAC's clock as it leaves the FPGA (an inverted copy of the
#: pixel clock, see :class:`soc.board_top.BoardTop`).
DAC_CLOCK = "vga_dac_clk"
#: Fraction of a clock period the Gray pointers may spend in skew and wire
#: delay (Intel: "less than one launch / latch clock").
GRAY_MARGIN = 0.8


def pll_clock_name(domain: str) -> str:
    """Clock that ``derive_pll_clocks`` creates on the PLL output of
    ``domain`` (Quartus names it after the output counter's pin; ``?`` stands
    for the brackets, which Tcl patterns would read as a character class)."""
    from .board_top import PLL_OUTPUTS
    if domain not in PLL_OUTPUTS:
        raise ValueError(f"domain must be one of {PLL_OUTPUTS}, got {domain!r}")
    return f"pll|general?{PLL_OUTPUTS.index(domain)}?.gpll~PLL_OUTPUT_COUNTER|divclk"


def _camera_port(number: int, signal: str) -> str:
    return f"ov5642_{number}__{signal}__io"


def _domain_clocks() -> dict:
    """SDC clock pattern of every clock domain of the top."""
    clocks = {"config": "clk50_0__io"}
    for number, (side, _) in CAMERA_HEADERS.items():
        clocks[f"cam_{side}"] = _camera_port(number, "pclk")
    for domain in ("sync", "vga", "xclk"):
        clocks[domain] = pll_clock_name(domain)
    return clocks


@dataclasses.dataclass(frozen=True)
class GrayCrossing:
    """One Gray-coded pointer of an ``AsyncFIFO`` crossing clock domains.

    Attributes
    ----------
    path : tuple of str
        Instance path of the FIFO inside the core.
    pointer : str
        ``"produce"`` (write pointer to the read side) or ``"consume"``.
    source, dest : str
        Clock domains of the pointer register and of the synchroniser.
    source_reg, dest_reg : str
        The pointer register and the synchroniser's first stage, as
        ``|``-separated names relative to the FIFO.
    """

    path: tuple
    pointer: str
    source: str
    dest: str
    source_reg: str
    dest_reg: str

    def pattern(self, reg: str) -> str:
        """Quartus name pattern of ``reg`` in the bundle (every hierarchy level
        may carry an ``entity:`` prefix, hence the ``*``)."""
        *inner, name = reg.split("|")
        levels = [SYSTEM_INSTANCE, CORE_INSTANCE, *self.path, *inner]
        return "|".join(f"*{level}" for level in levels) + f"|{name}*"


_MODULE = re.compile(r"^module\s+\\?(\S+)\s*\(([^)]*)\)", re.M)


def _clock_domain(port: str) -> str:
    return "sync" if port == "clk" else port[:-len("_clk")]


def async_fifo_crossings(core_verilog: str) -> list:
    """The Gray pointer crossings of every ``AsyncFIFO`` in the core's Verilog.

    Amaranth names each module after its instance path (``core.a.b``) and an
    ``AsyncFIFO`` synchronises its pointers in the submodules ``produce_cdc``
    and ``consume_cdc`` (first stage ``stage0``) from the registers
    ``produce_w_gry`` and ``consume_r_gry``.

    Returns
    -------
    list of GrayCrossing
    """
    modules = {}
    for match in _MODULE.finditer(core_verilog):
        ports = [p.strip().lstrip("\\") for p in match[2].split(",")]
        modules[match[1]] = [p for p in ports if p == "clk" or p.endswith("_clk")]
    crossings = []
    for name, clocks in modules.items():
        parent, _, leaf = name.rpartition(".")
        if leaf not in ("produce_cdc", "consume_cdc") or parent not in modules:
            continue
        pointer = leaf[:-len("_cdc")]
        parent_clocks = modules[parent]
        if len(clocks) != 1 or len(parent_clocks) != 2 or clocks[0] not in parent_clocks:
            raise ValueError(f"AsyncFIFO {parent!r}: cannot tell its two clocks apart")
        (source,) = set(parent_clocks) - set(clocks)
        crossings.append(GrayCrossing(
            path=tuple(parent.split(".")[1:]), pointer=pointer,
            source=_clock_domain(source), dest=_clock_domain(clocks[0]),
            source_reg="produce_w_gry" if pointer == "produce" else "consume_r_gry",
            dest_reg=f"{leaf}|stage0"))
    return crossings


def sdc_constraints(top_ports, crossings, *, sync_hz: float = SYNC_HZ, vga_hz: float = VGA_HZ,
                    xclk_hz: float = XCLK_HZ) -> str:
    """The timing constraints after the clocks Amaranth declares (50 MHz
    oscillator, both PCLKs).

    Parameters
    ----------
    top_ports : list of (name, direction, width)
        Ports of the board top; each gets a constraint or is a clock.
    crossings : list of GrayCrossing
        The AsyncFIFO pointers of the core (:func:`async_fifo_crossings`).
    sync_hz, vga_hz, xclk_hz : float
        PLL outputs.

    Raises
    ------
    ValueError
        For a top-level port this function does not know how to constrain.
    """
    from .board_top import PLL_OUTPUTS
    periods = {domain: 1e9 / hz for domain, hz in {
        "sync": sync_hz, "vga": vga_hz, "xclk": xclk_hz, "config": CONFIG_HZ,
        **{f"cam_{side}": PCLK_HZ for side, _ in CAMERA_HEADERS.values()}}.items()}
    clocks = _domain_clocks()
    lines = [
        "",
        f"# PLL outputs from the 50 MHz clock above: "
        + ", ".join(f"{n} {d} {1e3 / periods[d]:g} MHz" for n, d in enumerate(PLL_OUTPUTS)),
        "derive_pll_clocks",
        # the DAC samples on the rising edge of its clock pin, which carries the
        # inverted pixel clock (DDR output register)
        f"create_generated_clock -name {DAC_CLOCK} -invert "
        f"-source [get_pins {{{pll_clock_name('vga')}}}] [get_ports {{vga_0__clk__io}}]",
        "derive_clock_uncertainty",
        "",
        "# every domain is unrelated to every other: they meet only in synchronisers,",
        "# AsyncFIFOs and the frame buffer's dual-clock RAM",
        "set_clock_groups -asynchronous \\",
    ]
    groups = []
    for domain in ("config", "sync", "vga", "xclk",
                   *(f"cam_{side}" for side, _ in CAMERA_HEADERS.values())):
        members = [clocks[domain]] + ([DAC_CLOCK] if domain == "vga" else [])
        groups.append(f"    -group [get_clocks {{{' '.join(members)}}}]")
    lines.append(" \\\n".join(groups))

    lines += ["", "# AsyncFIFO Gray pointers: the clock groups cut their paths; the skew",
              f"# between bits stays under {GRAY_MARGIN:g} launch period and the wire delay under",
              f"# {GRAY_MARGIN:g} latch period, so the far side samples one pointer value or its",
              "# successor (set_max_skew and set_net_delay still apply across clock groups)"]
    for c in crossings:
        src, dst = c.pattern(c.source_reg), c.pattern(c.dest_reg)
        fifo = "/".join(c.path)
        lines += [
            f"# {fifo}: {c.pointer} pointer, {c.source} -> {c.dest}",
            f"set_max_skew -from [get_keepers {{{src}}}] -to [get_keepers {{{dst}}}] "
            f"{GRAY_MARGIN * periods[c.source]:.3f}",
            f"set_net_delay -max -from [get_keepers {{{src}}}] -to [get_keepers {{{dst}}}] "
            f"{GRAY_MARGIN * periods[c.dest]:.3f}",
        ]

    camera_inputs, vga_outputs, ddr = {}, [], []
    false_from, false_to = [], []
    for name, direction, width in top_ports:
        pattern = name if width == 1 else f"{name}*"
        camera = re.fullmatch(r"ov5642_(\d+)__(\w+)__io", name)
        if name == "clk50_0__io" or (camera and camera[2] == "pclk") or name == "vga_0__clk__io":
            continue                                    # clocks
        if camera and camera[2] in ("vsync", "href", "data"):
            camera_inputs.setdefault(int(camera[1]), []).append(pattern)
        elif re.fullmatch(r"vga_0__(r|g|b|hs|vs|blank_n)__io", name):
            vga_outputs.append(pattern)
        elif name.startswith("hps_ddr3_0__"):
            ddr.append(pattern)
        elif camera or re.fullmatch(r"(button|switch|led)_\d+__io|uart_0__(tx|rx)__io|"
                                    r"vga_0__sync_n__io|hps_io_0__\w+__io", name):
            if direction in ("input", "inout"):
                false_from.append(pattern)
            if direction in ("output", "inout"):
                false_to.append(pattern)
        else:
            raise ValueError(f"top-level port {name!r} has no timing rule")

    dvp = OV5642_DVP
    lines += ["", "# OV5642 digital video port: data, HREF, VSYNC launched on PCLK's falling",
              f"# edge, valid {dvp['pclk_to_data_min']:g}-{dvp['pclk_to_data_max']:g} ns "
              "later; captured on the rising edge"]
    for number, ports in sorted(camera_inputs.items()):
        clock = _camera_port(number, "pclk")
        for key, bound in (("max", "pclk_to_data_max"), ("min", "pclk_to_data_min")):
            lines.append(f"set_input_delay -clock [get_clocks {{{clock}}}] -clock_fall -{key} "
                         f"{dvp[bound]:.3f} [get_ports {{{' '.join(ports)}}}]")
    lines += ["", f"# ADV7123 DAC: setup {ADV7123['setup']:g} ns, hold {ADV7123['hold']:g} ns "
              f"to the rising edge of its clock ({DAC_CLOCK})",
              f"set_output_delay -clock [get_clocks {{{DAC_CLOCK}}}] -max {ADV7123['setup']:.3f} "
              f"[get_ports {{{' '.join(vga_outputs)}}}]",
              f"set_output_delay -clock [get_clocks {{{DAC_CLOCK}}}] -min {-ADV7123['hold']:.3f} "
              f"[get_ports {{{' '.join(vga_outputs)}}}]",
              "",
              "# static or slow pins, each synchronised or not timing-critical: KEY, SW, LEDR,",
              "# the RN-42 UART, the cameras' I2C, XCLK, RESETB and PWDN, VGA_SYNC_N, and the",
              "# HPS peripheral pins (hard HPS I/O: the false path changes no routing)",
              f"set_false_path -from [get_ports {{{' '.join(false_from)}}}]",
              f"set_false_path -to [get_ports {{{' '.join(false_to)}}}]",
              "",
              f"# the HPS DDR3 pins ({len(ddr)} ports) are constrained by the SDRAM interface's "
              "own SDC,",
              f"# {SYSTEM_NAME}/synthesis/submodules/hps_sdram_p0.sdc (in the QIP)",
              ""]
    return "\n".join(lines)


def _qpf() -> str:
    return "\n".join([
        "# Quartus project of the stereogest bundle (written by `stereogest generate`)",
        'QUARTUS_VERSION = "16.1"',
        f'PROJECT_REVISION = "{PROJECT}"',
        "",
    ])


def _build_script() -> str:
    pins = f"{SYSTEM_NAME}/synthesis/submodules/hps_sdram_p0_pin_assignments.tcl"
    return f"""#!/bin/sh
# The whole Quartus flow of the stereogest bundle, in order (see README.md).
# Written by `stereogest generate`. Needs Quartus Prime (Lite or Standard, with
# Cyclone V support) and its Platform Designer tools on PATH.
set -e
cd "$(dirname "$0")"
for tool in qsys-script qsys-generate quartus_map quartus_sta quartus_fit quartus_asm \\
        quartus_cpf; do
    command -v "$tool" >/dev/null 2>&1 || {{
        echo "$tool not found: put Quartus's bin directories on PATH" >&2; exit 1; }}
done
here="$(pwd)"
qsys-script --script={SYSTEM_TCL} --search-path="$here,\\$"
qsys-generate {SYSTEM_NAME}.qsys --synthesis=VERILOG --output-directory={SYSTEM_NAME} \\
    --part={DEVICE} --search-path="$here,\\$"
quartus_map --read_settings_files=on --write_settings_files=off {PROJECT} -c {PROJECT}
quartus_sta -t {pins} {PROJECT}
# synthesis again, now with the HPS DDR3 pin settings in the project
quartus_map --read_settings_files=on --write_settings_files=off {PROJECT} -c {PROJECT}
quartus_fit --read_settings_files=on --write_settings_files=off {PROJECT} -c {PROJECT}
quartus_asm {PROJECT} -c {PROJECT}
quartus_sta {PROJECT} -c {PROJECT}
# quartus_asm wrote {RBF} (uncompressed); the compressed bitstream for MSEL
# settings with compression (e.g. 01010, FPP x32)
quartus_cpf -c -o bitstream_compression=on {PROJECT}.sof {RBF_COMPRESSED}
echo "done: {PROJECT}.sof (JTAG), {RBF} (MSEL without compression) and {RBF_COMPRESSED}"
echo "(MSEL with compression); loading them: BRINGUP.md of the board bundle"
if [ -d {HANDOFF} ]; then
    echo "the HPS handoff for the preloader and U-Boot: {HANDOFF} (README.md, step 5)"
else
    echo "warning: Quartus wrote no {HANDOFF}: the preloader cannot be built from this project" >&2
fi
"""


def _readme(width, height, sync_hz, vga_hz, xclk_hz, refresh, ports, bases, vga_scale,
            scl_hz) -> str:
    conduits = [i for i in core_interfaces(ports) if i.kind == "conduit"]
    slaves = [i for i in core_interfaces(ports) if i.kind == "avalon"]
    slave_rows = "\n".join(
        f"| `{s.name}` | {bases[s.name]:#06x} | {LIGHTWEIGHT_BRIDGE_BASE + bases[s.name]:#010x} | "
        f"{4 << dict((r, w) for _, r, _, w in s.ports)['address']:#x} |" for s in slaves)
    conduit_list = ", ".join(f"`core_{c.name}`" for c in conduits)
    pins = f"{SYSTEM_NAME}/synthesis/submodules/hps_sdram_p0_pin_assignments.tcl"
    view = "full resolution" if vga_scale == 1 else \
        "half resolution, each stored pixel shown as a 2x2 block"
    return f"""# stereogest: Quartus bundle for the DE1-SoC

Written by `stereogest generate` ({width}x{height} pipeline). Device {DEVICE}
(Cyclone V SE, DE1-SoC). Regenerate with the same command; it replaces this
directory as a whole (Quartus outputs in it included).

## Files

| file | what |
|---|---|
| `{PROJECT}.v` | board top (Amaranth): pins, PLL, resets, the `{SYSTEM_NAME}` instance |
| `{PROJECT}.qsf`, `{PROJECT}.qpf` | Quartus project: device, pin of every top-level port, the system's QIP |
| `{PROJECT}.sdc` | clocks, asynchronous clock groups, AsyncFIFO pointer skew, camera and DAC I/O delays, false paths |
| `{CORE_FILE}` | the core: pipeline, camera configuration, FIFO and UART slaves, VGA view |
| `{HW_TCL}` | Platform Designer component of the core |
| `{SYSTEM_TCL}` | qsys-script that builds `{SYSTEM_NAME}.qsys` (HPS + core) |
| `{BUILD_SCRIPT}` | the steps below in one script |

## Clocks

| clock | source | frequency |
|---|---|---|
| pipeline and bus (core `clk`, lightweight bridge) | PLL output 0 | {sync_hz / 1e6:g} MHz |
| VGA pixel clock (640x480 raster, {refresh:.1f} Hz frames) | PLL output 1 | {vga_hz / 1e6:g} MHz |
| camera XCLK (both cameras) | PLL output 2 | {xclk_hz / 1e6:g} MHz |
| camera configuration (I2C master; SCL at most {scl_hz / 1e3:g} kHz) | board oscillator CLOCK_50 | {CONFIG_HZ / 1e6:g} MHz |
| left / right camera | each camera's PCLK | set by the camera |

## Address map (lightweight HPS-to-FPGA bridge)

| slave | bridge offset | HPS physical address | span (bytes) |
|---|---|---|---|
{slave_rows}

## Quartus steps

With Quartus Prime (Lite or Standard, 16.1 or later, Cyclone V support) on PATH,
in this directory (`sh {BUILD_SCRIPT}` runs steps 1-4):

1. Build the HPS system: `qsys-script --script={SYSTEM_TCL} --search-path="$PWD,\\$"`
   writes `{SYSTEM_NAME}.qsys` (the search path lets it find `{HW_TCL}`).
2. Generate it: `qsys-generate {SYSTEM_NAME}.qsys --synthesis=VERILOG
   --output-directory={SYSTEM_NAME} --part={DEVICE} --search-path="$PWD,\\$"`; the
   `.qsf` already includes `{SYSTEM_NAME}/synthesis/{SYSTEM_NAME}.qip`.
3. Analysis and synthesis, then the HPS DDR3 pin settings (termination, I/O
   standards) from the generated script:
   `quartus_map {PROJECT} -c {PROJECT}` then
   `quartus_sta -t {pins} {PROJECT}`,
   then `quartus_map` once more so the project is compiled with those settings.
4. Fit, assemble, time: `quartus_fit {PROJECT} -c {PROJECT}`,
   `quartus_asm {PROJECT} -c {PROJECT}`, `quartus_sta {PROJECT} -c {PROJECT}`,
   then `quartus_cpf -c -o bitstream_compression=on {PROJECT}.sof {RBF_COMPRESSED}`.
   Out come `{PROJECT}.sof` (JTAG), `{RBF}` (uncompressed) and `{RBF_COMPRESSED}`;
   the project configures by fast passive parallel, as the HPS does. Quartus
   also writes the HPS handoff during compilation: `{HANDOFF}/` (the HPS's pin
   multiplexing, clocks and DDR3 settings, for the boot loader).
5. Build the preloader and U-Boot from that handoff, with the SoC EDS of the
   same version as Quartus: `bsp-create-settings --type spl --bsp-dir
   software/spl_bsp --preloader-settings-dir {HANDOFF}
   --settings software/spl_bsp/settings.bsp`, then `make -C software/spl_bsp`
   (`preloader-mkpimage.bin`) and `make -C software/spl_bsp uboot`, and put
   them on the SD card (`BRINGUP.md`, "The preloader and U-Boot", also for
   mainline U-Boot). The HPS is set up as Terasic's DE1-SoC reference design
   (SD card, Ethernet, USB, UART0 console, QSPI, SPI, I2C, GPIO on their HPS
   pins; the board's 1 GB DDR3): a card made for that design (Terasic's
   images) carries a preloader for the same HPS settings.
6. Program the FPGA: over the USB-Blaster (the FPGA is the second device of the
   JTAG chain, after the HPS) `quartus_pgm -m jtag -o "p;{PROJECT}.sof@2"`, or
   from the board: the `.rbf` whose compression matches the MSEL switches
   (`python3 -m sw_hps --check` prints them; `{RBF}` for MSEL 00000 or 00100,
   `{RBF_COMPRESSED}` for 01010 and the other settings with compression), loaded
   by U-Boot (`fatload` + `fpga load`) or Linux's FPGA manager.
7. Enable the lightweight HPS-to-FPGA bridge (U-Boot `bridge enable`, older
   U-Boot `run bridge_enable_handoff`, or from Linux), check with
   `python3 -m sw_hps --check`, then start the application as root:

       python3 -m sw_hps --model model.json --bus devmem --robot uart

The commands of steps 5 to 7 for each U-Boot and kernel generation, the uio
device and the service are in the bring-up guide: `docs/bring-up.md` in the
repository, `BRINGUP.md` in the board bundle (`make hps-bundle` packs `sw_hps`
with a model file).

## Board functions

KEY[0] reset, KEY[1] power-cycle and reconfigure the cameras, KEY[2] (held) pause, SW[0]
capture, SW[9:7] VGA stage (0 right, 1 left, 2 disparity, 3 skin, 4 band,
5 opening; {view}); LEDR[0]/[1] cameras configured, [2] configuration
error, [3] FIFO-FULL, [4] gesture detected, [5] GO, [6] synchroniser fault,
[9:7] heartbeat. Camera header pins: `boards/README.md` in the repository.

## Platform Designer system

`clk_0` (clock source, {sync_hz / 1e6:g} MHz, exported `clk`/`reset`), `hps_0`
(`altera_hps`: lightweight bridge on, other bridges off, DDR3 exported as
`memory`, peripheral pins as `hps_io`, its FPGA reset as `h2f_reset`, which
the top adds to its reset tree), `{CORE_INSTANCE}` with its clock and reset from `clk_0`, its
slaves on `hps_0.h2f_lw_axi_master` and its conduits exported as {conduit_list}.
"""
