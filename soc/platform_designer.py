"""Platform Designer (Qsys) pieces that attach the core to the HPS: the
``_hw.tcl`` component of the core and the qsys-script that builds the HPS
system ``soc_system``.

Everything is derived from the core's ports (:func:`soc.core.core_ports`, taken
from its signature; a test checks them against the emitted Verilog with
:func:`verilog_ports`, which also reads the board top's ports), so the
component's ports are the core's ports by construction:

* ``clk`` is the component's clock sink, ``rst`` its reset sink (synchronous,
  active high);
* each group ``NAME__ROLE`` whose roles are exactly ``address``, ``read``,
  ``write``, ``writedata``, ``readdata`` is an Avalon-MM slave ``NAME`` (word
  addresses, fixed read latency 1, no wait states, see :mod:`soc.avalon`);
* every other group ``NAME__ROLE`` is a conduit ``NAME``, and the ports without
  ``__`` form the conduit ``board``. The system exports each conduit as
  ``core_NAME``, so Platform Designer names its port ``core_NAME_ROLE``
  (:func:`exported_port_name`), the name the board top connects.

The system (``soc_system``): a clock source fed by the board top's pipeline
clock (:data:`soc.clocks.SYNC_HZ`), the HPS configured as Terasic's DE1-SoC
reference design (SD card, Ethernet, USB, UART, QSPI, SPI, I2C, GPIO on its
dedicated pins, exported as ``hps_io``; the DE1-SoC's 1 GB DDR3 exported as
``memory``; its FPGA reset exported as ``h2f_reset``) with only the
lightweight HPS-to-FPGA bridge, and the core with its slaves on that bridge
(``0xFF200000 + base`` for the HPS).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from boards.de1_soc import HPS_IO_PINS

from .clocks import SYNC_HZ
from .hps_interface import LIGHTWEIGHT_BRIDGE_BASE, SLAVE_WINDOW

__all__ = ["verilog_ports", "CoreInterface", "core_interfaces", "exported_port_name",
           "soc_system_ports", "hw_tcl", "system_tcl", "HPS_MEMORY_PORTS", "SYSTEM_NAME",
           "CORE_INSTANCE", "QSYS_VERSION", "DEVICE", "HPS_DDR3_PARAMETERS", "conduit_map",
           "HPS_PERIPHERAL_PARAMETERS", "HPS_IO_PORTS", "H2F_RESET_PORT", "HPS_GPIOS",
           "SYSTEM_RESET_EDGES"]

#: Name of the Platform Designer system (and of its Verilog module).
SYSTEM_NAME = "soc_system"
#: Instance name of the core inside the system.
CORE_INSTANCE = "stereogest_core_0"
#: qsys Tcl API version the scripts ask for (Quartus 16.1 and later provide it).
QSYS_VERSION = "16.1"
#: The DE1-SoC's FPGA.
DEVICE = "5CSEMA5F31C6"
#: What the clock source ``clk_0`` declares of the system's exported reset: its
#: source is the board top's asynchronous OR of KEY[0], the PLL's lock and the
#: HPS's ``h2f_reset`` (:class:`soc.board_top.BoardTop`), in step with no clock,
#: so ``NONE``, and Platform Designer synchronises it for every sink that needs
#: synchronous edges (the core's reset declares ``BOTH``), as Terasic's DE1-SoC
#: reference designs do.
SYSTEM_RESET_EDGES = "NONE"
#: Prefix of the system's exports of the core's conduits.
EXPORT_PREFIX = "core_"
#: Conduit of the core ports without a ``__`` group.
BOARD_CONDUIT = "board"
AVALON_ROLES = {"address": "input", "read": "input", "write": "input",
                "writedata": "input", "readdata": "output"}

#: Ports of the HPS ``memory`` conduit as the system exports it (DE1-SoC: 32-bit
#: DDR3, 15 row-address bits, 3 bank bits): (name, direction, width).
HPS_MEMORY_PORTS = (
    ("memory_mem_a", "output", 15), ("memory_mem_ba", "output", 3),
    ("memory_mem_ck", "output", 1), ("memory_mem_ck_n", "output", 1),
    ("memory_mem_cke", "output", 1), ("memory_mem_cs_n", "output", 1),
    ("memory_mem_ras_n", "output", 1), ("memory_mem_cas_n", "output", 1),
    ("memory_mem_we_n", "output", 1), ("memory_mem_reset_n", "output", 1),
    ("memory_mem_dq", "inout", 32), ("memory_mem_dqs", "inout", 4),
    ("memory_mem_dqs_n", "inout", 4), ("memory_mem_odt", "output", 1),
    ("memory_mem_dm", "output", 4), ("memory_oct_rzqin", "input", 1),
)

#: HPS SDRAM controller settings for the DE1-SoC's two 4 Gb x16 DDR3 chips
#: (1 GB, 32 bits) at 400 MHz: the values of the ``hps_0`` of Terasic's DE1-SoC
#: reference designs (``soc_system.qsys`` of the DE1-SoC system CD).
HPS_DDR3_PARAMETERS = {
    "HPS_PROTOCOL": "DDR3", "MEM_VOLTAGE": "1.5V DDR3", "RATE": "Full",
    "MEM_CLK_FREQ": "400.0", "REF_CLK_FREQ": "25.0", "MEM_CLK_FREQ_MAX": "800.0",
    "MEM_VENDOR": "JEDEC", "MEM_FORMAT": "DISCRETE", "DISCRETE_FLY_BY": "1",
    "MEM_DQ_WIDTH": "32", "MEM_DQ_PER_DQS": "8", "MEM_ROW_ADDR_WIDTH": "15",
    "MEM_COL_ADDR_WIDTH": "10", "MEM_BANKADDR_WIDTH": "3", "MEM_IF_DM_PINS_EN": "1",
    "MEM_IF_DQSN_EN": "1", "MEM_CK_WIDTH": "1", "MEM_CS_WIDTH": "1", "MEM_CLK_EN_WIDTH": "1",
    "MEM_BL": "OTF", "MEM_BT": "Sequential", "MEM_ASR": "Manual", "MEM_SRT": "Normal",
    "MEM_PD": "DLL off", "MEM_DRV_STR": "RZQ/7", "MEM_DLL_EN": "1",
    "MEM_RTT_NOM": "RZQ/4", "MEM_RTT_WR": "RZQ/4", "MEM_WTCL": "8", "MEM_ATCL": "Disabled",
    "MEM_TCL": "11", "MEM_AUTO_LEVELING_MODE": "1", "MEM_USER_LEVELING_MODE": "Leveling",
    "TIMING_TIS": "180", "TIMING_TIH": "140", "TIMING_TDS": "30", "TIMING_TDH": "65",
    "TIMING_TDQSQ": "125", "TIMING_TQHS": "300", "TIMING_TQH": "0.38",
    "TIMING_TDQSCK": "255", "TIMING_TDQSCKDS": "450", "TIMING_TDQSCKDM": "900",
    "TIMING_TDQSCKDL": "1200", "TIMING_TDQSS": "0.25", "TIMING_TDQSH": "0.35",
    "TIMING_TQSH": "0.4", "TIMING_TDSH": "0.2", "TIMING_TDSS": "0.2",
    "MEM_TINIT_US": "500", "MEM_TMRD_CK": "4", "MEM_TRAS_NS": "35.0",
    "MEM_TRCD_NS": "13.75", "MEM_TRP_NS": "13.75", "MEM_TREFI_US": "7.8",
    "MEM_TRFC_NS": "260.0", "MEM_TWR_NS": "15.0", "MEM_TWTR": "4", "MEM_TFAW_NS": "30.0",
    "MEM_TRRD_NS": "7.5", "MEM_TRTP_NS": "7.5", "CFG_TCCD_NS": "2.5",
    "TIMING_BOARD_MAX_CK_DELAY": "0.03", "TIMING_BOARD_MAX_DQS_DELAY": "0.02",
    "TIMING_BOARD_SKEW_CKDQS_DIMM_MIN": "0.09", "TIMING_BOARD_SKEW_CKDQS_DIMM_MAX": "0.16",
    "TIMING_BOARD_SKEW_BETWEEN_DIMMS": "0.05", "TIMING_BOARD_SKEW_WITHIN_DQS": "0.01",
    "TIMING_BOARD_SKEW_BETWEEN_DQS": "0.08", "TIMING_BOARD_DQ_TO_DQS_SKEW": "0.0",
    "TIMING_BOARD_AC_SKEW": "0.03", "TIMING_BOARD_AC_TO_CK_SKEW": "0.0",
}

#: HPS-FPGA interfaces: the lightweight bridge and the HPS-to-FPGA reset
#: (``h2f_reset``, always present) only.
HPS_BRIDGE_PARAMETERS = {
    "F2S_Width": "0",            # FPGA-to-HPS bridge off
    "S2F_Width": "0",            # HPS-to-FPGA bridge off
    "LWH2F_Enable": "true",      # lightweight HPS-to-FPGA bridge on
    "F2SDRAM_Type": "", "F2SDRAM_Width": "",   # no FPGA-to-SDRAM ports
    "F2SINTERRUPT_Enable": "0", "MPU_EVENTS_Enable": "0", "GP_Enable": "0",
    "BOOTFROMFPGA_Enable": "0",
    "S2FCLK_USER0CLK_Enable": "0", "S2FCLK_USER1CLK_Enable": "0",
    "S2FCLK_USER2CLK_Enable": "0",
}

#: HPS GPIO lines the DE1-SoC wires (``GPIO_Enable``, 100 entries): the
#: ``gpio_inst_GPIOnn`` roles of :data:`boards.de1_soc.HPS_IO_PINS`.
HPS_GPIOS = tuple(int(role[len("gpio_inst_GPIO"):]) for role in HPS_IO_PINS
                  if role.startswith("gpio_inst_GPIO"))

#: HPS peripherals on their dedicated pins as in Terasic's DE1-SoC reference
#: designs (the preloader built from the handoff sets their pin multiplexing):
#: SD card, Ethernet, USB, console UART, QSPI flash, SPI, two I2C, GPIO; the
#: rest unused. Pins in :data:`boards.de1_soc.HPS_IO_PINS`.
HPS_PERIPHERAL_PARAMETERS = {
    **{f"{peripheral}_{key}": value
       for peripheral in ("EMAC0", "NAND", "USB0", "SPIM0", "SPIS0", "SPIS1", "UART1",
                          "I2C2", "I2C3", "CAN0", "CAN1", "TRACE")
       for key, value in (("PinMuxing", "Unused"), ("Mode", "N/A"))},
    "SDIO_PinMuxing": "HPS I/O Set 0", "SDIO_Mode": "4-bit Data",
    "EMAC1_PinMuxing": "HPS I/O Set 0", "EMAC1_Mode": "RGMII",
    "USB1_PinMuxing": "HPS I/O Set 0", "USB1_Mode": "SDR",
    "UART0_PinMuxing": "HPS I/O Set 0", "UART0_Mode": "No Flow Control",
    "QSPI_PinMuxing": "HPS I/O Set 0", "QSPI_Mode": "1 SS",
    "SPIM1_PinMuxing": "HPS I/O Set 0", "SPIM1_Mode": "Single Slave Select",
    "I2C0_PinMuxing": "HPS I/O Set 0", "I2C0_Mode": "I2C",
    "I2C1_PinMuxing": "HPS I/O Set 0", "I2C1_Mode": "I2C",
    "GPIO_Enable": " ".join("Yes" if i in HPS_GPIOS else "No" for i in range(100)),
    # the board's 25 MHz HPS oscillator (HPS_CLOCK_25)
    "eosc1_clk_mhz": "25.0", "eosc2_clk_mhz": "25.0",
}

#: Exported HPS interfaces besides ``memory``: its peripheral pins and its
#: reset to the FPGA (asserted while the HPS boots or resets the FPGA side).
HPS_IO_EXPORT = "hps_io"
H2F_RESET_EXPORT = "h2f_reset"
_PIN_DIRECTIONS = {"i": "input", "o": "output", "io": "inout"}
#: ``soc_system`` ports of the ``hps_io`` export: (name, direction, width).
HPS_IO_PORTS = tuple((f"{HPS_IO_EXPORT}_hps_io_{role}", _PIN_DIRECTIONS[direction], 1)
                     for role, (_, direction) in HPS_IO_PINS.items())
#: The ``soc_system`` port of ``h2f_reset`` (active low).
H2F_RESET_PORT = (f"{H2F_RESET_EXPORT}_reset_n", "output", 1)


# ---- Verilog ports ------------------------------------------------------------------

_DIRECTIONS = ("input", "output", "inout")
_IDENT = r"(?:\\\S+|[A-Za-z_][A-Za-z0-9_$]*)"
_RANGE = re.compile(r"\[\s*(-?\d+)\s*:\s*(-?\d+)\s*\]")


def _strip(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    return re.sub(r"\(\*.*?\*\)", " ", text, flags=re.S)


def _ident(name: str) -> str:
    return name[1:] if name.startswith("\\") else name


_DECL = re.compile(
    r"\b(input|output|inout)\b(?:\s+(?:wire|reg|logic|signed|unsigned|tri)\b)*\s*"
    r"(\[[^\]]*\])?\s*(" + _IDENT + r"(?:\s*,\s*" + _IDENT + r")*)\s*;")
_ANSI = re.compile(
    r"\s*(?:(input|output|inout)\b(?:\s+(?:wire|reg|logic|signed|unsigned|tri)\b)*)?\s*"
    r"(\[[^\]]*\])?\s*(" + _IDENT + r")\s*")


def _body_declarations(body: str) -> dict:
    """Port name -> (direction, width) of the ``input|output|inout ...;``
    declarations of a module body."""
    decl = {}
    for match in _DECL.finditer(body):
        direction, rng, names = match.groups()
        for name in names.split(","):
            decl[_ident(name.strip())] = (direction, _width(rng))
    return decl


def _ansi_ports(header: str, module: str) -> list:
    """Ports of an ANSI port list (a port without a direction takes the
    previous one's direction and range)."""
    ports, direction, rng = [], None, None
    for item in header.split(","):
        match = _ANSI.fullmatch(item)
        if not match:
            raise ValueError(f"module {module!r}: cannot read port declaration {item.strip()!r}")
        if match[1]:
            direction, rng = match[1], match[2]
        elif match[2]:
            rng = match[2]
        if direction is None:
            raise ValueError(f"module {module!r}: port {match[3]!r} has no direction")
        ports.append((_ident(match[3]), direction, _width(rng)))
    return ports


def _width(rng) -> int:
    if not rng:
        return 1
    match = _RANGE.fullmatch(rng.strip())
    if not match:
        raise ValueError(f"port range {rng!r} is not a constant [msb:lsb]")
    msb, lsb = int(match[1]), int(match[2])
    return abs(msb - lsb) + 1


def verilog_ports(text: str, module: str) -> list[tuple[str, str, int]]:
    """Ports of one Verilog module, in the order of its port list.

    Parameters
    ----------
    text : str
        Verilog source (comments and attributes are ignored). Both port styles
        are read: declarations in the body (Verilog-1995, as Amaranth and
        Yosys write) and declarations in the port list (ANSI).
    module : str
        Module name.

    Returns
    -------
    list of (name, direction, width)
        ``direction`` is ``"input"``, ``"output"`` or ``"inout"``; ``width``
        in bits (constant ``[msb:lsb]`` ranges only).

    Raises
    ------
    ValueError
        If the module is not found (or found twice), or a port of its list
        has no direction declaration.
    """
    src = _strip(text)
    heads = list(re.finditer(r"\bmodule\s+(" + _IDENT + r")\s*", src))
    found = [h for h in heads if _ident(h[1]) == module]
    if len(found) != 1:
        raise ValueError(f"module {module!r} found {len(found)} times in the Verilog text")
    pos = found[0].end()
    if src.startswith("#", pos):            # parameter list: skip its parentheses
        pos = _skip_parens(src, src.index("(", pos))
        pos = len(src) - len(src[pos:].lstrip())
    if not src.startswith("(", pos):
        raise ValueError(f"module {module!r} has no port list")
    end = _skip_parens(src, pos)
    header = src[pos + 1:end - 1]
    body_end = src.find("endmodule", end)
    body = src[end:body_end if body_end >= 0 else len(src)]
    if not header.strip():
        return []
    if re.search(r"\b(input|output|inout)\b", header):       # ANSI
        return _ansi_ports(header, module)
    order = [_ident(n.strip()) for n in header.split(",")]
    decl = _body_declarations(body)
    missing = [n for n in order if n not in decl]
    if missing:
        raise ValueError(f"module {module!r}: no direction declared for port(s) {missing}")
    return [(name, *decl[name]) for name in order]


def _skip_parens(text: str, start: int) -> int:
    """Index just past the parenthesis that closes the one at ``start``."""
    depth = 0
    for i in range(start, len(text)):
        if text[i] == "(":
            depth += 1
        elif text[i] == ")":
            depth -= 1
            if depth == 0:
                return i + 1
    raise ValueError("unbalanced parentheses in the Verilog text")


# ---- the core's interfaces ----------------------------------------------------------

@dataclass(frozen=True)
class CoreInterface:
    """One Platform Designer interface of the core.

    Attributes
    ----------
    name : str
        Interface name in the ``_hw.tcl``.
    kind : str
        ``"clock"``, ``"reset"``, ``"avalon"`` or ``"conduit"``.
    ports : tuple of (port, role, direction, width)
        Verilog port name, signal role, ``input``/``output``/``inout``, bits.
    """

    name: str
    kind: str
    ports: tuple


def core_interfaces(ports) -> list[CoreInterface]:
    """Group the core's Verilog ports into Platform Designer interfaces.

    Parameters
    ----------
    ports : list of (name, direction, width)
        As :func:`soc.core.core_ports` (or :func:`verilog_ports`) returns them.

    Returns
    -------
    list of CoreInterface
        Clock, reset, then the Avalon slaves and the conduits in order of
        first appearance.

    Raises
    ------
    ValueError
        If ``clk``/``rst`` are missing or not 1-bit inputs, an Avalon slave's
        signals have the wrong direction or data width, a port name repeats,
        or two ports of one conduit would get the same role.
    """
    ports = [(str(n), str(d), int(w)) for n, d, w in ports]
    names = [p[0] for p in ports]
    if len(set(names)) != len(names):
        raise ValueError("core ports repeat a name")
    by_name = {p[0]: p for p in ports}
    for special in ("clk", "rst"):
        if by_name.get(special, (None, None, None))[1:] != ("input", 1):
            raise ValueError(f"the core needs a 1-bit input port {special!r}")
    groups: dict[str, list] = {}
    for name, direction, width in ports:
        if name in ("clk", "rst"):
            continue
        if "__" in name:
            group, role = name.split("__", 1)
            role = role.replace("__", "_")
        else:
            group, role = BOARD_CONDUIT, name
        if not group or not role:
            raise ValueError(f"core port {name!r}: empty group or role")
        groups.setdefault(group, []).append((name, role, direction, width))
    result = [CoreInterface("clock", "clock", (("clk", "clk", "input", 1),)),
              CoreInterface("reset", "reset", (("rst", "reset", "input", 1),))]
    for group, members in groups.items():
        roles = [m[1] for m in members]
        if len(set(roles)) != len(roles):
            raise ValueError(f"conduit {group!r}: two ports map to one role")
        if set(roles) == set(AVALON_ROLES):
            for name, role, direction, width in members:
                if direction != AVALON_ROLES[role]:
                    raise ValueError(f"Avalon slave {group!r}: {name} must be an "
                                     f"{AVALON_ROLES[role]}, got {direction}")
                if role in ("writedata", "readdata") and width != 32:
                    raise ValueError(f"Avalon slave {group!r}: {name} must be 32 bits, "
                                     f"got {width}")
                if role in ("read", "write") and width != 1:
                    raise ValueError(f"Avalon slave {group!r}: {name} must be 1 bit")
            result.append(CoreInterface(group, "avalon", tuple(members)))
        else:
            result.append(CoreInterface(group, "conduit", tuple(members)))
    exported = [exported_port_name(i.name, m[1]) for i in result if i.kind == "conduit"
                for m in i.ports]
    if len(set(exported)) != len(exported):
        raise ValueError("two core conduit ports would get the same soc_system port name")
    return result


def exported_port_name(interface: str, role: str) -> str:
    """Port of the ``soc_system`` module for a role of an exported core conduit."""
    return f"{EXPORT_PREFIX}{interface}_{role}"


def soc_system_ports(core_ports) -> list[tuple[str, str, int]]:
    """Ports of the ``soc_system`` module as qsys-generate will write it.

    The clock source's ``clk_clk`` and ``reset_reset_n``, the HPS ``memory``
    conduit (:data:`HPS_MEMORY_PORTS`), its peripheral pins
    (:data:`HPS_IO_PORTS`) and reset to the FPGA (:data:`H2F_RESET_PORT`),
    then every core conduit port under its exported name. Returns (name,
    direction, width) tuples.
    """
    result = [("clk_clk", "input", 1), ("reset_reset_n", "input", 1),
              *HPS_MEMORY_PORTS, *HPS_IO_PORTS, H2F_RESET_PORT]
    for iface in core_interfaces(core_ports):
        if iface.kind == "conduit":
            for _, role, direction, width in iface.ports:
                result.append((exported_port_name(iface.name, role), direction, width))
    return result


def conduit_map(core_ports) -> dict[str, tuple[str, str, int]]:
    """Core conduit port -> (``soc_system`` port, direction, width)."""
    result = {}
    for iface in core_interfaces(core_ports):
        if iface.kind == "conduit":
            for port, role, direction, width in iface.ports:
                result[port] = (exported_port_name(iface.name, role), direction, width)
    return result


# ---- Tcl text -----------------------------------------------------------------------

def _tcl_word(value) -> str:
    """A Tcl word: braced unless it is a plain identifier or number."""
    text = str(value)
    if re.fullmatch(r"[A-Za-z0-9_.:/\-]+", text):
        return text
    if "{" in text or "}" in text or "\\" in text:
        raise ValueError(f"cannot quote {text!r} for Tcl")
    return "{" + text + "}"


_TCL_DIR = {"input": "Input", "output": "Output", "inout": "Bidir"}


def hw_tcl(core_ports, *, module: str = "stereogest_core",
           verilog_file: str = "stereogest_core.v", version: str = "1.0") -> str:
    """The ``_hw.tcl`` component of the core.

    Parameters
    ----------
    core_ports : list of (name, direction, width)
        The core's ports (:func:`soc.core.core_ports`).
    module, verilog_file : str
        Verilog module of the core and the file holding it (next to the
        ``_hw.tcl``).
    version : str
        Component version.
    """
    lines = [
        "# Platform Designer component of the stereogest core: its two Avalon-MM",
        "# slaves (word addresses, fixed read latency 1, no wait states) behind",
        "# the lightweight HPS-to-FPGA bridge, every other port a conduit.",
        "# Written by `stereogest generate` from the core's Verilog ports.",
        f"package require -exact qsys {QSYS_VERSION}",
        "",
        f"set_module_property NAME {_tcl_word(module)}",
        f"set_module_property VERSION {_tcl_word(version)}",
        "set_module_property INTERNAL false",
        "set_module_property OPAQUE_ADDRESS_MAP true",
        "set_module_property GROUP stereogest",
        "set_module_property AUTHOR stereogest",
        "set_module_property DISPLAY_NAME {stereogest core}",
        "set_module_property DESCRIPTION {Stereo-vision gesture pipeline, camera set-up, "
        "centroid FIFO, robot UART and VGA view}",
        "set_module_property INSTANTIATE_IN_SYSTEM_MODULE true",
        "set_module_property EDITABLE false",
        "set_module_property REPORT_TO_TALKBACK false",
        "set_module_property ALLOW_GREYBOX_GENERATION false",
        "",
        "add_fileset QUARTUS_SYNTH QUARTUS_SYNTH {} {}",
        f"set_fileset_property QUARTUS_SYNTH TOP_LEVEL {_tcl_word(module)}",
        "set_fileset_property QUARTUS_SYNTH ENABLE_RELATIVE_INCLUDE_PATHS false",
        f"add_fileset_file {_tcl_word(verilog_file)} VERILOG PATH {_tcl_word(verilog_file)} "
        "TOP_LEVEL_FILE",
        "",
    ]
    for iface in core_interfaces(core_ports):
        n = iface.name
        if iface.kind == "clock":
            lines += [f"add_interface {n} clock end", f"set_interface_property {n} clockRate 0"]
        elif iface.kind == "reset":
            lines += [f"add_interface {n} reset end",
                      f"set_interface_property {n} associatedClock clock",
                      # Amaranth resets are synchronous: both edges in the clock domain
                      f"set_interface_property {n} synchronousEdges BOTH"]
        elif iface.kind == "avalon":
            lines += [f"add_interface {n} avalon end"]
            for key, value in (("addressUnits", "WORDS"), ("associatedClock", "clock"),
                               ("associatedReset", "reset"), ("bitsPerSymbol", "8"),
                               ("burstOnBurstBoundariesOnly", "false"),
                               ("burstcountUnits", "WORDS"), ("explicitAddressSpan", "0"),
                               ("holdTime", "0"), ("linewrapBursts", "false"),
                               ("maximumPendingReadTransactions", "0"),
                               ("readLatency", "1"), ("readWaitTime", "0"),
                               ("setupTime", "0"), ("timingUnits", "Cycles"),
                               ("writeWaitTime", "0")):
                lines.append(f"set_interface_property {n} {key} {value}")
        else:
            lines += [f"add_interface {n} conduit end",
                      f"set_interface_property {n} associatedClock {{}}",
                      f"set_interface_property {n} associatedReset {{}}"]
        for port, role, direction, width in iface.ports:
            lines.append(f"add_interface_port {n} {_tcl_word(port)} {_tcl_word(role)} "
                         f"{_TCL_DIR[direction]} {width}")
        lines.append("")
    return "\n".join(lines)


def system_tcl(core_ports, slave_bases: dict, *, clock_hz: float = SYNC_HZ,
               core_module: str = "stereogest_core", device: str = DEVICE) -> str:
    """The qsys-script that builds ``soc_system.qsys``.

    Parameters
    ----------
    core_ports : list of (name, direction, width)
        The core's Verilog ports.
    slave_bases : dict
        Avalon slave name -> byte offset on the lightweight bridge (every slave
        of the core must have one; multiples of 0x100, below 2 MB).
    clock_hz : float
        Frequency of the clock the board top feeds in (the pipeline clock).
    core_module : str
        Component name (the ``_hw.tcl``'s ``NAME``).
    device : str
        FPGA part.

    Raises
    ------
    ValueError
        If a slave has no base, a base is not a multiple of 0x100 or outside the
        bridge, two bases collide, or a slave's span exceeds 0x100 bytes.
    """
    if isinstance(clock_hz, bool) or not isinstance(clock_hz, (int, float)) \
            or not 1e6 <= clock_hz <= 500e6:
        raise ValueError(f"clock_hz must be a number in [1e6, 500e6], got {clock_hz!r}")
    ifaces = core_interfaces(core_ports)
    slaves = [i for i in ifaces if i.kind == "avalon"]
    bases = {}
    for s in slaves:
        if s.name not in slave_bases:
            raise ValueError(f"Avalon slave {s.name!r} has no base address")
        base = slave_bases[s.name]
        if isinstance(base, bool) or not isinstance(base, int) or base % SLAVE_WINDOW \
                or not 0 <= base < 0x200000:
            raise ValueError(f"base of {s.name!r} must be a multiple of 0x100 in "
                             f"[0, 0x200000), got {base!r}")
        address_bits = dict((r, w) for _, r, _, w in s.ports)["address"]
        if 4 << address_bits > SLAVE_WINDOW:
            raise ValueError(f"slave {s.name!r} spans {4 << address_bits:#x} bytes, more than "
                             f"{SLAVE_WINDOW:#x}")
        if base in bases.values():
            raise ValueError(f"slaves share base {base:#x}")
        bases[s.name] = base
    extra = set(slave_bases) - set(bases)
    if extra:
        raise ValueError(f"base addresses for unknown slaves {sorted(extra)}")

    core = CORE_INSTANCE
    lines = [
        "# qsys-script: builds soc_system.qsys, the HPS with its lightweight",
        "# HPS-to-FPGA bridge and the stereogest core behind it.",
        "# Written by `stereogest generate`; run (next to stereogest_core_hw.tcl):",
        "#   qsys-script --script=soc_system.tcl --search-path=\"$PWD,$\"",
        f"package require -exact qsys {QSYS_VERSION}",
        "",
        f"create_system {SYSTEM_NAME}",
        "set_project_property DEVICE_FAMILY {Cyclone V}",
        f"set_project_property DEVICE {_tcl_word(device)}",
        "",
        "# the pipeline clock from the board top's PLL, and the FPGA-side reset: an",
        "# asynchronous OR of KEY[0], the PLL's lock and the HPS's h2f_reset, so it is",
        "# declared asynchronous and Platform Designer releases it through its own",
        "# reset synchroniser in front of the interconnect and the core",
        "add_instance clk_0 clock_source",
        f"set_instance_parameter_value clk_0 clockFrequency {float(clock_hz):.1f}",
        "set_instance_parameter_value clk_0 clockFrequencyKnown 1",
        f"set_instance_parameter_value clk_0 resetSynchronousEdges {SYSTEM_RESET_EDGES}",
        "",
        "# the HPS as the DE1-SoC reference design: its peripherals on their pins,",
        "# the board's DDR3, the lightweight bridge only",
        "add_instance hps_0 altera_hps",
    ]
    for key, value in {**HPS_BRIDGE_PARAMETERS, **HPS_PERIPHERAL_PARAMETERS,
                       **HPS_DDR3_PARAMETERS}.items():
        lines.append(f"set_instance_parameter_value hps_0 {key} {_tcl_word(value)}")
    lines += [
        "",
        "# the core (stereogest_core_hw.tcl)",
        f"add_instance {core} {_tcl_word(core_module)}",
        "",
        "# clocks and resets",
        "add_connection clk_0.clk hps_0.h2f_lw_axi_clock",
        f"add_connection clk_0.clk {core}.clock",
        f"add_connection clk_0.clk_reset {core}.reset",
        "",
        f"# the core's slaves on the lightweight bridge (HPS address "
        f"0x{LIGHTWEIGHT_BRIDGE_BASE:08X} + base)",
    ]
    for name, base in bases.items():
        lines += [f"add_connection hps_0.h2f_lw_axi_master {core}.{name}",
                  f"set_connection_parameter_value hps_0.h2f_lw_axi_master/{core}.{name} "
                  f"baseAddress {base:#06x}"]
    lines += [
        "",
        "# exported interfaces: clock, reset, HPS memory, pins and reset, the core's",
        "# conduits",
        "add_interface clk clock sink",
        "set_interface_property clk EXPORT_OF clk_0.clk_in",
        "add_interface reset reset sink",
        "set_interface_property reset EXPORT_OF clk_0.clk_in_reset",
        "add_interface memory conduit end",
        "set_interface_property memory EXPORT_OF hps_0.memory",
        f"add_interface {HPS_IO_EXPORT} conduit end",
        f"set_interface_property {HPS_IO_EXPORT} EXPORT_OF hps_0.hps_io",
        "# the HPS's reset of the FPGA side: the board top adds it to its reset tree",
        f"add_interface {H2F_RESET_EXPORT} reset source",
        f"set_interface_property {H2F_RESET_EXPORT} EXPORT_OF hps_0.h2f_reset",
    ]
    for iface in ifaces:
        if iface.kind == "conduit":
            export = EXPORT_PREFIX + iface.name
            lines += [f"add_interface {export} conduit end",
                      f"set_interface_property {export} EXPORT_OF {core}.{iface.name}"]
    lines += ["", f"save_system {SYSTEM_NAME}.qsys", ""]
    return "\n".join(lines)
