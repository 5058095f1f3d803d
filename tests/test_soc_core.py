# amaranth: UnusedElaboratable=no
"""soc/core.py: StereogestCore's ports (the list Platform Designer and the
simulation wrapper are built from) and its parameter checks. The core running
end to end: tests/test_soc_system.py."""
from __future__ import annotations

import pytest

from soc.core import CLOCK_DOMAINS, CORE_NAME, StereogestCore, core_ports, emit_core_verilog
from tests.test_hdl_gesture_pipeline import SMALL

W, H = 32, 16


def test_core_ports_are_the_documented_ones():
    from soc.platform_designer import verilog_ports
    core = StereogestCore(W, H, SMALL)
    text = emit_core_verilog(core)
    ports = {name: (direction, width) for name, direction, width in verilog_ports(text, CORE_NAME)}
    expected = {"clk": ("input", 1), "rst": ("input", 1),
                "fifo__address": ("input", 3), "fifo__readdata": ("output", 32),
                "uart__address": ("input", 2), "uart__writedata": ("input", 32),
                "left__data": ("input", 8), "right__vsync": ("input", 1),
                "left_i2c__sda_oe": ("output", 1), "right_i2c__scl_i": ("input", 1),
                "uart_tx": ("output", 1), "uart_rx": ("input", 1),
                "vga__r": ("output", 8), "vga__blank_n": ("output", 1),
                "stage_select": ("input", 3), "capture": ("input", 1), "pause": ("input", 1),
                "configure": ("input", 1), "leds": ("output", 10)}
    for domain in CLOCK_DOMAINS:
        expected[f"{domain}_clk"] = ("input", 1)
        expected[f"{domain}_rst"] = ("input", 1)
    for name, port in expected.items():
        assert ports.get(name) == port, name
    # the list Platform Designer and the simulation wrapper are built from, taken
    # from the signature, is the emitted Verilog's
    assert sorted(core_ports(core)) == sorted(verilog_ports(text, CORE_NAME))


@pytest.mark.parametrize("kwargs, word", [
    (dict(sync_freq=0), "sync_freq"), (dict(config_freq=1e12), "config_freq"),
    (dict(vga_mode="vga"), "vga_mode"), (dict(width=7), "width"),
    (dict(vga_scale=3), r"vga_scale must be in \[1, 2\]"), (dict(vga_scale=0), "vga_scale"),
    (dict(width=2048), r"width and height must be at most 1024 \(the FIFO words"),
])
def test_core_rejects_bad_parameters(kwargs, word):
    args = dict(width=W, height=H, params=SMALL)
    args.update(kwargs)
    with pytest.raises(ValueError, match=word):
        StereogestCore(**args)


@pytest.mark.parametrize("vga_scale, words", [(1, W * H), (2, W * H // 4), (None, W * H // 4)])
def test_core_frame_buffer_resolution(vga_scale, words):
    """``vga_scale`` reaches the frame buffer (half resolution by default)."""
    from amaranth.hdl import Fragment
    args = {} if vga_scale is None else dict(vga_scale=vga_scale)
    core = StereogestCore(W, H, SMALL, **args)
    assert core.frame_buffer.depth == words
    assert core.frame_buffer.scale == (vga_scale or 2)
    Fragment.get(core, None)            # elaborates (no unused elaboratables left)


def test_core_with_rectification_has_its_stages_and_the_same_ports():
    """`stereogest generate --calibration`: the core builds both rectification
    stages with the calibration's maps; its ports stay those of the bundle."""
    from tests.test_hdl_gesture_pipeline import small_rectification
    plain = StereogestCore(W, H, SMALL)
    core = StereogestCore(W, H, SMALL, rectification=small_rectification(W, H))
    text = emit_core_verilog(core)
    assert "rectify_left" in text and "rectify_right" in text
    assert "rectify_left" not in emit_core_verilog(plain)
    assert core_ports(core) == core_ports(plain)
