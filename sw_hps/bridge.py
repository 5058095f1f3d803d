"""State of the FPGA and of the lightweight HPS-to-FPGA bridge, read from the
HPS's own registers before the first access to the bridge.

Runs on the board's ARM: Python 3 standard library only.

A read through a lightweight bridge that is held in reset, or into an FPGA that
is not configured, does not return an error code: the ARM takes a bus error
(Python dies of SIGBUS) or reads garbage. The HPS's reset manager and FPGA
manager are hard blocks of the HPS and always answer, so reading them first
tells whether touching the bridge is safe, and what to fix if it is not.

Facts from the Cyclone V Hard Processor System Technical Reference Manual
(Intel document 683126; register map pages "brgmodrst" and "stat" at
intel.com/content/www/us/en/programmable/hps/cyclone-v/, section 5.3.2 "FPGA
Configuration" for the MSEL table), cross-checked with the Linux kernel's
``include/dt-bindings/reset/altr,rst-mgr.h`` (BRGMODRST bank: HPS2FPGA_RESET = 96,
LWHPS2FPGA_RESET = 97, i.e. bits 0 and 1 of the fourth reset register after
``altr,modrst-offset = <0x10>``) and ``drivers/fpga/socfpga.c`` (``stat`` at
offset 0, mode in bits [2:0], user mode 4):

* reset manager at ``0xFFD05000``; ``brgmodrst`` at offset ``0x1C``; bit 0
  hps2fpga, bit 1 lwhps2fpga, bit 2 fpga2hps; 1 = the bridge is held in reset
  (every bit resets to 1; the boot loader or the kernel clears them);
* FPGA manager at ``0xFF706000``; ``stat`` at offset 0: bits [2:0] the FPGA's
  mode (0 powered off, 1 reset phase, 2 configuration phase, 3 initialization
  phase, 4 user mode, 5 undetermined), bits [7:3] the MSEL pins, which fix the
  passive parallel width and whether the bitstream must be compressed.
"""
from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass

from .bus import DevMemBus

__all__ = ["RESET_MANAGER_BASE", "BRGMODRST", "BRGMODRST_HPS2FPGA", "BRGMODRST_LWHPS2FPGA",
           "BRGMODRST_FPGA2HPS", "FPGA_MANAGER_BASE", "FPGAMGR_STAT", "STAT_MODE_MASK",
           "STAT_MSEL_SHIFT", "STAT_MSEL_MASK", "FPGA_MODES", "USER_MODE", "MselScheme",
           "MSEL_SCHEMES", "BridgeState", "read_bridge_state", "FIX_CONFIGURE", "FIX_BRIDGE"]

#: Reset manager (``rstmgr``) of the Cyclone V HPS.
RESET_MANAGER_BASE = 0xFFD05000
#: Bridge module reset register: 1 = that bridge is held in reset.
BRGMODRST = 0x1C
BRGMODRST_HPS2FPGA = 1 << 0
BRGMODRST_LWHPS2FPGA = 1 << 1
BRGMODRST_FPGA2HPS = 1 << 2

#: FPGA manager (``fpgamgrregs``) of the Cyclone V HPS.
FPGA_MANAGER_BASE = 0xFF706000
#: Its status register: the FPGA's mode and the MSEL pins.
FPGAMGR_STAT = 0x0
STAT_MODE_MASK = 0x7
STAT_MSEL_SHIFT = 3
STAT_MSEL_MASK = 0x1F << STAT_MSEL_SHIFT
#: ``stat.mode`` values.
FPGA_MODES = {0: "powered off", 1: "reset phase", 2: "configuration phase",
              3: "initialization phase", 4: "user mode", 5: "undetermined"}
#: The mode in which the FPGA's logic runs (the only one in which the core answers).
USER_MODE = 4

#: How the HPS feeds a bitstream for an MSEL setting: passive parallel ``width``
#: (16 or 32 bits), ``compressed`` (the .rbf must be compressed) and ``aes`` (it
#: must be encrypted).
MselScheme = namedtuple("MselScheme", "width compressed aes")
#: The MSEL values with which the HPS can configure the FPGA (TRM table
#: "Configuration Schemes for FPGA Configuration by the HPS"; bit 2 only selects
#: the power-on-reset delay).
MSEL_SCHEMES = {}
for _por in (0b00000, 0b00100):
    MSEL_SCHEMES[_por | 0b00000] = MselScheme(16, False, False)
    MSEL_SCHEMES[_por | 0b00001] = MselScheme(16, False, True)
    MSEL_SCHEMES[_por | 0b00010] = MselScheme(16, True, False)
    MSEL_SCHEMES[_por | 0b01000] = MselScheme(32, False, False)
    MSEL_SCHEMES[_por | 0b01001] = MselScheme(32, False, True)
    MSEL_SCHEMES[_por | 0b01010] = MselScheme(32, True, False)
del _por

#: What to do when the FPGA is not in user mode (docs/bring-up.md, shipped as
#: BRINGUP.md, has the commands for each boot loader and kernel).
FIX_CONFIGURE = ("load the FPGA: stereogest.rbf from U-Boot ('fatload' + 'fpga load') or "
                 "Linux's FPGA manager, or stereogest.sof over JTAG (BRINGUP.md, 'Program "
                 "the FPGA')")
