"""The Terasic DE1-SoC as the recogniser uses it: amaranth-boards'
``DE1SoCPlatform`` plus the VGA DAC, the two OV5642 cameras on the GPIO
headers, the RN-42 Bluetooth UART, the HPS DDR3 pins and the HPS peripheral
pins (``hps_io``).

Board functions (our Table 22; the thesis gives SW[9:7] and LEDR[4])
--------------------------------------------------------------------

======== =================================================================
KEY[0]   reset of the FPGA side (held: cameras in reset, core reset)
KEY[1]   press: power-cycle both cameras and rewrite their registers (I2C)
KEY[2]   held: camera capture paused
KEY[3]   unused
SW[0]    on: camera capture runs
SW[9:7]  VGA stage: 0 right camera, 1 left camera, 2 disparity, 3 skin
         mask, 4 disparity-band mask, 5 opening (hand); 6-7 select no stage
         (``hdl.gesture_pipeline.VIDEO_STAGES``)
LEDR[0]  left camera configured
LEDR[1]  right camera configured
LEDR[2]  camera configuration error
LEDR[3]  FIFO-FULL (the HPS application does not keep up)
LEDR[4]  gesture detected
LEDR[5]  GO (the HPS application runs)
LEDR[6]  stereo synchroniser fault seen since reset
LEDR[9:7] frames completed, bits 5:3 (a heartbeat)
======== =================================================================

Camera headers
--------------

Both cameras use the same header pins, the right camera on GPIO_0 (``ov5642``
number 0), the left on GPIO_1 (number 1). Header pin 29 is 3.3 V and pin 30
ground (pins 11 and 12 are 5 V and ground); the OV5642 module runs from 3.3 V.
D[9:2] is the camera's 8-bit output (D[1:0] unused). RESETB and PWDN are
driven by the camera's configuration master (its power-up sequence).

====== ===== ============ ====== ======
signal pin   GPIO index   GPIO_0 GPIO_1
====== ===== ============ ====== ======
PCLK   1     0            AC18   AB17
XCLK   2     1            Y17    AA21
VSYNC  3     2            AD17   AB21
HREF   4     3            Y18    AC23
D9     5     4            AK16   AD24
D8     6     5            AK18   AE23
D7     7     6            AK19   AE24
D6     8     7            AJ19   AF25
D5     9     8            AJ17   AF26
D4     10    9            AJ16   AG25
D3     13    10           AH18   AG26
D2     14    11           AH17   AH24
SCL    15    12           AG16   AH27
SDA    16    13           AE16   AJ27
RESETB 17    14           AF16   AK29
PWDN   18    15           AG17   AK28
====== ===== ============ ====== ======

The RN-42 UART shares GPIO_0: FPGA TX on pin 39 (GPIO_0[34], AG18) to the
module's RX, FPGA RX on pin 40 (GPIO_0[35], AJ21) from the module's TX.

The PCLK pins (header pin 1, AC18 and AB17) are ordinary I/O, not dedicated
clock inputs of the Cyclone V: the Quartus bundle promotes each PCLK onto a
global clock network (``GLOBAL_SIGNAL "GLOBAL CLOCK"``), and the fitter's
warning about a clock driven from a non-dedicated pin is expected.

Pin sources: the FPGA pins of the headers are amaranth-boards' connectors
(the DE1-SoC manual's GPIO table); VGA, HPS DDR3 and HPS peripheral pins and
I/O standards are those of the DE1-SoC manual and Terasic's golden-top pin
assignments.
"""
from __future__ import annotations

from amaranth.build import Attrs, Clock, Pins, Resource, Subsignal
from amaranth_boards.de1_soc import DE1SoCPlatform

__all__ = ["StereogestDE1SoCPlatform", "CAMERA_PINS", "CAMERA_HEADERS", "UART_PINS",
           "PCLK_MAX_FREQUENCY", "HPS_IO_PINS", "header_gpio_index"]

#: Header pin (1-40) of every camera signal; ``data`` lists D2 .. D9 (LSB first).
CAMERA_PINS = {
    "pclk": "1", "xclk": "2", "vsync": "3", "href": "4",
    "data": "14 13 10 9 8 7 6 5",
    "scl": "15", "sda": "16", "reset_n": "17", "pwdn": "18",
}
#: ``ov5642`` resource number -> (camera side, GPIO header number).
CAMERA_HEADERS = {0: ("right", 0), 1: ("left", 1)}
#: RN-42 UART on GPIO_0: FPGA transmit and receive header pins.
UART_PINS = {"tx": "39", "rx": "40"}
#: Clock constraint of the camera PCLK inputs (Hz). An upper bound: the OV5642
#: at 24 MHz XCLK and the 640x480 table clocks out well below it.
PCLK_MAX_FREQUENCY = 50e6

