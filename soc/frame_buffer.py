"""Frame buffer of the VGA debug view (thesis Table 22, §7.5): the pipeline's
stage-select video (``GesturePipeline.o_video``, SW[9:7]) shown on the DE1-SoC
VGA output, 640x480 at 60 Hz.

The pipeline writes at its own clock (100 MHz, ``sync``) while the VGA side
reads at the pixel clock (25 MHz from the PLL, ``vga``), so the two meet only
in a true dual-clock block RAM; no other signal crosses the clock domains.
"""
from __future__ import annotations

from amaranth.hdl import Cat, DomainRenamer, Module, Mux, Signal, unsigned
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.validation import check_int
from sim.model.vga import SCALE_RANGE, stored_size

from .vga_timing import VGA_640x480_60, VgaMode, VgaTiming

__all__ = ["FrameBuffer", "VgaOutputSignature", "READ_LATENCY", "NO_INIT_ATTR", "VGA_SCALE"]

#: Pixel clocks from the raster counters to the registered VGA outputs:
#: one for the block RAM read, one for the output registers.
READ_LATENCY = 2
#: Attribute of a memory whose contents before the first write do not matter:
#: :func:`soc.core.emit_core_verilog` writes no initialiser for it.
NO_INIT_ATTR = "stereogest_no_init"
#: Default ``scale`` of :class:`FrameBuffer`: half resolution, a quarter of the
#: block RAM, as the M10K blocks are the whole core's tightest resource (the
#: figures: docs/figures/fpga.md) and a debug view needs no more.
VGA_SCALE = 2


class VgaOutputSignature(wiring.Signature):
    """The DE1-SoC VGA DAC pins (ADV7123) seen from the driver: ``r``, ``g``,
    ``b`` (8 bits each), ``hsync``, ``vsync`` and ``blank_n`` (low in the
    blanking). VGA_SYNC_N (tie low) and VGA_CLK (the pixel clock) belong to the
    board top.

    Parameters
    ----------
    hsync_negative, vsync_negative : bool
        Sync polarity; the sync outputs reset to their idle level.
    """

    def __init__(self, hsync_negative: bool = True, vsync_negative: bool = True):
        self.hsync_negative, self.vsync_negative = bool(hsync_negative), bool(vsync_negative)
        super().__init__({
            "r": Out(8), "g": Out(8), "b": Out(8),
            "hsync": Out(1, init=int(self.hsync_negative)),
            "vsync": Out(1, init=int(self.vsync_negative)),
            "blank_n": Out(1),
        })

    def __eq__(self, other):
        return isinstance(other, VgaOutputSignature) and \
            (other.hsync_negative, other.vsync_negative) == \
            (self.hsync_negative, self.vsync_negative)

    def __hash__(self):
        return hash(("VgaOutputSignature", self.hsync_negative, self.vsync_negative))

    def __repr__(self):
        return f"VgaOutputSignature({self.hsync_negative}, {self.vsync_negative})"


