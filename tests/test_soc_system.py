# amaranth: UnusedElaboratable=no
"""verif/system.py: the whole FPGA side (soc.core.StereogestCore) end to end under
Verilator with the unmodified board application on its registers (small frames;
the demo runs the full size). The core's ports: tests/test_soc_core.py."""
from __future__ import annotations

import numpy as np
import pytest

from sim.model.pipeline import run_clip
from sim.model.pipeline import video_picture
from verif.end_to_end import frames_to_still, hold_still, run_end_to_end
from verif.system import SystemBus, VerilatorSystem, decode_uart
from soc.hps_interface import UART_STATUS, UART_STATUS_TX_READY
from sw_hps.robot import UartLink
from sw_hps.telegram import telegram
from tests.test_hdl_gesture_pipeline import SMALL, small_frames

W, H = 32, 16


def test_decode_uart_is_a_real_receiver():
    bit = round(1e12 / 115200)
    # 0x31 = 0b00110001, LSB first, then a byte with a broken stop bit
    levels = [0] + [(0x31 >> i) & 1 for i in range(8)] + [1] + \
             [0] + [(0x55 >> i) & 1 for i in range(8)] + [0, 1]
    edges, last = [], 1
    for k, level in enumerate(levels):
        if level != last:
            edges.append((1000 + k * bit, level))
            last = level
    assert decode_uart(np.array(edges, dtype=np.int64)) == b"\x31"


@pytest.fixture(scope="module")
def system_run():
    """Twelve small frames with a moving hand through the Verilated core and the
    board application, beside the golden model."""
    from sw_hps.hmm import load_models
    import sw_hps
    from pathlib import Path
    models = load_models(Path(sw_hps.__file__).parent / "models" / "thesis7.json")
    left, right = small_frames(12, W, H)
    trajectory, kept = run_clip(left, right, SMALL, keep=lambda n: n == 11)
    left, right, played, extra = hold_still(left, right, trajectory, SMALL, kept[11])
    result = run_end_to_end(left, right, models, played, kept[11], SMALL, stage="left",
                            posture_model=_AnyHand())
    return result, played, extra, kept[11]


class _AnyHand:
    """A posture model that names every described hand "hand"."""

    def classify(self, features):
        return "hand" if np.any(features) else None


def test_the_board_application_names_postures_through_the_soc(system_run):
    """With a posture model the thesis loop polls the posture slave over the
    bridge while it reads the FIFO (whose words still equal the model's, in
    the test below); each finished gesture names the posture held over the
    records it read, as the model's records name it (in these small frames
    the hand is described in 2 of the gesture's 7 frames: no posture)."""
    from sw_hps.posture import held_posture, record_posture
    result, played, _, _ = system_run
    finished = [r for r in result.results if r["outcome"] != "dropped"]
    names = [record_posture(_AnyHand(), words) for words in played.posture]
    assert names.count("hand") == 2
    expected = held_posture(n for n, f in zip(names, played.flag) if f)[0]
    assert finished
    for r in finished:
        assert r["posture_share"] is not None          # records were read over its span
        assert r["posture"] == expected


def test_the_last_posture_record_through_the_soc_equals_the_golden_model(system_run):
    """The posture slave's last record, read by the board's reader over the
    bridge, is the model's record of the last frame played (the hold-still
    repeats included), and Status.SEQ counts every frame."""
    result, played, extra, _ = system_run
    assert len(played.posture) == len(played.flag)
    assert result.posture_expected[0] == len(played.flag)
    assert result.posture == result.posture_expected and result.posture_matches_model
    # (the hand has left these small frames by the last one; make demo shows one)


def test_fifo_words_equal_the_golden_model(system_run):
    result, played, _, _ = system_run
    assert played.flag.any()
    assert result.expected, "the clip must flag some frames"
    assert result.popped == result.expected


def test_vga_frame_equals_the_golden_model(system_run):
    """The core's default frame buffer (half resolution) shows the model's
    picture of the last frame, pixel for pixel; the full-resolution picture
    is not what it shows (the check tells the two apart)."""
    from hdl.lrcc import disparity_bits
    from sim.model.vga import vga_frame
    from soc.core import FRAME_BUFFER_BITS, VGA_SCALE
    from soc.vga_timing import VGA_640x480_60
    result, _, _, stages = system_run
    assert result.vga.shape == (480, 640)
    assert result.vga[:H, :W].any()
    assert result.vga_mismatches == 0
    picture = video_picture(stages, "left", disparity_bits(SMALL.max_disparity))
    for scale in (1, 2):
        shown = vga_frame(picture, VGA_640x480_60, FRAME_BUFFER_BITS, scale=scale)[:480, :640, 0]
        assert np.array_equal(result.vga, shown) == (scale == VGA_SCALE)


def test_vga_frame_at_full_resolution_equals_the_golden_model():
    """``vga_scale=1`` reaches the Verilated core: a short clip, the last frame's
    picture shown whole, pixel for pixel (and not the half-resolution one)."""
    from pathlib import Path

    import sw_hps
    from hdl.lrcc import disparity_bits
    from sim.model.vga import vga_frame
    from soc.core import FRAME_BUFFER_BITS
    from soc.vga_timing import VGA_640x480_60
    from sw_hps.hmm import load_models
    models = load_models(Path(sw_hps.__file__).parent / "models" / "thesis7.json")
    left, right = small_frames(3, W, H)
    trajectory, kept = run_clip(left, right, SMALL, keep=lambda n: n == 2)
    left, right, played, _ = hold_still(left, right, trajectory, SMALL)
    result = run_end_to_end(left, right, models, played, kept[2], SMALL, stage="right",
                            vga_scale=1)
    assert result.vga_mismatches == 0 and result.vga[:H, :W].any()
    picture = video_picture(kept[2], "right", disparity_bits(SMALL.max_disparity))
    half = vga_frame(picture, VGA_640x480_60, FRAME_BUFFER_BITS, scale=2)[:480, :640, 0]
    assert not np.array_equal(result.vga, half)


