"""The clock of every domain of the core, in Hz: one place for the PLL
(:class:`soc.board_top.BoardTop`), the Quartus constraints (``stereogest
generate``) and the place-and-route check (``stereogest timing``).

======== ============================ =========================================
domain   source on the DE1-SoC        frequency
======== ============================ =========================================
sync     PLL output 0                 100 MHz, the thesis' pixel clock
vga      PLL output 1                 25 MHz (640x480 raster, 59.5 Hz frames)
xclk     PLL output 2                 24 MHz, both cameras' XCLK
config   CLOCK_50, board oscillator   50 MHz, the cameras' I2C masters
cam_*    each camera's PCLK           constrained at its upper bound
======== ============================ =========================================
"""
from __future__ import annotations

from boards.de1_soc import PCLK_MAX_FREQUENCY

__all__ = ["SYNC_HZ", "VGA_HZ", "XCLK_HZ", "CONFIG_HZ", "PCLK_HZ", "domain_clocks"]

SYNC_HZ = 100e6
VGA_HZ = 25e6
XCLK_HZ = 24e6
CONFIG_HZ = 50e6
#: The camera PCLK constraint (an upper bound; see boards.de1_soc).
PCLK_HZ = PCLK_MAX_FREQUENCY


def domain_clocks(sync_hz: float = SYNC_HZ, vga_hz: float = VGA_HZ) -> dict[str, float]:
    """Constraint (Hz) of each clock domain of :class:`soc.core.StereogestCore`."""
    return {"sync": float(sync_hz), "cam_left": PCLK_HZ, "cam_right": PCLK_HZ,
            "config": CONFIG_HZ, "vga": float(vga_hz)}
