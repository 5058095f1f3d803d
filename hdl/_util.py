"""Small helpers shared by the components of :mod:`hdl`: parameter checks (the
golden model's), bit widths, register delays. The stream convention every
component follows is described in :mod:`hdl`; the position counter of a stage is
:class:`hdl.raster_position.RasterPosition`."""
from __future__ import annotations

from amaranth.hdl import Signal

from sim.model.validation import check_int, check_odd_window

__all__ = ["check_int", "check_odd_window", "check_geometry", "check_domain", "delay", "replicate",
           "register_input", "times_constant",
           "KEEP_REGISTER", "NO_RW_COLLISION", "registered_read",
           "bits_for", "WIDTH_RANGE", "HEIGHT_RANGE", "PIXEL_BITS_RANGE"]

WIDTH_RANGE = (8, 4096)
HEIGHT_RANGE = (2, 4096)
PIXEL_BITS_RANGE = (1, 16)


def bits_for(value: int) -> int:
    """Bits of an unsigned number that holds 0 .. value."""
    return max(1, int(value).bit_length())


def check_geometry(width, height, min_width: int = WIDTH_RANGE[0]):
    """Validate the frame size; ``min_width`` raises the lower bound of the width."""
    lo = max(WIDTH_RANGE[0], min_width)
    width = check_int("width", width, lo, WIDTH_RANGE[1])
    height = check_int("height", height, *HEIGHT_RANGE)
    return width, height


def check_domain(name: str, value) -> str:
    """Validate a clock domain name (a non-empty string)."""
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} must be a non-empty clock domain name, got {value!r}")
    return value


def delay(m, value, cycles: int, name: str = "dly", *, reset_less: bool = False):
    """``value`` delayed by ``cycles`` free-running registers (0 = the value itself);
    ``reset_less`` for data that a delayed valid qualifies."""
    out = value
    for i in range(cycles):
        reg = Signal(out.shape(), name=f"{name}_{i}", reset_less=reset_less)
        m.d.sync += reg.eq(out)
        out = reg
    return out


#: Attributes of a register that synthesis must not merge with its equals:
#: yosys' ``keep`` (hdl.place_route carries it from the wire to the flip-flop),
#: Quartus' ``preserve``.
KEEP_REGISTER = {"keep": 1, "preserve": 1}

#: Attributes of a memory whose read port never reads a word in the cycle the
#: write port writes it (or discards such a read): yosys' ``no_rw_check``. With
#: it, and the read made by :func:`registered_read`, yosys builds no collision
#: bypass behind the block.
NO_RW_COLLISION = {"no_rw_check": 1}


def registered_read(m, memory, addr, name: str, *, en=None):
    """The word of ``memory`` at ``addr`` in a register (loaded when ``en``, or
    every cycle): the block RAM's own read register, so the word is there one
    cycle after ``addr``, as from a synchronous read port.

    The read port is combinational and the register follows it: yosys merges the
    two into the block's synchronous read, and with :data:`NO_RW_COLLISION` on
    the memory it keeps no read-old-data semantics for a collision with the
    write port. An Amaranth synchronous read port declares those semantics, and
    yosys builds them on the ECP5 as a multiplexer (a LUT and two registers)
    behind the block, whatever the attribute: logic between the block and the
    register after it (routed, a block's output through that LUT was the limit
    of the whole pipeline)."""
    port = memory.read_port(domain="comb")
    m.d.comb += port.addr.eq(addr)
    word = Signal(port.data.shape(), name=name, reset_less=True)
    with m.If(1 if en is None else en):
        m.d.sync += word.eq(port.data)
    return word


def replicate(m, value, copies: int, name: str = "rep", init: int = 0, *,
              reset_less: bool = False):
    """``copies`` registers, each ``value`` one cycle late, kept apart in
    synthesis (:data:`KEEP_REGISTER`): a flag that steers hundreds of registers
    drives each share from its own copy, a short net instead of one that spans
    the block (routed on an ECP5: 8.5 ns of routing for one such net), and an
    operand that feeds several multipliers reaches each from a register next
    to it (``reset_less`` for data)."""
    regs = []
    for i in range(copies):
        reg = Signal(value.shape(), name=f"{name}_{i}", init=init, attrs=KEEP_REGISTER,
                     reset_less=reset_less)
        m.d.sync += reg.eq(value)
        regs.append(reg)
    return regs


def times_constant(value, factor: int):
    """``value * factor`` for a constant ``factor`` >= 0, as a sum of shifted
    copies of ``value``: synthesis maps a product by a constant to a DSP block,
    whose routing in and out (routed on an ECP5: 3.6 + 3.1 + 3.4 ns) cost more
    than a cycle; two or three shifted terms are one carry chain each."""
    if factor < 0:
        raise ValueError(f"factor must be >= 0, got {factor}")
    terms = [value << i for i in range(factor.bit_length()) if factor >> i & 1]
    total = terms[0] if terms else value * 0
    for term in terms[1:]:
        total = total + term
    return total


def register_input(m, i_stream, copies: int, name: str):
    """An input register of an always-ready stream: its payload, registered as
    ``name``, and ``copies`` registered copies of its ``valid``
    (:func:`replicate`, named ``beat_<n>``), the beats of that registered
    payload. A stage whose beat steers many registers gives each group its
    own copy. Returns ``(payload, beats)``."""
    payload = Signal(i_stream.payload.shape(), name=name)
    m.d.sync += payload.eq(i_stream.payload)
    return payload, replicate(m, i_stream.valid, copies, "beat")
