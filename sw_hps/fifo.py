"""Register map and driver of the FPGA's centroid FIFO peripheral (thesis §7.4.1,
Tables 12 and 13).

Runs on the board's ARM: Python 3 and numpy only, nothing else from this project.
This module is the one definition of the register interface; the hardware slave
(an Avalon-MM slave on the lightweight HPS-to-FPGA bridge) implements exactly it,
and :class:`sw_hps.simulated.SimulatedFifoPeripheral` models it in software.

Register map (byte offsets from the slave's base, 32-bit words)
---------------------------------------------------------------

======  ==========  ====  ==========================================================
offset  name        kind  meaning
======  ==========  ====  ==========================================================
0x00    Dato_X      R     pops the X FIFO: smoothed centroid x, unsigned 10.8 fixed
                          point in bits [17:0] (bits [31:18] read 0); an empty FIFO
                          reads 0 and pops nothing
0x04    Dato_Y      R     pops the Y FIFO (same format)
0x08    reserved    R     reads 0, writes ignored
0x0C    Control     R/W   bit 0 GO (R/W): 1 = capture runs (pairs are pushed and the
                          gesture bit follows the spotting flag);
                          bit 1 FIFO data (RO): 1 = both FIFOs hold >= 1 entry;
                          bit 2 gesture (RO): 1 = NO valid gesture in progress (the
                          thesis polarity: 0 while the spotting flag is set);
                          bit 3 FIFO-CLR (W1): writing 1 empties both FIFOs and
                          clears FIFO-FULL; self-clearing, reads 0;
                          bit 4 FIFO-FULL (RO, sticky): a push found a FIFO full
                          since the last FIFO-CLR (that pair was dropped);
                          bits [31:5] read 0, writes to RO bits are ignored
0x10    Longitud_X  R     number of entries in the X FIFO (0..FIFO_DEPTH)
0x14    Longitud_Y  R     number of entries in the Y FIFO (0..FIFO_DEPTH)
======  ==========  ====  ==========================================================

The gesture spotting runs whatever GO is; GO gates its effects. While GO is 1 the
hardware pushes one (x, y) pair per video frame whose spotting flag is set, and the
gesture bit reads NOT(GO AND flag) (0 = gesture in progress, from the frame the flag
rises until the frame it falls; setting GO during a gesture shows it at once). If
either FIFO is full the pair is dropped from both (they stay aligned) and FIFO-FULL
is set. While GO is 0 nothing is pushed and the gesture bit reads 1. The FIFO
depth of the hardware is :data:`FIFO_DEPTH` (512 x 18 bits fits one M10K block per
FIFO; a gesture of the thesis lasts 40-100 frames).

The pushed values are smoothed centroids of the board's :data:`FRAME_WIDTH` x
:data:`FRAME_HEIGHT` frames: 0 <= x < FRAME_WIDTH, 0 <= y < FRAME_HEIGHT in pixels
(``x << FRAC_BITS`` in the register). X and Y are pushed in the same cycle and popped
in pairs, so Longitud_X equals Longitud_Y (two reads can straddle a push, though).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "DATO_X", "DATO_Y", "RESERVED", "CONTROL", "LONGITUD_X", "LONGITUD_Y", "REGISTER_SPAN",
    "CTRL_GO", "CTRL_FIFO_DATA", "CTRL_NO_GESTURE", "CTRL_FIFO_CLR", "CTRL_FIFO_FULL",
    "CTRL_READABLE_MASK", "FRAC_BITS", "DATA_BITS", "DATA_MASK", "FIFO_DEPTH",
    "FRAME_WIDTH", "FRAME_HEIGHT", "LIGHTWEIGHT_BRIDGE_BASE", "FifoStatus", "FifoPeripheral",
    "to_fixed", "from_fixed",
]

# ---- register offsets (bytes) -------------------------------------------------------
DATO_X = 0x00
DATO_Y = 0x04
RESERVED = 0x08
CONTROL = 0x0C
LONGITUD_X = 0x10
LONGITUD_Y = 0x14
#: Bytes the slave decodes (six 32-bit words).
REGISTER_SPAN = 0x18

# ---- Control bits ---------------------------------------------------------------
CTRL_GO = 1 << 0
CTRL_FIFO_DATA = 1 << 1
CTRL_NO_GESTURE = 1 << 2
CTRL_FIFO_CLR = 1 << 3
CTRL_FIFO_FULL = 1 << 4
#: Bits of Control that can read 1 (FIFO-CLR always reads 0).
CTRL_READABLE_MASK = CTRL_GO | CTRL_FIFO_DATA | CTRL_NO_GESTURE | CTRL_FIFO_FULL

# ---- data format ----------------------------------------------------------------
#: Fractional bits of Dato_X / Dato_Y (10.8 fixed point, thesis eq. 27).
FRAC_BITS = 8
#: Bits used in Dato_X / Dato_Y.
DATA_BITS = 18
DATA_MASK = (1 << DATA_BITS) - 1
#: Entries per FIFO in the hardware.
FIFO_DEPTH = 512
#: Frame size of the board in pixels (the OV5642 register table sets 640 x 480; the
#: SoC is built at this size, ``soc.core.StereogestCore``'s default, checked by the
#: tests). Dato_X / Dato_Y lie in [0, FRAME_WIDTH) / [0, FRAME_HEIGHT).
FRAME_WIDTH = 640
FRAME_HEIGHT = 480

#: Physical base address of the lightweight HPS-to-FPGA bridge (Cyclone V HPS).
LIGHTWEIGHT_BRIDGE_BASE = 0xFF200000


def to_fixed(pixels: float) -> int:
    """Pixels to the 10.8 fixed-point register value (rounded, clipped to 18 bits)."""
    value = int(round(float(pixels) * (1 << FRAC_BITS)))
    return min(max(value, 0), DATA_MASK)


def from_fixed(raw: int) -> float:
    """10.8 fixed-point register value (low 18 bits) to pixels."""
    return (int(raw) & DATA_MASK) / (1 << FRAC_BITS)


@dataclass(frozen=True)
class FifoStatus:
    """Decoded Control register plus the two FIFO lengths (thesis Table 13).

    Attributes
    ----------
    control : int
        Raw Control word.
    go, data, no_gesture, full : bool
        GO, FIFO data, gesture (1 = no gesture, thesis polarity), FIFO-FULL.
    length_x, length_y : int
        Longitud_X, Longitud_Y.
    """
    control: int
    go: bool
    data: bool
    no_gesture: bool
    full: bool
    length_x: int
    length_y: int

    @property
    def gesture_active(self) -> bool:
        """True while the hardware flags a gesture in progress (gesture bit 0)."""
        return not self.no_gesture

    @property
    def pairs_available(self) -> int:
        """Pairs that can be popped now: min of the lengths, 0 if FIFO data is 0."""
        return min(self.length_x, self.length_y) if self.data else 0

    @classmethod
    def decode(cls, control: int, length_x: int, length_y: int) -> "FifoStatus":
        control = int(control) & 0xFFFFFFFF
        return cls(control=control, go=bool(control & CTRL_GO),
                   data=bool(control & CTRL_FIFO_DATA),
                   no_gesture=bool(control & CTRL_NO_GESTURE),
                   full=bool(control & CTRL_FIFO_FULL),
                   length_x=int(length_x) & 0xFFFFFFFF, length_y=int(length_y) & 0xFFFFFFFF)


class FifoPeripheral:
    """Typed driver of the FIFO slave over any :class:`sw_hps.bus.Bus`
    (thesis §7.4.1, Tables 12-13).

    Parameters
    ----------
    bus : Bus
        Register access (``read32``, ``write32``).
    base : int
        Byte offset of the slave inside the bus window (multiple of 4).
    """

    def __init__(self, bus, base: int = 0):
        if isinstance(base, bool) or not isinstance(base, int) or base < 0 or base % 4:
            raise ValueError(f"base must be a non-negative multiple of 4, got {base!r}")
        self.bus = bus
        self.base = base

    def _read(self, offset: int) -> int:
        return int(self.bus.read32(self.base + offset)) & 0xFFFFFFFF

    def _write(self, offset: int, value: int) -> None:
        self.bus.write32(self.base + offset, value & 0xFFFFFFFF)

    def control(self) -> int:
        """Raw Control word."""
        return self._read(CONTROL)

    def start(self) -> None:
        """Set GO: capture runs."""
        self._write(CONTROL, CTRL_GO)

    def stop(self) -> None:
        """Clear GO: capture stops."""
        self._write(CONTROL, 0)

    def clear(self, keep_running: bool = True) -> None:
        """Empty both FIFOs and clear FIFO-FULL (FIFO-CLR), leaving GO set if
        ``keep_running`` (one write: GO and FIFO-CLR together)."""
        self._write(CONTROL, CTRL_FIFO_CLR | (CTRL_GO if keep_running else 0))

    def status(self) -> FifoStatus:
        """Read Control, Longitud_X and Longitud_Y (three bus reads)."""
        control = self._read(CONTROL)
        return FifoStatus.decode(control, self._read(LONGITUD_X), self._read(LONGITUD_Y))

    def lengths(self) -> tuple[int, int]:
        """Read Longitud_X and Longitud_Y only (two bus reads)."""
        return self._read(LONGITUD_X), self._read(LONGITUD_Y)

    def pop_words(self) -> tuple[int, int]:
        """Pop one pair as the whole 32-bit Dato_X / Dato_Y words (bits [31:18]
        should read 0; unlike :meth:`pop_raw` they are kept so a caller can check)."""
        return self._read(DATO_X), self._read(DATO_Y)

    def pop_raw(self) -> tuple[int, int]:
        """Pop one pair as raw 10.8 fixed-point integers (low 18 bits)."""
        x, y = self.pop_words()
        return x & DATA_MASK, y & DATA_MASK

    def pop(self) -> tuple[float, float]:
        """Pop one pair in pixels (10.8 decoded)."""
        x, y = self.pop_raw()
        return from_fixed(x), from_fixed(y)
