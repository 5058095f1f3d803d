"""soc/clocks.py: one frequency per clock domain of the core, the same set of
domains the core declares."""
from boards.de1_soc import PCLK_MAX_FREQUENCY
from soc.clocks import CONFIG_HZ, PCLK_HZ, SYNC_HZ, VGA_HZ, XCLK_HZ, domain_clocks
from soc.core import CLOCK_DOMAINS


def test_every_domain_of_the_core_has_a_clock():
    assert set(domain_clocks()) == {"sync", *CLOCK_DOMAINS}


def test_the_figures():
    assert (SYNC_HZ, VGA_HZ, XCLK_HZ, CONFIG_HZ) == (100e6, 25e6, 24e6, 50e6)
    assert PCLK_HZ == PCLK_MAX_FREQUENCY
    clocks = domain_clocks(sync_hz=80e6, vga_hz=25.175e6)
    assert clocks["sync"] == 80e6 and clocks["vga"] == 25.175e6
    assert clocks["cam_left"] == clocks["cam_right"] == PCLK_HZ
    assert clocks["config"] == CONFIG_HZ
