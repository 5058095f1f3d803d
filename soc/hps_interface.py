"""What the FPGA side and the HPS application agree on (thesis §7.4.1, §8.5.1):
the lightweight bridge, where each slave sits on it, each slave's registers and
their fields, the data format of the centroid FIFO and the gesture classes.

The one definition of these facts. The hardware slaves (:mod:`soc.fifo_slave`,
:mod:`soc.uart`) decode the registers declared here, Platform Designer places
the slaves at :data:`SLAVE_BASES`, the board application (:mod:`sw_hps`)
drives them with the constants below, and the renderer and the recogniser name
the classes with :data:`GESTURE_NAMES`. Python's standard library only: the
board bundle ships this file beside ``sw_hps`` (Python 3 + numpy on the ARM).

Registers are declared the way amaranth-soc declares a peripheral's: each
register and each field named, with its access and meaning; the flat
``NAME = offset`` / ``NAME = mask`` constants the drivers use are derived from
the declarations, and :meth:`RegisterMap.table` renders the map for the docs.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "Field", "Register", "RegisterMap",
    "LIGHTWEIGHT_BRIDGE_BASE", "SLAVE_WINDOW", "SLAVE_BASES", "FIFO_BASE", "UART_BASE",
    "FIFO_REGISTERS", "UART_REGISTERS", "GESTURE_NAMES",
    "FRAC_BITS", "DATA_BITS", "DATA_MASK", "FIFO_DEPTH", "FRAME_WIDTH", "FRAME_HEIGHT",
    "DATO_X", "DATO_Y", "RESERVED", "CONTROL", "LONGITUD_X", "LONGITUD_Y", "REGISTER_SPAN",
    "ID", "VERSION", "CORE_MAGIC", "CORE_REVISION", "version_word", "decode_version",
    "CTRL_GO", "CTRL_FIFO_DATA", "CTRL_NO_GESTURE", "CTRL_FIFO_CLR", "CTRL_FIFO_FULL",
    "CTRL_READABLE_MASK", "CTRL_STREAM", "DATO_X_FLAG", "DATO_Y_PRESENT",
    "UART_TXDATA", "UART_STATUS", "UART_RXDATA", "UART_SPAN", "UART_STATUS_TX_READY",
    "UART_STATUS_RX_VALID",
    "POSTURE_SECTORS", "POSTURE_RING_EDGES_16THS", "POSTURE_RINGS", "POSTURE_BANDS",
    "POSTURE_BAND_SPAN", "POSTURE_WORDS", "POSTURE_WORD_COUNT", "posture_word_offsets",
    "POSTURE_BASE", "POSTURE_REGISTERS", "POSTURE_STATUS", "POSTURE_INDEX", "POSTURE_DATA",
    "POSTURE_LAYOUT", "POSTURE_SPAN", "POSTURE_STATUS_SEQ", "posture_layout_word",
]

#: Access kinds of registers and fields: read (a read may pop), write, read/write,
#: read-only beside writable bits, write-one (self-clearing, reads 0).
ACCESS = ("R", "W", "RW", "RO", "W1")


@dataclass(frozen=True)
class Field:
    """Bits ``[bit + width - 1 : bit]`` of a register."""
    name: str
    bit: int
    width: int
    access: str
    doc: str

    def __post_init__(self):
        if self.access not in ACCESS:
            raise ValueError(f"access of field {self.name!r} must be one of {ACCESS}, "
                             f"got {self.access!r}")
        if not (0 <= self.bit and 1 <= self.width and self.bit + self.width <= 32):
            raise ValueError(f"field {self.name!r} must lie in bits [31:0]")

    @property
    def mask(self) -> int:
        """The field's bits in the register word."""
        return ((1 << self.width) - 1) << self.bit


@dataclass(frozen=True)
class Register:
    """One 32-bit register at a byte ``offset`` from the slave's base."""
    name: str
    offset: int
    access: str
    doc: str
    fields: tuple[Field, ...] = ()

    def __post_init__(self):
        if self.access not in ACCESS or self.offset % 4:
            raise ValueError(f"register {self.name!r}: access in {ACCESS}, offset a "
                             f"multiple of 4")
        used = 0
        for f in self.fields:
            if used & f.mask:
                raise ValueError(f"register {self.name!r}: field {f.name!r} overlaps")
            used |= f.mask

    def __getitem__(self, name: str) -> Field:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(f"register {self.name!r} has no field {name!r}")

    @property
    def word(self) -> int:
        """Word address (``offset // 4``), what the slave decodes."""
        return self.offset // 4


