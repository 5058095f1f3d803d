"""soc/hps_interface.py: the one declaration of what the FPGA side and the HPS
application share, and everyone taking it from there."""
from __future__ import annotations

import pytest

from soc import hps_interface as hi
from soc.hps_interface import FIFO_REGISTERS, UART_REGISTERS, Field, Register, RegisterMap


def test_fifo_map_is_thesis_table_12_and_13():
    assert [(r.name, r.offset) for r in FIFO_REGISTERS] == [
        ("Dato_X", 0x00), ("Dato_Y", 0x04), ("reserved", 0x08), ("Control", 0x0C),
        ("Longitud_X", 0x10), ("Longitud_Y", 0x14), ("ID", 0x18), ("Version", 0x1C)]
    assert (hi.ID, hi.VERSION, hi.REGISTER_SPAN) == (0x18, 0x1C, 0x20)
    control = FIFO_REGISTERS["Control"]
    # the thesis' five bits, then ours: the streaming mode (issue 28)
    assert [(f.name, f.bit) for f in control.fields] == [
        ("GO", 0), ("FIFO_DATA", 1), ("NO_GESTURE", 2), ("FIFO_CLR", 3), ("FIFO_FULL", 4),
        ("STREAM", 5)]
    assert (hi.CTRL_GO, hi.CTRL_FIFO_CLR, hi.CTRL_FIFO_FULL, hi.CTRL_STREAM) == (1, 8, 16, 32)
    assert hi.CTRL_READABLE_MASK == 0b110111              # FIFO_CLR reads 0
    assert FIFO_REGISTERS["Dato_X"]["data"].mask == hi.DATA_MASK == (1 << 18) - 1
    assert hi.DATO_X_FLAG == hi.DATO_Y_PRESENT == 1 << 18
    assert FIFO_REGISTERS.address_width == 3 and UART_REGISTERS.address_width == 2


def test_id_and_version_words():
    """ID spells "SGST"; Version packs the build parameters into the declared
    fields (checked bit by bit against a hand-packed word)."""
    assert hi.CORE_MAGIC.to_bytes(4, "big") == b"SGST"
    version = FIFO_REGISTERS["Version"]
    assert [(f.name, f.bit, f.width) for f in version.fields] == [
        ("REVISION", 0, 8), ("FIFO_DEPTH_LOG2", 8, 5), ("STREAMING", 13, 1),
        ("FRAME_WIDTH_DIV8", 16, 8), ("FRAME_HEIGHT_DIV8", 24, 8)]
    # the board: revision 2, 512 = 2**9 entries, streaming, 640 / 8 = 80, 480 / 8 = 60
    assert hi.version_word() == hi.CORE_REVISION | 9 << 8 | 1 << 13 | 80 << 16 | 60 << 24
    assert hi.version_word(fifo_depth=8, streaming=False, frame_width=32, frame_height=16,
                           revision=7) == 7 | 3 << 8 | 4 << 16 | 2 << 24


@pytest.mark.parametrize("params", [
    dict(),
    dict(fifo_depth=2, streaming=False, frame_width=8, frame_height=8, revision=0),
    dict(fifo_depth=1 << 31, frame_width=2040, frame_height=2040, revision=255),
    dict(fifo_depth=65536, frame_width=1024, frame_height=768, revision=1),
])
def test_version_round_trip(params):
    word = hi.version_word(**params)
    assert 0 <= word < 1 << 32
    full = dict(fifo_depth=hi.FIFO_DEPTH, streaming=True, frame_width=hi.FRAME_WIDTH,
                frame_height=hi.FRAME_HEIGHT, revision=hi.CORE_REVISION)
    full.update(params)
    assert hi.decode_version(word) == full
    assert hi.version_word(**full) == word


def test_version_rounding():
    """Depths that are not powers of two (the software model's) round down,
    frame sizes that are not multiples of 8 round up: coordinates stay below."""
    decoded = hi.decode_version(hi.version_word(fifo_depth=20, frame_width=98,
                                                frame_height=61))
    assert (decoded["fifo_depth"], decoded["frame_width"], decoded["frame_height"]) == \
        (16, 104, 64)
    assert hi.decode_version(hi.version_word(fifo_depth=1))["fifo_depth"] == 1


