"""The whole FPGA side of the DE1-SoC system without pins or PLL (thesis
chapters 5-8): what the board top wraps and what the end-to-end demo simulates.

Blocks, by clock domain::

    config     (50 MHz)       Ov5642Config        x2  §5.1   I2C register table per camera
    cam_left / cam_right      GesturePipeline's capture   §5.2   camera PCLK
    sync       (100 MHz)      GesturePipeline             ch. 5-7 pixels to (x, y, flag)
                              FifoSlave                   §7.4.1 Avalon-MM, bridge offset 0x000
                              UartSlave                   §8.5.1 Avalon-MM, bridge offset 0x100
                              PostureSlave                §10.1  Avalon-MM, bridge offset 0x200
                              FrameBuffer (write side)    Table 22 stage-select video
    vga        (pixel clock)  FrameBuffer (read side)     640x480 at 60 Hz

Board functions (our Table 22; the thesis gives SW[9:7] and LEDR[4]):

=========  ==========================================================
input      ``stage_select`` (SW[9:7]) VGA stage, :data:`VIDEO_STAGES`;
           ``capture`` (SW[0]) cameras captured; ``pause`` (KEY[2]
           held) capture paused; ``configure`` (KEY[1]) power-cycle
           both cameras and rewrite their registers. All asynchronous, synchronised here.
``leds``   [0] left camera configured, [1] right camera configured,
           [2] configuration error, [3] FIFO-FULL, [4] gesture detected,
           [5] GO (the HPS application runs), [6] synchroniser fault
           seen, [9:7] frames completed, bits 5:3 (a heartbeat).
=========  ==========================================================
"""
from __future__ import annotations

import re

from amaranth.hdl import (Cat, ClockDomain, DomainRenamer, Module,
                          Shape, Signal)
from amaranth.lib import cdc, wiring
from amaranth.lib.wiring import In, Out

from hdl._util import check_geometry
from hdl.gesture_pipeline import VIDEO_STAGES, GesturePipeline
from sim.model.pipeline import PipelineParams
from sim.model.validation import check_int, check_number
from sim.model.vga import SCALE_RANGE

from .clocks import CONFIG_HZ, SYNC_HZ
from .fifo_slave import FifoSlave
from .frame_buffer import NO_INIT_ATTR, VGA_SCALE, FrameBuffer
from .hps_interface import DATA_BITS, FIFO_BASE, FIFO_DEPTH, POSTURE_BASE, UART_BASE
from .ov5642_config import SCL_FREQ_RANGE, Ov5642Config
from .posture_slave import PostureSlave
from .uart import UartSlave
from .vga_timing import VGA_640x480_60, VgaMode

__all__ = ["StereogestCore", "CameraPins", "I2cPins", "CameraPowerPins", "CORE_NAME",
           "CLOCK_DOMAINS",
           "FIFO_BASE", "UART_BASE", "POSTURE_BASE", "FRAME_BUFFER_BITS", "core_ports", "emit_core_verilog",
           "strip_zero_init", "VGA_SCALE",
           "VIDEO_STAGES"]

#: Verilog module name of the core (the ``_hw.tcl`` component wraps it).
CORE_NAME = "stereogest_core"
#: Clock domains besides ``sync`` (ports ``<name>_clk`` and ``<name>_rst``).
CLOCK_DOMAINS = ("cam_left", "cam_right", "config", "vga")
#: Bits per pixel of the VGA frame buffer.
FRAME_BUFFER_BITS = 4

#: Camera pins as the camera drives them (the core takes ``In(CameraPins)``).
CameraPins = wiring.Signature({"vsync": Out(1), "href": Out(1), "data": Out(8)})
#: Open-drain I2C pins: ``*_oe`` pulls the line low, ``*_i`` is the line level.
I2cPins = wiring.Signature({"scl_oe": Out(1), "sda_oe": Out(1),
                            "scl_i": In(1), "sda_i": In(1)})
#: A camera's power-down (PWDN, 1: power down) and reset (RESETB, 0: reset)
#: pins, driven by its configuration master's power-up sequence.
CameraPowerPins = wiring.Signature({"pwdn": Out(1), "reset_n": Out(1)})


