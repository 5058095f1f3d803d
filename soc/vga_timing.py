"""VGA raster timing of the debug view (thesis Table 22, §7.5: SW[9:7] selects
the pipeline stage shown on the DE1-SoC VGA output at 640x480, 60 Hz).

:class:`VgaMode` holds the figures of one video mode, :data:`VGA_640x480_60`
the industry-standard (VESA DMT) 640x480 mode, and :class:`VgaTiming` counts
the raster and decodes the sync pulses in the pixel-clock domain.

Raster convention (shared with the golden model :func:`sim.model.vga.vga_frame`)
-------------------------------------------------------------------------------
A line is ``h_active`` visible pixels (x = 0 .. h_active-1), then the front
porch, the sync pulse and the back porch; a frame is ``v_active`` visible lines,
then the vertical front porch, sync and back porch, counted in whole lines (the
vertical sync changes at x = 0). A negative-polarity sync is low during its
pulse and high otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import Out

from sim.model.validation import check_int

__all__ = ["VgaMode", "VGA_640x480_60", "VgaTiming"]

#: Largest total line length / frame height accepted (keeps the counters small).
MAX_TOTAL = 8192


@dataclass(frozen=True)
class VgaMode:
    """Figures of one VGA video mode, in pixel clocks (horizontal) and lines
    (vertical).

    Parameters
    ----------
    pixel_clock : int
        Pixel clock in Hz (>= 1).
    h_active, h_front, h_sync, h_back : int
        Visible pixels, front porch, sync pulse and back porch of a line
        (active and sync >= 1, porches >= 0).
    v_active, v_front, v_sync, v_back : int
        The same in lines, for a frame.
    hsync_negative, vsync_negative : bool
        True when the sync pulse is low-active.

    Raises
    ------
    ValueError
        Naming the field, if a figure is not an integer in its range, a
        polarity is not a bool, or a total exceeds 8192.
    """

    pixel_clock: int
    h_active: int
    h_front: int
    h_sync: int
    h_back: int
    v_active: int
    v_front: int
    v_sync: int
    v_back: int
    hsync_negative: bool
    vsync_negative: bool

    def __post_init__(self):
        lows = {"pixel_clock": 1, "h_active": 1, "h_sync": 1, "v_active": 1, "v_sync": 1}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name.endswith("_negative"):
                if not isinstance(value, bool):
                    raise ValueError(f"{f.name} must be a bool, got {value!r}")
            elif f.name == "pixel_clock":
                check_int(f.name, value, 1)
            else:
                check_int(f.name, value, lows.get(f.name, 0), MAX_TOTAL)
        for name, total in (("h_total", self.h_total), ("v_total", self.v_total)):
            if total > MAX_TOTAL:
                raise ValueError(f"{name} must be in [1, {MAX_TOTAL}], got {total}")

    @property
    def h_total(self) -> int:
        """Pixel clocks per line."""
        return self.h_active + self.h_front + self.h_sync + self.h_back

    @property
    def v_total(self) -> int:
        """Lines per frame."""
        return self.v_active + self.v_front + self.v_sync + self.v_back

    @property
    def h_sync_start(self) -> int:
        """x of the first pixel clock of the horizontal sync pulse."""
        return self.h_active + self.h_front

    @property
    def v_sync_start(self) -> int:
        """y of the first line of the vertical sync pulse."""
        return self.v_active + self.v_front

    @property
    def refresh_hz(self) -> float:
        """Frames per second at ``pixel_clock``."""
        return self.pixel_clock / (self.h_total * self.v_total)


#: 640x480 at 60 Hz (VESA DMT): 800 x 525 total, 25.175 MHz, 59.94 Hz, both
#: syncs negative. The DE1-SoC's PLL gives 25 MHz (59.52 Hz), which monitors accept.
VGA_640x480_60 = VgaMode(25_175_000, 640, 16, 96, 48, 480, 10, 2, 33, True, True)


class VgaTiming(wiring.Component):
    """Raster counters and sync decoding of the VGA debug view (thesis Table 22).

    Runs in the ``sync`` domain; rename it to the pixel-clock domain
    (``DomainRenamer("vga")``).

    Parameters
    ----------
    mode : VgaMode

    Ports
    -----
    x : Out(range(h_total)), y : Out(range(v_total))
        The raster position (registers; x = 0, y = 0 after reset).
    active : Out(1)
        Position inside the visible area.
    hsync, vsync : Out(1)
        Sync pulses with the mode's polarity.
    frame_start : Out(1)
        High at x = 0, y = 0.

    ``active``, ``hsync``, ``vsync`` and ``frame_start`` are decoded
    combinationally from ``x`` and ``y`` in the same cycle; users register them.
    """

    def __init__(self, mode: VgaMode = VGA_640x480_60):
        if not isinstance(mode, VgaMode):
            raise ValueError(f"mode must be a VgaMode, got {mode!r}")
        self.mode = mode
        super().__init__({
            "x": Out(range(mode.h_total)),
            "y": Out(range(mode.v_total)),
            "active": Out(1),
            "hsync": Out(1),
            "vsync": Out(1),
            "frame_start": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        mode = self.mode
        x, y = self.x, self.y
        line_end = x == mode.h_total - 1
        with m.If(line_end):
            m.d.sync += x.eq(0)
            with m.If(y == mode.v_total - 1):
                m.d.sync += y.eq(0)
            with m.Else():
                m.d.sync += y.eq(y + 1)
        with m.Else():
            m.d.sync += x.eq(x + 1)
        in_hsync = (x >= mode.h_sync_start) & (x < mode.h_sync_start + mode.h_sync)
        in_vsync = (y >= mode.v_sync_start) & (y < mode.v_sync_start + mode.v_sync)
        m.d.comb += [
            self.active.eq((x < mode.h_active) & (y < mode.v_active)),
            self.hsync.eq(in_hsync ^ int(mode.hsync_negative)),
            self.vsync.eq(in_vsync ^ int(mode.vsync_negative)),
            self.frame_start.eq((x == 0) & (y == 0)),
        ]
        return m