@pytest.mark.parametrize("params, message", [
    (dict(fifo_depth=0), r"^fifo_depth must be an int in \[1, 4294967295\], got 0$"),
    (dict(fifo_depth=1 << 32), r"^fifo_depth must be an int in \[1, 4294967295\]"),
    (dict(fifo_depth=512.0), r"^fifo_depth must be an int"),
    (dict(frame_width=0), r"^frame_width must be an int in \[1, 2040\], got 0$"),
    (dict(frame_width=2041), r"^frame_width must be an int in \[1, 2040\]"),
    (dict(frame_height=True), r"^frame_height must be an int in \[1, 2040\], got True$"),
    (dict(frame_height=2048), r"^frame_height must be"),
    (dict(revision=-1), r"^revision must be an int in \[0, 255\], got -1$"),
    (dict(revision=256), r"^revision must be"),
])
def test_version_word_range_errors(params, message):
    with pytest.raises(ValueError, match=message):
        hi.version_word(**params)


def test_uart_map():
    assert (hi.UART_TXDATA, hi.UART_STATUS, hi.UART_RXDATA, hi.UART_SPAN) == (0, 4, 8, 12)
    assert (hi.UART_STATUS_TX_READY, hi.UART_STATUS_RX_VALID) == (1, 2)


def test_table_lists_every_register_and_field():
    text = FIFO_REGISTERS.table()
    for r in FIFO_REGISTERS:
        assert [f"{r.offset:#04x}", r.name, r.access] in [line.split()[:3]
                                                           for line in text.splitlines()]
        for f in r.fields:
            assert f" {f.name} ({f.access})" in text
    assert text.splitlines()[0] == text.splitlines()[2] == text.splitlines()[-1]


@pytest.mark.parametrize("build, message", [
    (lambda: Field("x", 30, 4, "R", ""), "bits"),
    (lambda: Field("x", 0, 1, "RWX", ""), "access"),
    (lambda: Register("r", 2, "R", ""), "multiple of 4"),
    (lambda: Register("r", 0, "R", "", (Field("a", 0, 2, "R", ""), Field("b", 1, 1, "R", ""))),
     "overlaps"),
    (lambda: RegisterMap("m", 8, (Register("a", 0, "R", ""), Register("b", 0, "R", ""))),
     "offsets"),
    (lambda: RegisterMap("m", 8, (Register("a", 8, "R", ""),)), "span"),
])
def test_declarations_are_checked(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def test_everyone_takes_the_facts_from_here():
    """The driver, the hardware, the app's defaults, the bundle generator and the
    renderer hold the same objects, not copies."""
    import sim.gesture_shapes
    import soc.core
    import soc.fifo_slave
    import soc.uart
    import sw_hps.bus
    import sw_hps.fifo
    import sw_hps.robot
    import sw_hps.telegram
    from sw_hps.__main__ import build_parser
    assert sim.gesture_shapes.GESTURE_NAMES is sw_hps.telegram.GESTURE_NAMES is hi.GESTURE_NAMES
    assert sw_hps.fifo.CONTROL == hi.CONTROL and sw_hps.robot.UART_STATUS == hi.UART_STATUS
    assert soc.fifo_slave.ADDRESS_WIDTH == FIFO_REGISTERS.address_width
    assert soc.uart.ADDRESS_WIDTH == UART_REGISTERS.address_width
    assert (soc.core.FIFO_BASE, soc.core.UART_BASE) == (hi.SLAVE_BASES["fifo"],
                                                        hi.SLAVE_BASES["uart"])
    assert sw_hps.bus.DevMemBus.__init__.__defaults__[0] == hi.LIGHTWEIGHT_BRIDGE_BASE
    args = build_parser().parse_args(["--model", "m.json", "--bus", "sim", "--robot", "none"])
    assert args.bridge_offset == hi.FIFO_BASE
    assert args.uart_offset == hi.UART_BASE - hi.FIFO_BASE
