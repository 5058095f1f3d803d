"""OV5642 camera capture (thesis §5.2, Fig. 25, Table 9).

Turns the camera's pins (VSYNC, HREF, 8 data bits, one byte per PCLK cycle) into a
stream of pixel words ``{sof, sol, luma, chroma}``: each word is one luma byte and
the chroma byte that follows it (Cb for even x, Cr for odd x, as the YCbCr 4:2:2
byte order ``Y0 Cb0 Y1 Cr0 ...``; the receiver tells which from x).

All logic runs in the component's ``sync`` domain; the system renames it to the
camera's PCLK domain (``DomainRenamer("cam_left")(CameraCapture(...))``). The
ports stay reachable through the renamed object (it forwards attribute access),
or the composer keeps a reference to the component itself, as
``hdl/gesture_pipeline.py`` does.

Golden model: :func:`sim.camera.capture_words` (start high, pause low, output
always ready).
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.wiring import In, Out

from ._util import check_geometry

__all__ = ["CameraCapture", "capture_word_layout"]


def capture_word_layout() -> data.StructLayout:
    """Payload of a captured word: start of frame, start of line, the pair's bytes."""
    return data.StructLayout({"sof": 1, "sol": 1, "luma": 8, "chroma": 8})


class CameraCapture(wiring.Component):
    """Pixel words from the pins of one OV5642 camera (thesis §5.2, Table 9).

    Parameters
    ----------
    width : int in [8, 4096], even
        Pixels per line kept (words with x >= width are cropped).
    height : int in [2, 4096]
        Lines per frame kept (lines with y >= height are cropped).

    Ports (all in domain ``sync``, i.e. the camera's PCLK after renaming)
    -----
    vsync, href : In(1); data : In(8)
        Camera pins, registered once on entry.
    start, pause : In(1)
        Asynchronous controls, synchronised by two-flop ``FFSynchronizer``s.
        ``start`` low stops capture at once (the frame in progress is cut);
        ``pause`` high lets the frame in progress complete but begins no new one.
    o_stream : Out(stream.Signature(capture_word_layout())), with ``ready``
        One word per byte pair. A word emitted while ``ready`` is low is lost: it
        counts an overrun and nothing more is emitted until the next frame
        boundary, so the receiver sees a clean ``sof`` next.
    x, y : Out
        Position of the next pixel (saturating at ``width`` / ``height``).
    frames : Out(16)
        Frames started (wrapping).
    overruns : Out(16)
        Words lost to ``ready`` low (wrapping).

    Timing
    ------
    A word is valid on ``o_stream`` ``latency`` = 2 cycles after its chroma byte is
    on the pins (pin register, word register).

    Frame boundary: a VSYNC-low cycle right after a VSYNC-high cycle whose HREF was
    low. Capture waits for one after reset, after ``start`` rises, after ``pause``
    falls and after an overrun. A VSYNC pulse with HREF high (a glitch inside a
    line) ends the frame but is not a boundary, so the rest of the damaged frame is
    not captured as a new frame.
    """

    latency = 2

    def __init__(self, width: int, height: int):
        self.width, self.height = check_geometry(width, height)
        if self.width % 2:
            raise ValueError(f"width must be even (4:2:2 pixel pairs) in [8, 4096], "
                             f"got {self.width}")
        super().__init__({
            "vsync": In(1), "href": In(1), "data": In(8),
            "start": In(1), "pause": In(1),
            "o_stream": Out(stream.Signature(capture_word_layout())),
            "x": Out(range(self.width + 1)), "y": Out(range(self.height + 1)),
            "frames": Out(16), "overruns": Out(16),
        })

    def elaborate(self, platform):
        m = Module()
        w, h = self.width, self.height

        start = Signal()
        pause = Signal()
        m.submodules.start_sync = FFSynchronizer(self.start, start, o_domain="sync")
        m.submodules.pause_sync = FFSynchronizer(self.pause, pause, o_domain="sync")

        # pins, registered once (the I/O flops)
        vsync = Signal()
        href = Signal()
        byte = Signal(8)
        href_prev = Signal()
        m.d.sync += [vsync.eq(self.vsync), href.eq(self.href), byte.eq(self.data),
                     href_prev.eq(href)]

        active = Signal()        # inside a frame being captured
        boundary = Signal()      # last VSYNC-high cycle had HREF low (and no pause)
        lines = Signal(range(h + 1))  # lines started in this frame (saturating)
        # 1: the luma byte of a pair is held. Every line restarts it at HREF rising,
        # so HREF falling between the two bytes of a pair drops the lone luma.
        phase = Signal()
        luma = Signal(8)
        x, y = self.x, self.y

        out = self.o_stream
        overrun = out.valid & ~out.ready
        frame_start = ~vsync & boundary & ~pause
        live = (active | frame_start) & ~vsync
        line_base = Mux(frame_start, 0, lines)

        m.d.sync += out.valid.eq(0)
        with m.If(overrun):
            m.d.sync += self.overruns.eq(self.overruns + 1)

        with m.If(~start | overrun):
            # Stop now; only a whole new frame restarts the capture.
            m.d.sync += [active.eq(0), boundary.eq(0)]
        with m.Else():
            with m.If(vsync):
                # any VSYNC-high cycle ends the frame; a boundary needs HREF low
                m.d.sync += [active.eq(0), boundary.eq(~href & ~pause)]
            with m.Else():
                m.d.sync += boundary.eq(0)
                with m.If(frame_start):
                    m.d.sync += [active.eq(1), lines.eq(0), x.eq(0), y.eq(0),
                                 self.frames.eq(self.frames + 1)]
                with m.If(live & href):
                    with m.If(~href_prev):
                        # HREF rising: a new line, this byte is its first luma
                        m.d.sync += [x.eq(0), y.eq(line_base),
                                     lines.eq(Mux(line_base == h, h, line_base + 1)),
                                     luma.eq(byte), phase.eq(1)]
                    with m.Elif(~phase):
                        m.d.sync += [luma.eq(byte), phase.eq(1)]
                    with m.Else():
                        m.d.sync += [
                            out.valid.eq((x < w) & (y < h)),
                            out.payload.sof.eq((x == 0) & (y == 0)),
                            out.payload.sol.eq(x == 0),
                            out.payload.luma.eq(luma),
                            out.payload.chroma.eq(byte),
                            x.eq(Mux(x == w, w, x + 1)),
                            phase.eq(0),
                        ]
        return m