def test_leds_show_go_and_the_unanswered_configuration(system_run):
    """GO; no camera configured (no I2C target here); the configuration error
    (LEDR[2]) lit exactly when the simulated time has passed the moment the
    model's schedule gives up on a target that never answers (the power-up,
    then every attempt of row 0)."""
    from sim.model.ov5642_config import first_row_schedule
    from soc.ov5642_config import Ov5642Config
    from verif.clocks import Clocks
    result, _, _, _ = system_run
    leds = result.leds
    assert leds & (1 << 5), "GO set by the application"
    assert not leds & 0b11
    master = Ov5642Config(clk_freq=1e12 / Clocks().config_ps)
    gave_up = first_row_schedule(master.timing, master.power, max_retries=master.max_retries,
                                 ready=1 << 62).error_at
    simulated_ps = result.stats["vga_cycles"] * Clocks().vga_ps
    gave_up_ps = gave_up * Clocks().config_ps
    assert abs(simulated_ps - gave_up_ps) > 1e9, "too close to tell (1 ms)"
    assert bool(leds & (1 << 2)) == (simulated_ps > gave_up_ps), \
        (simulated_ps / 1e9, gave_up_ps / 1e9, f"{leds:010b}")


def test_hold_still_ends_the_flag(system_run):
    _, played, extra, _ = system_run
    assert not played.flag[-1]
    assert frames_to_still(played, SMALL) == 0


@pytest.mark.parametrize("stage", ["disparity", "skin", "left"])
def test_video_picture_matches_the_pipeline_video_encoding(stage):
    left, right = small_frames(2, W, H)
    _, kept = run_clip(left, right, SMALL, keep=lambda n: True)
    picture = video_picture(kept[1], stage, 4)
    assert picture.dtype == np.uint8 and picture.shape == (H, W)
    if stage == "disparity":
        assert np.array_equal(picture, kept[1].disparity.astype(np.uint8) << 4)
    elif stage == "skin":
        assert set(np.unique(picture)) <= {0, 255}


def test_uart_link_bytes_reach_the_tx_pin():
    """The HPS driver (UartLink) through the Avalon slave to the pin, decoded by
    the independent receiver."""
    left, right = small_frames(1, W, H)
    with VerilatorSystem(left, right, SMALL) as system:
        bus = SystemBus(system)
        system.advance(2e-6)
        assert bus.read32(0x100 + UART_STATUS) & UART_STATUS_TX_READY
        data = telegram("stop") + telegram("forward")
        assert UartLink(bus, 0x100).send(data)
        system.advance(len(data) * 10 / 115200 + 200e-6)
        edges = system.uart_edges()
    assert decode_uart(edges) == data


def test_identification_registers_over_the_bridge():
    """ID and Version read over the simulated lightweight bridge: the magic and
    the parameters the core was built with (its 32 x 16 frames, the board's FIFO
    depth, the streaming mode), as the driver's identify() decodes them."""
    from soc.hps_interface import CORE_MAGIC, FIFO_DEPTH, ID, VERSION, version_word
    from sw_hps.fifo import FifoPeripheral
    left, right = small_frames(1, W, H)
    with VerilatorSystem(left, right, SMALL) as system:
        bus = SystemBus(system)
        words = bus.read32(ID), bus.read32(VERSION)
        bus.write32(ID, 0)                             # read-only: ignored
        bus.write32(VERSION, 0)
        identity = FifoPeripheral(bus).identify()
    assert words == (CORE_MAGIC, version_word(fifo_depth=FIFO_DEPTH, streaming=True,
                                              frame_width=W, frame_height=H))
    assert (identity.magic, identity.version_word) == words
    assert identity.supported and (identity.frame_width, identity.frame_height) == (W, H)
    assert identity.fifo_depth == FIFO_DEPTH and identity.streaming


def test_streaming_mode_pushes_every_frame():
    """Control = GO | STREAM (issue 28): the Verilated core pushes every frame's
    record, with the spotting flag and the hand-present bit above the data,
    word for word the golden model's (sw_hps.simulated.streaming_words); the
    frames include flagged and unflagged ones, with and without a hand."""
    from hdl.gesture_pipeline import pipeline_timing
    from sw_hps.fifo import CTRL_GO, CTRL_STREAM, FifoPeripheral
    from sw_hps.simulated import streaming_words
    left, right = small_frames(12, W, H)
    trajectory, _ = run_clip(left, right, SMALL)
    expected = streaming_words(trajectory)
    flags = {(x >> 18 & 1, y >> 18 & 1) for x, y in expected}
    assert len(expected) == 12 and {(0, 1), (1, 1)} <= flags, flags
    timing = pipeline_timing(W, H, SMALL)
    with VerilatorSystem(left, right, SMALL) as system:
        bus = SystemBus(system)
        fifo = FifoPeripheral(bus)
        fifo.start(streaming=True)
        assert fifo.status().streaming and fifo.status().go
        while not system.cameras_done:
            system.advance(20e-6)
        system.advance((timing.record_cycles + 8 * W) / 100e6)
        while fifo.status().pairs_available:
            fifo.pop_words()
    assert bus.popped == expected
