"""Driver of the FPGA's centroid FIFO peripheral (thesis §7.4.1,
Tables 12 and 13).

Runs on the board's ARM: Python 3 and numpy only, and :mod:`soc.hps_interface`
(shipped with it). The hardware slave (an Avalon-MM slave on the lightweight
HPS-to-FPGA bridge) and this driver take the register map from there, and
:class:`sw_hps.simulated.SimulatedFifoPeripheral` models it in software.

The register map is declared in :data:`soc.hps_interface.FIFO_REGISTERS` (its
``table()`` prints it): Dato_X and Dato_Y pop the two FIFOs (10.8 fixed point),
Control holds GO, FIFO data, gesture, FIFO-CLR, FIFO-FULL and STREAM, Longitud_X
and Longitud_Y count the entries, ID reads :data:`CORE_MAGIC` and Version the
core's build parameters (:meth:`FifoPeripheral.identify`).

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

from typing import Optional

from soc.hps_interface import (CONTROL, CORE_MAGIC, CORE_REVISION, CTRL_FIFO_CLR,
                               CTRL_FIFO_DATA, CTRL_FIFO_FULL, CTRL_GO, CTRL_NO_GESTURE,
                               CTRL_READABLE_MASK, CTRL_STREAM, DATO_X_FLAG, DATO_Y_PRESENT,
                               DATA_BITS, DATA_MASK, DATO_X, DATO_Y, FIFO_DEPTH, FRAC_BITS,
                               FRAME_HEIGHT, FRAME_WIDTH, ID, LIGHTWEIGHT_BRIDGE_BASE,
                               LONGITUD_X, LONGITUD_Y, REGISTER_SPAN, RESERVED, VERSION,
                               decode_version)

__all__ = [
    "DATO_X", "DATO_Y", "RESERVED", "CONTROL", "LONGITUD_X", "LONGITUD_Y", "ID", "VERSION",
    "REGISTER_SPAN", "CORE_MAGIC", "CORE_REVISION", "CoreIdentity",
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


def _ascii(word: int) -> str:
    """A register word as four characters, most significant byte first (how
    :data:`CORE_MAGIC` spells "SGST"); bytes that are not printable show as '.'."""
    return "".join(chr(b) if 0x20 <= b < 0x7F else "."
                   for b in ((word >> shift) & 0xFF for shift in (24, 16, 8, 0)))


@dataclass(frozen=True)
class CoreIdentity:
    """What the ID and Version registers say about the core behind the bridge.

    Attributes
    ----------
    magic : int
        The ID register as read.
    version_word : int
        The Version register as read.
    present : bool
        ID reads :data:`CORE_MAGIC`: a stereogest core answers at this address
        (a bitstream from before the ID register, an unconfigured FPGA or a
        disabled bridge reads something else).
    revision, fifo_depth, streaming, frame_width, frame_height : optional
        The Version register's fields (:func:`soc.hps_interface.decode_version`);
        None unless ``present`` (another word's bits mean nothing).
    """
    magic: int
    version_word: int
    present: bool
    revision: Optional[int] = None
    fifo_depth: Optional[int] = None
    streaming: Optional[bool] = None
    frame_width: Optional[int] = None
    frame_height: Optional[int] = None

    @classmethod
    def decode(cls, magic: int, version_word: int) -> "CoreIdentity":
        """The record for the two register words."""
        magic, version_word = int(magic) & 0xFFFFFFFF, int(version_word) & 0xFFFFFFFF
        if magic != CORE_MAGIC:
            return cls(magic=magic, version_word=version_word, present=False)
        return cls(magic=magic, version_word=version_word, present=True,
                   **decode_version(version_word))

    @property
    def supported(self) -> bool:
        """A core whose register map is the one this driver was written for
        (:data:`CORE_REVISION`)."""
        return self.present and self.revision == CORE_REVISION

    def describe(self) -> str:
        """One line for logs and ``--check``."""
        if not self.present:
            return (f"no stereogest core: ID reads {self.magic:#010x} ('{_ascii(self.magic)}'), "
                    f"expected {CORE_MAGIC:#010x} ('{_ascii(CORE_MAGIC)}'): no FPGA image "
                    f"loaded, the bridge not enabled, a bitstream from before the ID "
                    f"register, or a wrong bridge offset")
        line = (f"stereogest core, register map revision {self.revision}: FIFO depth "
                f"{self.fifo_depth}, streaming mode "
                f"{'implemented' if self.streaming else 'absent'}, frames "
                f"{self.frame_width}x{self.frame_height} (Version {self.version_word:#010x})")
        if not self.supported:
            line += f"; this application expects revision {CORE_REVISION}"
        return line


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

    def identify(self) -> CoreIdentity:
        """Read ID and Version (two bus reads, no side effect): which core
        answers at this address and with what parameters it was built."""
        return CoreIdentity.decode(self._read(ID), self._read(VERSION))

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