#: The HPS peripheral pins the board wires (dedicated HPS I/O, 3.3 V): the
#: ``hps_io`` role of the Platform Designer HPS (``hps_io_<role>``) -> (FPGA
#: ball, direction), for the peripherals of Terasic's DE1-SoC reference design:
#: EMAC1 RGMII to the KSZ9021 PHY, QSPI flash, SD card (4 bit), USB1 ULPI to the
#: USB3300, SPIM1 (LTC header), UART0 (USB-UART), I2C0 (accelerometer, audio
#: codec, video in), I2C1 (LTC header) and seven GPIOs (GPIO09 USB-UART
#: CONV_USB_N, 35 PHY interrupt, 40 LTC GPIO, 48 I2C control, 53 HPS_LED,
#: 54 HPS_KEY, 61 accelerometer interrupt).
HPS_IO_PINS = {
    "emac1_inst_TX_CLK": ("H19", "o"), "emac1_inst_TXD0": ("F20", "o"),
    "emac1_inst_TXD1": ("J19", "o"), "emac1_inst_TXD2": ("F21", "o"),
    "emac1_inst_TXD3": ("F19", "o"), "emac1_inst_RXD0": ("A21", "i"),
    "emac1_inst_MDIO": ("E21", "io"), "emac1_inst_MDC": ("B21", "o"),
    "emac1_inst_RX_CTL": ("K17", "i"), "emac1_inst_TX_CTL": ("A20", "o"),
    "emac1_inst_RX_CLK": ("G20", "i"), "emac1_inst_RXD1": ("B20", "i"),
    "emac1_inst_RXD2": ("B18", "i"), "emac1_inst_RXD3": ("D21", "i"),
    "qspi_inst_IO0": ("C20", "io"), "qspi_inst_IO1": ("H18", "io"),
    "qspi_inst_IO2": ("A19", "io"), "qspi_inst_IO3": ("E19", "io"),
    "qspi_inst_SS0": ("A18", "o"), "qspi_inst_CLK": ("D19", "o"),
    "sdio_inst_CMD": ("F18", "io"), "sdio_inst_D0": ("G18", "io"),
    "sdio_inst_D1": ("C17", "io"), "sdio_inst_CLK": ("A16", "o"),
    "sdio_inst_D2": ("D17", "io"), "sdio_inst_D3": ("B16", "io"),
    "usb1_inst_D0": ("E16", "io"), "usb1_inst_D1": ("G16", "io"),
    "usb1_inst_D2": ("D16", "io"), "usb1_inst_D3": ("D14", "io"),
    "usb1_inst_D4": ("A15", "io"), "usb1_inst_D5": ("C14", "io"),
    "usb1_inst_D6": ("D15", "io"), "usb1_inst_D7": ("M17", "io"),
    "usb1_inst_CLK": ("N16", "i"), "usb1_inst_STP": ("C15", "o"),
    "usb1_inst_DIR": ("E14", "i"), "usb1_inst_NXT": ("A14", "i"),
    "spim1_inst_CLK": ("C23", "o"), "spim1_inst_MOSI": ("D22", "o"),
    "spim1_inst_MISO": ("E24", "i"), "spim1_inst_SS0": ("D24", "o"),
    "uart0_inst_RX": ("B25", "i"), "uart0_inst_TX": ("C25", "o"),
    "i2c0_inst_SDA": ("C24", "io"), "i2c0_inst_SCL": ("E23", "io"),
    "i2c1_inst_SDA": ("A25", "io"), "i2c1_inst_SCL": ("H23", "io"),
    "gpio_inst_GPIO09": ("B15", "io"), "gpio_inst_GPIO35": ("C19", "io"),
    "gpio_inst_GPIO40": ("H17", "io"), "gpio_inst_GPIO48": ("B26", "io"),
    "gpio_inst_GPIO53": ("A24", "io"), "gpio_inst_GPIO54": ("G21", "io"),
    "gpio_inst_GPIO61": ("B22", "io"),
}

_LVTTL = Attrs(io_standard="3.3-V LVTTL")
# inputs that must not float: the open-drain I2C lines (a fallback for modules
# without their own pull-ups, too weak for 400 kHz: boards/README.md) and the
# idle-high UART input; a driven output gets none (it would do nothing)
_PULLED_UP = Attrs(io_standard="3.3-V LVTTL", weak_pull_up_resistor="ON")
_SSTL15 = Attrs(io_standard="SSTL-15 CLASS I")
_SSTL15_DIFF = Attrs(io_standard="DIFFERENTIAL 1.5-V SSTL CLASS I")


def header_gpio_index(pin: int) -> int:
    """GPIO index (``GPIO_n[index]``) of a 40-pin header pin.

    Pins 11/12 (5 V, GND) and 29/30 (3.3 V, GND) carry power.
    """
    if isinstance(pin, bool) or not isinstance(pin, int) or not 1 <= pin <= 40 \
            or pin in (11, 12, 29, 30):
        raise ValueError(f"pin must be a signal pin of the 40-pin header, got {pin!r}")
    return pin - 1 - 2 * (pin > 12) - 2 * (pin > 30)