class StereogestCore(wiring.Component):
    """Cameras to Avalon registers, plus camera set-up, robot UART and VGA view.

    Parameters
    ----------
    width, height : int
        Frame size (thesis 640 x 480; at most 1024 x 1024, the FIFO words'
        coordinates); the cameras' registers set 640 x 480.
    params : sim.model.pipeline.PipelineParams
        Algorithm parameters (thesis run-time values by default).
    rectification : sim.model.rectify.StereoRectification, optional
        Both cameras' compressed maps (:func:`sim.calibration.stereo_rectification`):
        the pipeline rectifies with them (:mod:`hdl.rectify`); None: it does not.
    sync_freq : float
        Pipeline and bus clock in Hz (:data:`soc.clocks.SYNC_HZ`, the thesis'
        100 MHz); sets the UART divisor.
    config_freq : float
        Clock of the ``config`` domain in Hz (:data:`soc.clocks.CONFIG_HZ`, the
        board's 50 MHz).
    vga_mode : soc.vga_timing.VgaMode
        Raster of the VGA output (640 x 480 at 60 Hz).
    fifo_depth : int
        Entries of each centroid FIFO (``soc.hps_interface.FIFO_DEPTH``).
    sync_fifo_depth : int
        Words of each camera FIFO of the stereo synchroniser.
    uart_baudrate : int
        Robot link (RN-42), 115200 8N1.
    frame_buffer_bits : int
        Bits kept per pixel by the VGA frame buffer.
    vga_scale : int in [1, 2]
        Resolution of the VGA frame buffer: 1 full, 2 half in x and y
        (:data:`soc.frame_buffer.VGA_SCALE`, the default: it saves M10K blocks).
    config_table : sequence of (address, value, delay_ms), optional
        OV5642 register writes (default: the vendored 988-row table).
    scl_freq : float in (0, 400e3]
        Highest SCL frequency of the cameras' I2C in Hz (fast mode, 400 kHz, by
        default; lower it for cameras without their own pull-ups,
        boards/README.md).

    Ports
    -----
    fifo, uart, posture : ``In(AvalonSlaveSignature)``, the three slaves (sync
        domain); the posture slave never completes a record without
        ``params.posture``.
    left, right : ``In(CameraPins)`` in ``cam_left`` / ``cam_right``.
    left_i2c, right_i2c : ``Out(I2cPins)`` in ``config``.
    left_power, right_power : ``Out(CameraPowerPins)`` in ``config``: PWDN and
        RESETB of each camera, held in power-down and reset while the core is
        in reset and released by the master's power-up sequence.
    uart_tx, uart_rx : the robot link.
    vga : the VGA DAC signals (``vga`` domain).
    stage_select, capture, pause, configure, leds : board functions (above).
    cam_left_clk, cam_left_rst, ... : clock and reset of every domain but
        ``sync`` (whose are ``clk`` and ``rst`` in the Verilog).
    """

    def __init__(self, width: int = 640, height: int = 480,
                 params: PipelineParams = PipelineParams(), *, rectification=None,
                 sync_freq: float = SYNC_HZ,
                 config_freq: float = CONFIG_HZ, vga_mode: VgaMode = VGA_640x480_60,
                 fifo_depth: int = FIFO_DEPTH, sync_fifo_depth: int = 2048,
                 uart_baudrate: int = 115200, frame_buffer_bits: int = FRAME_BUFFER_BITS,
                 vga_scale: int = VGA_SCALE,
                 config_table=None, scl_freq: float = SCL_FREQ_RANGE[1]):
        width, height = check_geometry(width, height)
        self.sync_freq = check_number("sync_freq", sync_freq, 1e6, 500e6, unit="Hz")
        self.config_freq = check_number("config_freq", config_freq, 1e6, 500e6, unit="Hz")
        if not isinstance(vga_mode, VgaMode):
            raise ValueError(f"vga_mode must be a VgaMode, got {type(vga_mode).__name__}")
        check_int("vga_scale", vga_scale, *SCALE_RANGE)
        self.width, self.height, self.params = width, height, params
        self.vga_mode = vga_mode
        self.pipeline = GesturePipeline(width, height, params, rectification=rectification,
                                        fifo_depth=sync_fifo_depth)
        record = self.pipeline.o_stream.payload.shape()
        coord_bits = max(Shape.cast(record[axis].shape).width for axis in ("x", "y"))
        if coord_bits > DATA_BITS:
            raise ValueError(f"width and height must be at most "
                             f"{1 << (DATA_BITS - params.frac_bits)} (the FIFO words' "
                             f"{DATA_BITS}-bit coordinates), got {width}x{height}")
        # the register map's width at every frame size: FLAG and PRESENT at bit 18
        self.fifo_slave = FifoSlave(data_bits=DATA_BITS, depth=fifo_depth,
                                    frame_width=width, frame_height=height)
        self.uart_slave = UartSlave(clk_freq=self.sync_freq, baudrate=uart_baudrate)
        self.posture_slave = PostureSlave()
        self.config = [Ov5642Config(clk_freq=self.config_freq, scl_freq=scl_freq,
                                    table=config_table)
                       for _ in range(2)]
        self.frame_buffer = FrameBuffer(width, height, vga_mode, pixel_bits=frame_buffer_bits,
                                        scale=vga_scale)
        domain_ports = {}
        for name in CLOCK_DOMAINS:
            domain_ports[f"{name}_clk"] = In(1)
            domain_ports[f"{name}_rst"] = In(1)
        super().__init__({
            **domain_ports,
            "fifo": self.fifo_slave.signature.members["bus"],
            "uart": self.uart_slave.signature.members["bus"],
            "posture": self.posture_slave.signature.members["bus"],
            "left": In(CameraPins), "right": In(CameraPins),
            "left_i2c": Out(I2cPins), "right_i2c": Out(I2cPins),
            "left_power": Out(CameraPowerPins), "right_power": Out(CameraPowerPins),
            "uart_tx": Out(1, init=1), "uart_rx": In(1, init=1),
            "vga": self.frame_buffer.signature.members["vga"],
            "stage_select": In(3), "capture": In(1), "pause": In(1), "configure": In(1),
            "leds": Out(10),
        })

    def elaborate(self, platform):
        m = Module()
        for name in CLOCK_DOMAINS:
            cd = ClockDomain(name, local=True)
            m.domains += cd
            m.d.comb += [cd.clk.eq(getattr(self, f"{name}_clk")),
                         cd.rst.eq(getattr(self, f"{name}_rst"))]

        # --- the pipeline: camera pins to one record per frame ---------------------------
        m.submodules.pipeline = pipe = self.pipeline
        wiring.connect(m, wiring.flipped(self.left), pipe.left)
        wiring.connect(m, wiring.flipped(self.right), pipe.right)
        # (CameraCapture synchronises start and pause into each camera domain)
        m.d.comb += [pipe.start.eq(self.capture), pipe.pause.eq(self.pause)]
        stage = Signal(3)
        m.submodules.stage_sync = cdc.FFSynchronizer(self.stage_select, stage)
        m.d.comb += pipe.video_select.eq(stage)

        # --- HPS side: centroid FIFO, robot UART, posture record -------------------------
        m.submodules.fifo_slave = fifo = self.fifo_slave
        wiring.connect(m, wiring.flipped(self.fifo), fifo.bus)
        rec = pipe.o_stream
        m.d.comb += [fifo.i_stream.valid.eq(rec.valid),
                     fifo.i_stream.payload.x.eq(rec.payload.x),
                     fifo.i_stream.payload.y.eq(rec.payload.y),
                     fifo.i_stream.payload.flag.eq(rec.payload.flag),
                     fifo.i_stream.payload.present.eq(rec.payload.area != 0)]
        m.submodules.posture_slave = posture = self.posture_slave
        wiring.connect(m, wiring.flipped(self.posture), posture.bus)
        wiring.connect(m, pipe.o_posture, posture.i_stream)
        m.submodules.uart_slave = uart = self.uart_slave
        wiring.connect(m, wiring.flipped(self.uart), uart.bus)
        m.d.comb += [self.uart_tx.eq(uart.tx), uart.rx.eq(self.uart_rx)]

        # --- camera configuration (config domain), one I2C master per camera -------------
        configure = Signal()
        m.submodules.configure_sync = cdc.FFSynchronizer(self.configure, configure,
                                                         o_domain="config")
        status = []
        for side, master in zip(("left", "right"), self.config):
            m.submodules[f"config_{side}"] = cfg = DomainRenamer("config")(master)
            pins = getattr(self, f"{side}_i2c")
            power = getattr(self, f"{side}_power")
            m.d.comb += [cfg.start.eq(configure), pins.scl_oe.eq(cfg.scl_oe),
                         pins.sda_oe.eq(cfg.sda_oe), cfg.scl_i.eq(pins.scl_i),
                         cfg.sda_i.eq(pins.sda_i),
                         power.pwdn.eq(cfg.pwdn), power.reset_n.eq(cfg.reset_n)]
            done, error = Signal(name=f"{side}_configured"), Signal(name=f"{side}_config_error")
            m.submodules[f"{side}_done_sync"] = cdc.FFSynchronizer(cfg.done, done)
            m.submodules[f"{side}_error_sync"] = cdc.FFSynchronizer(cfg.error, error)
            status.append((done, error))

        # --- VGA debug view (Table 22) ----------------------------------------------------
        m.submodules.frame_buffer = fb = self.frame_buffer
        wiring.connect(m, pipe.o_video, fb.i_stream)
        wiring.connect(m, wiring.flipped(self.vga), fb.vga)

        # --- LEDs ----------------------------------------------------------------------
        fault_seen = Signal()
        with m.If(pipe.faults != 0):
            m.d.sync += fault_seen.eq(1)
        (left_done, left_error), (right_done, right_error) = status
        m.d.comb += self.leds.eq(Cat(left_done, right_done, left_error | right_error,
                                     fifo.full, fifo.gesture, fifo.go, fault_seen,
                                     pipe.frames[3:6]))
        return m