#: What to do when the lightweight bridge is held in reset.
FIX_BRIDGE = ("release the lightweight bridge: U-Boot 'bridge enable' (older U-Boot: 'run "
              "bridge_enable_handoff'), or on Linux 'echo 1 > "
              "/sys/class/fpga-bridge/lwhps2fpga/enable' (Altera 3.x kernels) or "
              "'bridge-enable = <1>' on the lwhps2fpga bridge in the device tree (mainline "
              "kernels) (BRINGUP.md, 'Enable the bridge')")


@dataclass(frozen=True)
class BridgeState:
    """The two HPS registers that tell whether the lightweight bridge can be used.

    Attributes
    ----------
    brgmodrst : int
        Reset manager's ``brgmodrst`` word.
    fpga_stat : int
        FPGA manager's ``stat`` word.
    """
    brgmodrst: int
    fpga_stat: int

    @property
    def lw_bridge_in_reset(self) -> bool:
        """The lightweight HPS-to-FPGA bridge is held in reset."""
        return bool(self.brgmodrst & BRGMODRST_LWHPS2FPGA)

    @property
    def fpga_mode(self) -> int:
        """``stat.mode``: 4 is user mode."""
        return self.fpga_stat & STAT_MODE_MASK

    @property
    def fpga_mode_name(self) -> str:
        return FPGA_MODES.get(self.fpga_mode, f"reserved mode {self.fpga_mode}")

    @property
    def user_mode(self) -> bool:
        """The FPGA is configured and its logic runs."""
        return self.fpga_mode == USER_MODE

    @property
    def msel(self) -> int:
        """The MSEL pins (``stat`` bits [7:3])."""
        return (self.fpga_stat & STAT_MSEL_MASK) >> STAT_MSEL_SHIFT

    @property
    def scheme(self):
        """The :class:`MselScheme` of the MSEL pins, or None if the HPS cannot
        configure the FPGA with that setting."""
        return MSEL_SCHEMES.get(self.msel)

    @property
    def safe(self) -> bool:
        """Accesses to the lightweight bridge can be made: the FPGA is in user
        mode and the bridge out of reset."""
        return self.user_mode and not self.lw_bridge_in_reset

    def describe_msel(self) -> str:
        """MSEL and the bitstream it asks for, e.g. ``MSEL 01010 (FPP x32,
        compressed .rbf)``."""
        scheme = self.scheme
        if scheme is None:
            return (f"MSEL {self.msel:05b} (not a setting the HPS can configure the FPGA "
                    f"with: U-Boot and Linux cannot load an .rbf)")
        kind = "compressed" if scheme.compressed else "uncompressed"
        aes = ", AES-encrypted" if scheme.aes else ""
        return f"MSEL {self.msel:05b} (FPP x{scheme.width}, {kind}{aes} .rbf)"

    def describe(self) -> str:
        """One line: the FPGA's mode and the bridge's reset state."""
        bridge = "held in reset" if self.lw_bridge_in_reset else "out of reset"
        return (f"FPGA {self.fpga_mode_name}, lightweight bridge {bridge} "
                f"(stat {self.fpga_stat:#x}, brgmodrst {self.brgmodrst:#x})")

    def problems(self) -> list:
        """Each reason the bridge cannot be used, as ``"<problem>; fix: <fix>"`` lines,
        the FPGA first (releasing a bridge to an unconfigured FPGA does not help)."""
        found = []
        if not self.user_mode:
            found.append(f"FPGA not in user mode ({self.fpga_mode_name}, "
                         f"{self.describe_msel()}); fix: {FIX_CONFIGURE}")
        if self.lw_bridge_in_reset:
            found.append(f"lightweight HPS-to-FPGA bridge held in reset (brgmodrst "
                         f"{self.brgmodrst:#x}); fix: {FIX_BRIDGE}")
        return found

    def fix(self) -> str:
        """The first fix to apply ('' when the bridge can be used)."""
        if not self.user_mode:
            return FIX_CONFIGURE
        if self.lw_bridge_in_reset:
            return FIX_BRIDGE
        return ""


def read_bridge_state(path: str = "/dev/mem", open_window=None) -> BridgeState:
    """Read ``brgmodrst`` and the FPGA manager's ``stat`` (never the bridge).

    Parameters
    ----------
    path : str
        The physical-memory device (root only); a test passes a sparse file.
    open_window : callable, optional
        ``open_window(address, span)`` returning a bus (``read32``, ``close``)
        whose offset 0 is physical ``address``; defaults to :class:`DevMemBus`
        on ``path``. Tests inject fakes.

    Raises
    ------
    BusError
        ``path`` cannot be opened or mapped (the message names it).
    """
    if open_window is None:
        def open_window(address, span):
            return DevMemBus(base=address, offset=0, span=span, path=path)
    values = []
    for base, offset in ((RESET_MANAGER_BASE, BRGMODRST), (FPGA_MANAGER_BASE, FPGAMGR_STAT)):
        window = open_window(base + offset, 4)
        try:
            values.append(int(window.read32(0)) & 0xFFFFFFFF)
        finally:
            window.close()
    return BridgeState(brgmodrst=values[0], fpga_stat=values[1])