def _camera(number: int) -> Resource:
    _, gpio = CAMERA_HEADERS[number]
    conn = ("gpio", gpio)
    p = CAMERA_PINS
    return Resource(
        "ov5642", number,
        Subsignal("pclk", Pins(p["pclk"], dir="i", conn=conn), Clock(PCLK_MAX_FREQUENCY)),
        Subsignal("xclk", Pins(p["xclk"], dir="o", conn=conn)),
        Subsignal("vsync", Pins(p["vsync"], dir="i", conn=conn)),
        Subsignal("href", Pins(p["href"], dir="i", conn=conn)),
        Subsignal("data", Pins(p["data"], dir="i", conn=conn)),
        Subsignal("scl", Pins(p["scl"], dir="io", conn=conn), _PULLED_UP),
        Subsignal("sda", Pins(p["sda"], dir="io", conn=conn), _PULLED_UP),
        Subsignal("reset_n", Pins(p["reset_n"], dir="o", conn=conn)),
        Subsignal("pwdn", Pins(p["pwdn"], dir="o", conn=conn)),
        _LVTTL,
    )


_VGA = Resource(
    "vga", 0,
    Subsignal("r", Pins("A13 C13 E13 B12 C12 D12 E12 F13", dir="o")),
    Subsignal("g", Pins("J9 J10 H12 G10 G11 G12 F11 E11", dir="o")),
    Subsignal("b", Pins("B13 G13 H13 F14 H14 F15 G15 J14", dir="o")),
    Subsignal("hs", Pins("B11", dir="o")),
    Subsignal("vs", Pins("D11", dir="o")),
    Subsignal("blank_n", Pins("F10", dir="o")),
    Subsignal("sync_n", Pins("C10", dir="o")),
    Subsignal("clk", Pins("A11", dir="o")),
    _LVTTL,
)

_HPS_DDR3 = Resource(
    "hps_ddr3", 0,
    Subsignal("a", Pins("F26 G30 F28 F30 J25 J27 F29 E28 H27 G26 D29 C30 B30 C29 H25",
                        dir="o"), _SSTL15),
    Subsignal("ba", Pins("E29 J24 J23", dir="o"), _SSTL15),
    Subsignal("ck_p", Pins("M23", dir="o"), _SSTL15_DIFF),
    Subsignal("ck_n", Pins("L23", dir="o"), _SSTL15_DIFF),
    Subsignal("cke", Pins("L29", dir="o"), _SSTL15),
    Subsignal("cs_n", Pins("H24", dir="o"), _SSTL15),
    Subsignal("ras_n", Pins("D30", dir="o"), _SSTL15),
    Subsignal("cas_n", Pins("E27", dir="o"), _SSTL15),
    Subsignal("we_n", Pins("C28", dir="o"), _SSTL15),
    Subsignal("reset_n", Pins("P30", dir="o"), _SSTL15),
    Subsignal("dq", Pins("K23 K22 H30 G28 L25 L24 J30 J29 K26 L26 K29 K27 M26 M27 L28 M30 "
                         "U26 T26 N29 N28 P26 P27 N27 R29 P24 P25 T29 T28 R27 R26 V30 W29",
                         dir="io"), _SSTL15),
    Subsignal("dqs_p", Pins("N18 N25 R19 R22", dir="io"), _SSTL15_DIFF),
    Subsignal("dqs_n", Pins("M19 N24 R18 R21", dir="io"), _SSTL15_DIFF),
    Subsignal("odt", Pins("H28", dir="o"), _SSTL15),
    Subsignal("dm", Pins("K28 M28 R28 W30", dir="o"), _SSTL15),
    Subsignal("rzq", Pins("D27", dir="i"), _SSTL15),
)


_HPS_IO = Resource(
    "hps_io", 0,
    *[Subsignal(role, Pins(pin, dir=direction)) for role, (pin, direction) in HPS_IO_PINS.items()],
    _LVTTL,
)


class StereogestDE1SoCPlatform(DE1SoCPlatform):
    """DE1-SoC with the recogniser's peripherals (see the module docstring).

    Resources added to ``DE1SoCPlatform``: ``vga`` 0 (r, g, b 8 bits, hs, vs,
    blank_n, sync_n, clk), ``ov5642`` 0 (right, GPIO_0) and 1 (left, GPIO_1)
    with pclk (clock-constrained), xclk, vsync, href, data (D[9:2]), scl, sda,
    reset_n, pwdn, ``uart`` 0 (tx, rx to the RN-42 on GPIO_0) and ``hps_ddr3``
    0 (the HPS SDRAM pins, for the Platform Designer system's memory conduit)
    and ``hps_io`` 0 (the HPS peripheral pins, :data:`HPS_IO_PINS`, for its
    ``hps_io`` conduit).
    The board's ``led``, ``button`` and ``switch`` resources are LEDR, KEY
    (inverted: 1 = pressed) and SW.
    """

    resources = [
        *DE1SoCPlatform.resources,
        _VGA,
        _camera(0), _camera(1),
        Resource("uart", 0,
                 Subsignal("rx", Pins(UART_PINS["rx"], dir="i", conn=("gpio", 0)), _PULLED_UP),
                 Subsignal("tx", Pins(UART_PINS["tx"], dir="o", conn=("gpio", 0))),
                 _LVTTL),
        _HPS_DDR3,
        _HPS_IO,
    ]