@dataclass(frozen=True)
class RegisterMap:
    """A slave's registers; ``span`` bytes are decoded."""
    name: str
    span: int
    registers: tuple[Register, ...]

    def __post_init__(self):
        offsets = [r.offset for r in self.registers]
        if len(set(offsets)) != len(offsets) or max(offsets) >= self.span:
            raise ValueError(f"register map {self.name!r}: offsets must differ and lie "
                             f"below the span {self.span:#x}")

    def __getitem__(self, name: str) -> Register:
        for r in self.registers:
            if r.name == name:
                return r
        raise KeyError(f"register map {self.name!r} has no register {name!r}")

    def __iter__(self):
        return iter(self.registers)

    @property
    def address_width(self) -> int:
        """Word-address bits the slave decodes."""
        return max(1, (self.span // 4 - 1).bit_length())

    def table(self) -> str:
        """The map as a reStructuredText table (offset, name, access, meaning)."""
        rows = []
        for r in self.registers:
            rows.append((f"{r.offset:#04x}", r.name, r.access, r.doc))
            for f in r.fields:
                bits = f"bits [{f.bit + f.width - 1}:{f.bit}]" if f.width > 1 else f"bit {f.bit}"
                rows.append(("", "", "", f"{bits} {f.name} ({f.access}): {f.doc}"))
        widths = [max(len(row[k]) for row in rows + [("offset", "name", "kind", "meaning")])
                  for k in range(4)]
        rule = "  ".join("=" * w for w in widths)
        fmt = "  ".join(f"{{:<{w}}}" for w in widths)
        lines = [rule, fmt.format("offset", "name", "kind", "meaning").rstrip(), rule]
        lines += [fmt.format(*row).rstrip() for row in rows]
        return "\n".join(lines + [rule])


# ---- the bridge -----------------------------------------------------------------
#: Physical base address of the lightweight HPS-to-FPGA bridge (Cyclone V HPS).
LIGHTWEIGHT_BRIDGE_BASE = 0xFF200000
#: Bytes each slave's window takes on the bridge (slave bases are multiples of it).
SLAVE_WINDOW = 0x100
#: Byte offset of each slave of the core from the bridge's base.
SLAVE_BASES = {"fifo": 0x000, "uart": 0x100, "posture": 0x200}
FIFO_BASE = SLAVE_BASES["fifo"]
UART_BASE = SLAVE_BASES["uart"]
POSTURE_BASE = SLAVE_BASES["posture"]

# ---- the centroid FIFO's data ---------------------------------------------------
#: Fractional bits of Dato_X / Dato_Y (10.8 fixed point, thesis eq. 27).
FRAC_BITS = 8
#: Bits used in Dato_X / Dato_Y.
DATA_BITS = 18
DATA_MASK = (1 << DATA_BITS) - 1
#: Entries per FIFO in the hardware (512 x 18 bits: one M10K block per FIFO; a
#: gesture of the thesis lasts 40-100 frames).
FIFO_DEPTH = 512
#: Frame size of the board in pixels (the OV5642 register table sets 640 x 480;
#: the SoC is built at this size). Dato_X / Dato_Y lie in [0, FRAME_WIDTH) /
#: [0, FRAME_HEIGHT).
FRAME_WIDTH = 640
FRAME_HEIGHT = 480

#: The centroid FIFO slave (thesis §7.4.1, Table 12: registers; Table 13: Control).
FIFO_REGISTERS = RegisterMap("fifo", span=0x20, registers=(
    Register("Dato_X", 0x00, "R",
             "pops the X FIFO: smoothed centroid x, unsigned 10.8 fixed point; an "
             "empty FIFO reads 0 and pops nothing",
             (Field("data", 0, DATA_BITS, "R", "x << FRAC_BITS (bits above FLAG read 0)"),
              Field("FLAG", DATA_BITS, 1, "R", "streaming mode: the frame's spotting flag "
                                               "(0 in the thesis mode)"))),
    Register("Dato_Y", 0x04, "R", "pops the Y FIFO (same format)",
             (Field("data", 0, DATA_BITS, "R", "y << FRAC_BITS"),
              Field("PRESENT", DATA_BITS, 1, "R", "streaming mode: 1 = the frame saw a "
                                                  "hand (centroid area > 0; 0 in the "
                                                  "thesis mode)"))),
    Register("reserved", 0x08, "R", "reads 0, writes ignored"),
    Register("Control", 0x0C, "RW", "capture control and status; bits [31:6] read 0", (
        Field("GO", 0, 1, "RW", "1 = capture runs: pairs are pushed and the gesture bit "
                                "follows the spotting flag"),
        Field("FIFO_DATA", 1, 1, "RO", "1 = both FIFOs hold at least one entry"),
        Field("NO_GESTURE", 2, 1, "RO", "1 = no valid gesture in progress (the thesis "
                                        "polarity: 0 while the spotting flag is set)"),
        Field("FIFO_CLR", 3, 1, "W1", "writing 1 empties both FIFOs and clears FIFO_FULL"),
        Field("FIFO_FULL", 4, 1, "RO", "sticky: a push found a FIFO full since the last "
                                       "FIFO_CLR (that pair was dropped)"),
        Field("STREAM", 5, 1, "RW", "1 = streaming mode: while GO every frame's record is "
                                    "pushed, with its FLAG and PRESENT bits, so that the "
                                    "HPS finds gesture boundaries itself; 0 = the thesis: "
                                    "only frames with the spotting flag set"),
    )),
    Register("Longitud_X", 0x10, "R", "entries in the X FIFO (0..FIFO_DEPTH)"),
    Register("Longitud_Y", 0x14, "R", "entries in the Y FIFO (0..FIFO_DEPTH)"),
    Register("ID", 0x18, "R", "identification: reads CORE_MAGIC (ASCII \"SGST\") when a "
             "stereogest core answers here; tells the core apart from a bridge that reads "
             "all ones or all zeros", (Field("magic", 0, 32, "R", "CORE_MAGIC"),)),
    Register("Version", 0x1C, "R", "the register interface's revision and the core's "
             "build parameters the application depends on", (
        Field("REVISION", 0, 8, "R", "CORE_REVISION: bumped when this map changes"),
        Field("FIFO_DEPTH_LOG2", 8, 5, "R", "log2 of the entries per FIFO, rounded down "
                                            "(the hardware's depths are powers of two)"),
        Field("STREAMING", 13, 1, "R", "1 = Control's STREAM bit is implemented"),
        Field("FRAME_WIDTH_DIV8", 16, 8, "R", "frame width in pixels / 8, rounded up: "
                                              "Dato_X's x lies below 8 times this"),
        Field("FRAME_HEIGHT_DIV8", 24, 8, "R", "frame height in pixels / 8, rounded up"),
    )),
))

#: The UART slave to the RN-42 Bluetooth module (thesis §8.5.1; the map is ours).
UART_REGISTERS = RegisterMap("uart", span=0x0C, registers=(
    Register("TXDATA", 0x00, "W", "byte to send (ignored while TX_READY is 0)",
             (Field("data", 0, 8, "W", "the byte"),)),
    Register("STATUS", 0x04, "R", "transmitter and receiver state", (
        Field("TX_READY", 0, 1, "R", "the transmit holding register can take a byte"),
        Field("RX_VALID", 1, 1, "R", "RXDATA holds a received byte"),
    )),
    Register("RXDATA", 0x08, "R", "pops the received byte",
             (Field("data", 0, 8, "R", "the byte"),)),
))

# ---- constants for the drivers (derived from the declarations) ------------------
DATO_X = FIFO_REGISTERS["Dato_X"].offset
DATO_Y = FIFO_REGISTERS["Dato_Y"].offset
RESERVED = FIFO_REGISTERS["reserved"].offset
CONTROL = FIFO_REGISTERS["Control"].offset
LONGITUD_X = FIFO_REGISTERS["Longitud_X"].offset
LONGITUD_Y = FIFO_REGISTERS["Longitud_Y"].offset
ID = FIFO_REGISTERS["ID"].offset
VERSION = FIFO_REGISTERS["Version"].offset
#: What the ID register reads: ASCII "SGST" (0x53 0x47 0x53 0x54).
CORE_MAGIC = 0x53475354
#: Revision of this register map (2: streaming mode, ID and Version registers).
CORE_REVISION = 2
#: Bytes the FIFO slave decodes (eight 32-bit words).
REGISTER_SPAN = FIFO_REGISTERS.span
CTRL_GO = FIFO_REGISTERS["Control"]["GO"].mask
CTRL_FIFO_DATA = FIFO_REGISTERS["Control"]["FIFO_DATA"].mask
CTRL_NO_GESTURE = FIFO_REGISTERS["Control"]["NO_GESTURE"].mask
CTRL_FIFO_CLR = FIFO_REGISTERS["Control"]["FIFO_CLR"].mask
CTRL_FIFO_FULL = FIFO_REGISTERS["Control"]["FIFO_FULL"].mask
CTRL_STREAM = FIFO_REGISTERS["Control"]["STREAM"].mask
#: Bits of Control that can read 1 (FIFO_CLR always reads 0).
CTRL_READABLE_MASK = CTRL_GO | CTRL_FIFO_DATA | CTRL_NO_GESTURE | CTRL_FIFO_FULL | CTRL_STREAM
#: The streaming mode's flag bits in Dato_X and Dato_Y.
DATO_X_FLAG = FIFO_REGISTERS["Dato_X"]["FLAG"].mask
DATO_Y_PRESENT = FIFO_REGISTERS["Dato_Y"]["PRESENT"].mask

UART_TXDATA = UART_REGISTERS["TXDATA"].offset
UART_STATUS = UART_REGISTERS["STATUS"].offset
UART_RXDATA = UART_REGISTERS["RXDATA"].offset
UART_SPAN = UART_REGISTERS.span
UART_STATUS_TX_READY = UART_REGISTERS["STATUS"]["TX_READY"].mask
UART_STATUS_RX_VALID = UART_REGISTERS["STATUS"]["RX_VALID"].mask

# ---- the posture descriptor ------------------------------------------------------
# The hand's shape, one record per frame (sim.model.posture defines what each
# count means; the hardware is hdl.posture_descriptor.PostureDescriptor).
#: Angular sectors of the polar occupancy about the anchor (a multiple of 8).
POSTURE_SECTORS = 32
#: Ring edges as 16ths of the squared hand width: radius 0.5, 0.75, 1, 1.25 widths.
POSTURE_RING_EDGES_16THS = (4, 9, 16, 25)
POSTURE_RINGS = len(POSTURE_RING_EDGES_16THS) + 1
#: Bands of the finger crossings above the anchor, each 3/16 of the hand width tall.
POSTURE_BANDS = 8
POSTURE_BAND_SPAN = (3, 16)
#: The record's 32-bit words in order: (name, words, meaning). Sums take two
#: words, low then high; ``a | b << 16`` packs two values below 2**16.
POSTURE_WORDS = (
    ("reference", 1, "the reference this frame is described about: x | top << 16"),
    ("reference_width", 1, "its hand width in pixels (0: no hand, polar and bands are 0)"),
    ("area", 1, "mask pixels"),
    ("sum_x", 2, "sum of their x"),
    ("sum_y", 2, "sum of their y"),
    ("sum_xx", 2, "sum of x * x"),
    ("sum_yy", 2, "sum of y * y"),
    ("sum_xy", 2, "sum of x * y"),
    ("box_x", 1, "bounding box: x_min | x_max << 16 (0 for an empty mask)"),
    ("box_y", 1, "y_min | y_max << 16"),
    ("band_sum", POSTURE_BANDS, "per band: the run starts of its rows"),
    ("band_rows_max", POSTURE_BANDS, "per band: rows | the largest row's run starts << 16"),
    ("polar", POSTURE_RINGS * POSTURE_SECTORS, "mask pixels per ring * SECTORS + sector"),
)
POSTURE_WORD_COUNT = sum(count for _, count, _ in POSTURE_WORDS)


def posture_word_offsets() -> dict:
    """The first word's index of each entry of :data:`POSTURE_WORDS`."""
    offsets, at = {}, 0
    for name, count, _ in POSTURE_WORDS:
        offsets[name] = at
        at += count
    return offsets


#: The posture slave (ours, §10.1): the latest frame's record, read a word at
#: a time. Two records are kept: the hardware writes one while the other is read.
POSTURE_REGISTERS = RegisterMap("posture", span=0x10, registers=(
    Register("Status", 0x00, "R", "records so far", (
        Field("SEQ", 0, 16, "R", "records completed since reset (wraps); a reader that "
                                 "sees it advance by 2 or more while it reads a record "
                                 "reads it again"),)),
    Register("Index", 0x04, "RW", "the next Data read's word; a write also chooses the "
             "record Data reads: the latest complete one", (
        Field("index", 0, 8, "RW", "word index, 0 .. POSTURE_WORD_COUNT - 1"),)),
    Register("Data", 0x08, "R", "the record's word at Index (POSTURE_WORDS), then Index "
             "+= 1; 0 past the last word"),
    Register("Layout", 0x0C, "R", "the record's layout, so that the reader checks it "
             "has the same", (
        Field("SECTORS", 0, 8, "R", "POSTURE_SECTORS"),
        Field("RINGS", 8, 4, "R", "POSTURE_RINGS"),
        Field("BANDS", 12, 4, "R", "POSTURE_BANDS"),
        Field("WORDS", 16, 12, "R", "POSTURE_WORD_COUNT"),
    )),
))
POSTURE_STATUS = POSTURE_REGISTERS["Status"].offset
POSTURE_INDEX = POSTURE_REGISTERS["Index"].offset
POSTURE_DATA = POSTURE_REGISTERS["Data"].offset
POSTURE_LAYOUT = POSTURE_REGISTERS["Layout"].offset
POSTURE_SPAN = POSTURE_REGISTERS.span
POSTURE_STATUS_SEQ = POSTURE_REGISTERS["Status"]["SEQ"].mask


def posture_layout_word() -> int:
    """What the posture slave's Layout register reads."""
    fields = POSTURE_REGISTERS["Layout"]
    values = {"SECTORS": POSTURE_SECTORS, "RINGS": POSTURE_RINGS, "BANDS": POSTURE_BANDS,
              "WORDS": POSTURE_WORD_COUNT}
    return sum(value << fields[name].bit for name, value in values.items())


# ---- the gesture classes --------------------------------------------------------
#: The seven gestures of thesis Fig. 16 in class order: the renderer's gestures,
#: the model files' classes and the NXT telegrams' digits (index + 1).
GESTURE_NAMES = ("forward", "back", "right", "left", "rotate-right", "rotate-left", "stop")


def version_word(*, fifo_depth: int = FIFO_DEPTH, streaming: bool = True,
                 frame_width: int = FRAME_WIDTH, frame_height: int = FRAME_HEIGHT,
                 revision: int = CORE_REVISION) -> int:
    """The Version register's value for a core built with these parameters.

    Parameters
    ----------
    fifo_depth : int in [1, 2**32 - 1]
        Entries per FIFO; recorded as log2 rounded down (a power of two, as in
        the hardware, is exact; the software model also takes other depths).
    streaming : bool
        Whether Control's STREAM bit is implemented.
    frame_width, frame_height : int in [1, 2040]
        Frame size in pixels; recorded in units of 8 pixels rounded up (exact
        for the board's 640 x 480), so that coordinates always lie below the
        decoded size.
    revision : int in [0, 255]
        Revision of the register map (:data:`CORE_REVISION`).

    Raises
    ------
    ValueError
        A value outside its range (the message names it).
    """
    fields = FIFO_REGISTERS["Version"]

    def limit(name):
        # the largest value the field holds, and the parameter that maps onto it
        return fields[name].mask >> fields[name].bit

    checks = (("fifo_depth", fifo_depth, 1, (1 << (limit("FIFO_DEPTH_LOG2") + 1)) - 1),
              ("frame_width", frame_width, 1, 8 * limit("FRAME_WIDTH_DIV8")),
              ("frame_height", frame_height, 1, 8 * limit("FRAME_HEIGHT_DIV8")),
              ("revision", revision, 0, limit("REVISION")))
    for name, value, low, high in checks:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ValueError(f"{name} must be an int in [{low}, {high}], got {value!r}")
    values = {"REVISION": revision, "FIFO_DEPTH_LOG2": fifo_depth.bit_length() - 1,
              "STREAMING": int(bool(streaming)), "FRAME_WIDTH_DIV8": -(-frame_width // 8),
              "FRAME_HEIGHT_DIV8": -(-frame_height // 8)}
    return sum(value << fields[name].bit for name, value in values.items())


def decode_version(word: int) -> dict:
    """The Version register's fields: ``revision``, ``fifo_depth``, ``streaming``,
    ``frame_width``, ``frame_height`` (the inverse of :func:`version_word` up to
    its rounding: a power of two of entries, multiples of 8 pixels)."""
    fields = FIFO_REGISTERS["Version"]

    def get(name):
        return (word & fields[name].mask) >> fields[name].bit
    return {"revision": get("REVISION"), "fifo_depth": 1 << get("FIFO_DEPTH_LOG2"),
            "streaming": bool(get("STREAMING")), "frame_width": get("FRAME_WIDTH_DIV8") * 8,
            "frame_height": get("FRAME_HEIGHT_DIV8") * 8}
