"""soc/hps_interface.py: the one declaration of what the FPGA side and the HPS
application share, and everyone taking it from there."""
from __future__ import annotations

import pytest

from soc import hps_interface as hi
from soc.hps_interface import FIFO_REGISTERS, UART_REGISTERS, Field, Register, RegisterMap


def test_fifo_map_is_thesis_table_12_and_13():
    assert [(r.name, r.offset) for r in FIFO_REGISTERS] == [
        ("Dato_X", 0x00), ("Dato_Y", 0x04), ("reserved", 0x08), ("Control", 0x0C),
        ("Longitud_X", 0x10), ("Longitud_Y", 0x14)]
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
