"""Driver of the FPGA's centroid FIFO peripheral (thesis §7.4.1,
Tables 12 and 13).

Runs on the board's ARM: Python 3 and numpy only, and :mod:`soc.hps_interface`
(shipped with it). The hardware slave (an Avalon-MM slave on the lightweight
HPS-to-FPGA bridge) and this driver take the register map from there, and
:class:`sw_hps.simulated.SimulatedFifoPeripheral` models it in software.

The register map is declared in :data:`soc.hps_interface.FIFO_REGISTERS` (its
``table()`` prints it): Dato_X and Dato_Y pop the two FIFOs (10.8 fixed point),
Control holds GO, FIFO data, gesture, FIFO-CLR, FIFO-FULL and STREAM, Longitud_X
and Longitud_Y count the entries.

The gesture spotting runs whatever GO is; GO gates its effects. While GO is 1 the
hardware pushes one (x, y) pair per video frame whose spotting flag is set, and the
gesture bit reads NOT(GO AND flag) (0 = gesture in progress, from the frame the flag
rises until the frame it falls; setting GO during a gesture shows it at once). If
either FIFO is full the pair is dropped from both (they stay aligned) and FIFO-FULL
is set. While GO is 0 nothing is pushed and the gesture bit reads 1. The FIFO
depth of the hardware is :data:`FIFO_DEPTH` (512 x 19 bits fits one M10K block per
FIFO; a gesture of the thesis lasts 40-100 frames).

Streaming mode (STREAM = 1, issue 28): while GO is 1 every frame is pushed, with
the spotting flag in Dato_X's FLAG bit and whether the frame saw a hand in
Dato_Y's PRESENT bit (:meth:`FifoPeripheral.pop_record`), so that the
application finds gesture boundaries itself; both bits read 0 in the thesis mode.

The pushed values are smoothed centroids of the board's :data:`FRAME_WIDTH` x
:data:`FRAME_HEIGHT` frames: 0 <= x < FRAME_WIDTH, 0 <= y < FRAME_HEIGHT in pixels
(``x << FRAC_BITS`` in the register). X and Y are pushed in the same cycle and popped
in pairs, so Longitud_X equals Longitud_Y (two reads can straddle a push, though).
"""
from __future__ import annotations

from dataclasses import dataclass

from soc.hps_interface import (CONTROL, CTRL_FIFO_CLR, CTRL_FIFO_DATA, CTRL_FIFO_FULL,
                               CTRL_GO, CTRL_NO_GESTURE, CTRL_READABLE_MASK, CTRL_STREAM,
                               DATO_X_FLAG, DATO_Y_PRESENT, DATA_BITS,
                               DATA_MASK, DATO_X, DATO_Y, FIFO_DEPTH, FRAC_BITS, FRAME_HEIGHT,
                               FRAME_WIDTH, LIGHTWEIGHT_BRIDGE_BASE, LONGITUD_X, LONGITUD_Y,
                               REGISTER_SPAN, RESERVED)

__all__ = [
    "DATO_X", "DATO_Y", "RESERVED", "CONTROL", "LONGITUD_X", "LONGITUD_Y", "REGISTER_SPAN",
    "CTRL_GO", "CTRL_FIFO_DATA", "CTRL_NO_GESTURE", "CTRL_FIFO_CLR", "CTRL_FIFO_FULL",
    "CTRL_READABLE_MASK", "CTRL_STREAM", "DATO_X_FLAG", "DATO_Y_PRESENT", "FRAC_BITS", "DATA_BITS", "DATA_MASK", "FIFO_DEPTH",
    "FRAME_WIDTH", "FRAME_HEIGHT", "LIGHTWEIGHT_BRIDGE_BASE", "FifoStatus", "FifoPeripheral",
    "to_fixed", "from_fixed",
]

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
    streaming : bool
        STREAM: every frame's record is pushed.
    """
    control: int
    go: bool
    data: bool
    no_gesture: bool
    full: bool
    length_x: int
    length_y: int
    streaming: bool = False

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
                   length_x=int(length_x) & 0xFFFFFFFF, length_y=int(length_y) & 0xFFFFFFFF,
                   streaming=bool(control & CTRL_STREAM))


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

    def start(self, streaming: bool = False) -> None:
        """Set GO: capture runs (``streaming``: every frame's record is pushed,
        Control.STREAM)."""
        self._write(CONTROL, CTRL_GO | (CTRL_STREAM if streaming else 0))

    def stop(self) -> None:
        """Clear GO: capture stops."""
        self._write(CONTROL, 0)

    def clear(self, keep_running: bool = True, streaming: bool = False) -> None:
        """Empty both FIFOs and clear FIFO-FULL (FIFO-CLR), leaving GO set if
        ``keep_running`` (one write: GO, STREAM and FIFO-CLR together)."""
        self._write(CONTROL, CTRL_FIFO_CLR | (CTRL_GO if keep_running else 0)
                    | (CTRL_STREAM if streaming else 0))

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

    def pop_record(self) -> tuple[int, int, bool, bool]:
        """Pop one streaming-mode record: raw 10.8 x and y, the frame's spotting
        flag (Dato_X.FLAG) and whether it saw a hand (Dato_Y.PRESENT)."""
        x, y = self.pop_words()
        return x & DATA_MASK, y & DATA_MASK, bool(x & DATO_X_FLAG), bool(y & DATO_Y_PRESENT)