def core_ports(core: StereogestCore) -> list[tuple[str, str, int]]:
    """The core's Verilog ports as ``(name, "input" | "output", width)``, derived
    from its signature the way Amaranth names them: ``clk`` and ``rst`` of the
    ``sync`` domain, then each member with its path joined by ``__``
    (``fifo__address``, ``left_i2c__scl_oe``; the other domains' ``<domain>_clk``
    and ``<domain>_rst`` are members). Platform Designer's component and the
    simulation wrapper are built from this list; a test checks it against the
    emitted Verilog."""
    ports = [("clk", "input", 1), ("rst", "input", 1)]
    for path, member, _ in core.signature.flatten(core):
        ports.append(("__".join(str(part) for part in path),
                      "input" if member.flow == wiring.In else "output",
                      Shape.cast(member.shape).width))
    return ports


def emit_core_verilog(core: StereogestCore) -> str:
    """Verilog text of the core as module :data:`CORE_NAME`.

    Memories marked :data:`soc.frame_buffer.NO_INIT_ATTR` (their contents
    before the first write do not matter) get no ``initial`` block: Amaranth
    writes one assignment per word (307,200 for the frame buffer), and a
    Cyclone V block RAM without initial contents powers up at zero anyway,
    as Verilator's model does.
    """
    from amaranth.back import verilog
    text = verilog.convert(core, name=CORE_NAME, emit_src=False)
    return strip_zero_init(text)


def strip_zero_init(text: str) -> str:
    """``text`` without the all-zero ``initial`` blocks of the memories that
    carry :data:`soc.frame_buffer.NO_INIT_ATTR`; an initialiser with any
    nonzero word is kept."""
    block = re.compile(
        r"(\(\* " + re.escape(NO_INIT_ATTR) + r' = "1" \*\)\n\s*reg \[[^\]]*\] (\S+) \[[^\]]*\];\n)'
        r"\s*initial begin\n((?:\s*\S+\[\d+\] = \d+'h0+;\n)*)\s*end\n")

    def keep_declaration(match):
        name = match[2]
        lines = match[3].split(";")[:-1]
        if not all(line.strip().startswith(f"{name}[") for line in lines):
            return match[0]
        return match[1]
    return block.sub(keep_declaration, text)