class FrameBuffer(wiring.Component):
    """One frame of the stage-select video, shown in grey on the VGA output
    (thesis Table 22, VGA debug view).

    Each incoming pixel's top ``pixel_bits`` are stored at its raster address
    (``first`` restarts at address 0; pixels past ``width * height`` and before
    the first ``first`` are dropped); at ``scale`` 2 only the pixels at even x
    and even y are stored. The VGA side scans the memory in step with a
    :class:`~soc.vga_timing.VgaTiming`, shows each stored pixel as a ``scale`` x
    ``scale`` block (the picture keeps its width x height) and widens each
    stored value to 8 bits by bit replication (4 bits ``v``: ``v << 4 | v``),
    the golden model :func:`sim.model.vga.vga_frame`. A frame smaller than the
    visible area sits at the top-left, the rest is black.

    Single buffer: the VGA side may show parts of two successive frames
    (tearing) when the pipeline writes while it reads; acceptable for a debug
    view, and it halves the memory.

    Memory: ``ceil(width / scale) * ceil(height / scale) * pixel_bits`` bits
    in one :class:`amaranth.lib.memory.Memory`, written in ``sync`` and read in
    ``vga`` (a true dual-clock block RAM). At the board size, 4 bits: 320 x 240
    x 4 = 307,200 bits at half resolution, 640 x 480 x 4 = 1,228,800 bits at
    full (their M10K blocks: docs/design/soc.md, Resources).

    Parameters
    ----------
    width : int in [1, mode.h_active]
    height : int in [1, mode.v_active]
        Size of the incoming frames.
    mode : VgaMode
        VGA timing (default 640x480 at 60 Hz).
    pixel_bits : int in [1, 8]
        Bits stored per pixel (top bits of the 8-bit input).
    scale : int in [1, 2]
        1: full resolution; 2 (default, :data:`VGA_SCALE`): half resolution in
        x and y, a quarter of the memory, because the M10K blocks are what the
        whole core runs short of.

    Ports
    -----
    i_stream : In, ``{first, pixel: 8}``, always ready, domain ``sync``.
    vga : Out(:class:`VgaOutputSignature`), domain ``vga``; every output is
        registered, and all of them refer to the same raster position,
        :data:`READ_LATENCY` pixel clocks after the timing counters. After
        reset the counters start at x = 0, y = 0.

    Raises
    ------
    ValueError
        Naming the parameter and its range.
    """

    def __init__(self, width: int = 640, height: int = 480,
                 mode: VgaMode = VGA_640x480_60, pixel_bits: int = 4, *,
                 scale: int = VGA_SCALE):
        if not isinstance(mode, VgaMode):
            raise ValueError(f"mode must be a VgaMode, got {mode!r}")
        self.mode = mode
        self.width = check_int("width", width, 1, mode.h_active)
        self.height = check_int("height", height, 1, mode.v_active)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, 1, 8)
        self.scale = check_int("scale", scale, *SCALE_RANGE)
        self.stored_width, self.stored_height = stored_size(self.width, self.height,
                                                            self.scale)
        self.depth = self.stored_width * self.stored_height
        self.memory_bits = self.depth * self.pixel_bits
        self.latency = READ_LATENCY
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout({"first": 1, "pixel": 8}),
                                            always_ready=True)),
            "vga": Out(VgaOutputSignature(mode.hsync_negative, mode.vsync_negative)),
        })

    def elaborate(self, platform):
        m = Module()
        pb, depth = self.pixel_bits, self.depth
        # what is shown before the first frame is written does not matter (the
        # simulators start it at zero); the Verilog skips the all-zero initialiser
        m.submodules.memory = mem = memory.Memory(shape=unsigned(pb), depth=depth, init=[],
                                                  attrs={NO_INIT_ATTR: "1"})
        write = mem.write_port()
        read = mem.read_port(domain="vga")

        # --- write side (pipeline clock) ---------------------------------------------
        # Starts "past the frame" so pixels before the first `first` are dropped.
        write_addr = Signal(range(depth + 1), init=depth)
        beat = self.i_stream.valid
        payload = self.i_stream.payload
        addr = Mux(payload.first, 0, write_addr)
        in_frame = payload.first | (write_addr < depth)
        store = in_frame
        if self.scale == 2:
            # the incoming raster position; only even columns of even rows are kept
            column = Signal(range(max(2, self.width)))
            odd_row = Signal()
            here = Mux(payload.first, 0, column)
            here_odd_row = Mux(payload.first, 0, odd_row)
            store = in_frame & ~here[0] & ~here_odd_row
            with m.If(beat):
                with m.If(here == self.width - 1):
                    m.d.sync += [column.eq(0), odd_row.eq(~here_odd_row)]
                with m.Else():
                    m.d.sync += [column.eq(here + 1), odd_row.eq(here_odd_row)]
        m.d.comb += [
            write.addr.eq(addr),
            write.data.eq(payload.pixel[8 - pb:]),
            write.en.eq(beat & store),
        ]
        with m.If(beat & store):
            m.d.sync += write_addr.eq(addr + 1)

        # --- read side (pixel clock) ---------------------------------------------------
        timing = VgaTiming(self.mode)
        m.submodules.timing = DomainRenamer("vga")(timing)
        # A raster counter instead of y * width + x; the blanking lines below the
        # image (there is at least the vertical sync) rewind it for the next frame.
        read_addr = Signal(range(depth + 1))
        in_image = (timing.x < self.width) & (timing.y < self.height)
        if self.scale == 1:
            with m.If(timing.y >= self.height):
                m.d.vga += read_addr.eq(0)
            with m.Elif(in_image):
                m.d.vga += read_addr.eq(read_addr + 1)
        else:
            # Each stored row is read on two lines, each word on two pixels:
            # the address advances after odd x, and at the end of a line goes
            # back to the row's start (after even y) or on to the next row.
            row_start = Signal(range(depth + 1))
            with m.If(timing.y >= self.height):
                m.d.vga += [read_addr.eq(0), row_start.eq(0)]
            with m.Elif(in_image & (timing.x == self.width - 1)):
                with m.If(timing.y[0]):
                    m.d.vga += [read_addr.eq(row_start + self.stored_width),
                                row_start.eq(row_start + self.stored_width)]
                with m.Else():
                    m.d.vga += read_addr.eq(row_start)
            with m.Elif(in_image & timing.x[0]):
                m.d.vga += read_addr.eq(read_addr + 1)
        m.d.comb += read.addr.eq(read_addr)

        # Stage 1: the memory reads; the decoded position waits beside it.
        # Sync registers start at the idle level, so reset makes no stray pulse.
        mode = self.mode
        hsync_1 = Signal(init=int(mode.hsync_negative))
        vsync_1 = Signal(init=int(mode.vsync_negative))
        active_1 = Signal()
        in_image_1 = Signal()
        m.d.vga += [hsync_1.eq(timing.hsync), vsync_1.eq(timing.vsync),
                    active_1.eq(timing.active), in_image_1.eq(in_image)]

        # Stage 2: output registers; grey by repeating the stored bits downwards.
        copies = -(-8 // pb)
        grey = Cat(*[read.data] * copies)[pb * copies - 8:]
        level = Mux(in_image_1, grey, 0)
        vga = self.vga
        m.d.vga += [
            vga.r.eq(level), vga.g.eq(level), vga.b.eq(level),
            vga.hsync.eq(hsync_1), vga.vsync.eq(vsync_1), vga.blank_n.eq(active_1),
        ]
        return m
