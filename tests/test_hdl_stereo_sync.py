# amaranth: UnusedElaboratable=no
"""hdl/stereo_sync.py (thesis §5.3): two CameraCaptures in their own PCLK domains
feeding the StereoSynchronizer, clean and with every link fault.

Multi-clock runs: ``sync`` 10 ns, ``cam_left`` 20 ns, ``cam_right`` 20 ns with a 7 ns
phase offset (21 ns in the clean run), cameras started 200-250 PCLK cycles apart
(6 cycles in the small-FIFO run).

Synchroniser output contract checked on every run: a completed frame is W*H pixel
beats (``first`` on the first) immediately followed by FLUSH flush beats; an aborted
frame is a prefix of its pixel beats and nothing more (no padding, no flush), the
next beat being the next frame's ``first``; nothing between frames.
"""
import numpy as np
import pytest
from amaranth.hdl import ClockDomain, DomainRenamer, Elaboratable, Module, Signal
from amaranth.lib import wiring
from amaranth.sim import Simulator

from hdl.camera_capture import CameraCapture
from hdl.stereo_sync import StereoSynchronizer
from sim.camera import (CameraTiming, camera_waveform, cut_frame, href_glitch, pack_pins,
                        stop_frame, vsync_in_line)
from tests.test_hdl_camera_capture import CAM_NS, H, TIMING, VSYNC_BIT, W, _frames

FLUSH = 10
SYNC_NS = 10

# ------------------------------------------------------------------ stereo harness


class _StereoTop(Elaboratable):
    """Two captures renamed to the camera domains, the synchroniser, and the three
    clock domains; each camera's pins are driven as one packed word (pack_pins)."""

    def __init__(self, **sync_kw):
        self.capture = [CameraCapture(W, H), CameraCapture(W, H)]
        self.sync = StereoSynchronizer(W, H, **sync_kw)
        self.pins = [Signal(10, name="pins_left"), Signal(10, name="pins_right")]
        self.start = Signal(init=1)
        self.pause = Signal()
        self.domains = [ClockDomain("sync"), ClockDomain("cam_left"), ClockDomain("cam_right")]

    def elaborate(self, platform):
        m = Module()
        m.domains += self.domains
        m.submodules.sync = sync = self.sync
        for side, cap, pins, into in (("left", self.capture[0], self.pins[0], sync.i_left),
                                      ("right", self.capture[1], self.pins[1], sync.i_right)):
            renamed = DomainRenamer(f"cam_{side}")(cap)
            m.submodules[f"capture_{side}"] = renamed
            # the ports are reached through the renamed wrapper (it forwards them)
            m.d.comb += [renamed.data.eq(pins[:8]), renamed.href.eq(pins[8]),
                         renamed.vsync.eq(pins[9]), renamed.start.eq(self.start),
                         renamed.pause.eq(self.pause)]
            wiring.connect(m, renamed.o_stream, into)
        return m


def _run_stereo(wave_l, wave_r, *, right_ns=CAM_NS, right_phase_ns=7, reset_at_ns=None,
                **sync_kw):
    """Simulate; returns (beats, counters). ``beats``: (cycle, payload) of every valid
    output cycle, or ("reset", cycle) when the sync reset was high."""
    sync_kw.setdefault("flush", FLUSH)
    top = _StereoTop(**sync_kw)
    tail = 80
    n = max(len(wave_l), len(wave_r)) + tail
    pins = [np.concatenate([p, np.full(n - len(p), VSYNC_BIT, np.uint16)]).tolist()
            for p in (pack_pins(wave_l), pack_pins(wave_r))]
    beats, counters = [], {}
    end_ns = n * max(CAM_NS, right_ns) + right_phase_ns + 50

    def camera(k, domain):
        async def tb(ctx):
            signal = top.pins[k]
            for word in pins[k]:
                ctx.set(signal, word)
                await ctx.tick(domain)
        return tb

    async def collector(ctx):
        o, rst = top.sync.o_stream, top.domains[0].rst
        payload = o.payload.as_value()
        cycle = 0
        while True:
            if ctx.get(rst):
                beats.append(("reset", cycle))
            elif ctx.get(o.valid):
                beats.append((cycle, ctx.get(payload)))
            await ctx.tick("sync")
            cycle += 1

    async def finish(ctx):
        await ctx.delay(end_ns * 1e-9)
        s = top.sync
        counters.update(frames=ctx.get(s.frames), faults=ctx.get(s.faults),
                        stale=ctx.get(s.stale),
                        started=[ctx.get(c.frames) for c in top.capture],
                        overruns=[ctx.get(c.overruns) for c in top.capture])

    async def resetter(ctx):
        await ctx.delay(reset_at_ns * 1e-9)
        for cd in top.domains:
            ctx.set(cd.rst, 1)
        await ctx.delay(120e-9)
        for cd in top.domains:
            ctx.set(cd.rst, 0)

    sim = Simulator(top)
    sim.add_clock(SYNC_NS * 1e-9, domain="sync")
    sim.add_clock(CAM_NS * 1e-9, domain="cam_left")
    sim.add_clock(right_ns * 1e-9, domain="cam_right", phase=right_phase_ns * 1e-9)
    sim.add_testbench(camera(0, "cam_left"))
    sim.add_testbench(camera(1, "cam_right"))
    sim.add_testbench(finish)
    sim.add_testbench(collector, background=True)
    if reset_at_ns is not None:
        sim.add_testbench(resetter)
    sim.run()
    return beats, counters


def _unpack(payload):
    """(first, left luma, left chroma, right luma, right chroma) of a pixel-pair word."""
    return (payload & 1, (payload >> 1) & 0xFF, (payload >> 9) & 0xFF,
            (payload >> 17) & 0xFF, (payload >> 25) & 0xFF)


def _split(beats, flush=FLUSH):
    """Output frames, checking the contract: ``first`` on the first pixel only; a
    completed frame is W*H pixels then exactly ``flush`` zero beats on consecutive
    cycles; an aborted frame is fewer than W*H pixels, ended by the next frame's
    ``first`` (so no flush after it); nothing between frames. A frame cut by the sync
    reset is discarded (the pipeline is reset too). Returns a list of (pixels
    (p, 4) uint8: left luma, left chroma, right luma, right chroma; complete)."""
    frames, current = [], None
    n = W * H

    def close(complete):
        frames.append((np.array(current["pixels"], dtype=np.uint8).reshape(-1, 4),
                       complete))

    for beat in beats:
        if beat[0] == "reset":
            current = None
            continue
        cycle, payload = beat
        first, *pix = _unpack(payload)
        if first:
            if current is not None:
                # the frame before was aborted: pixels only, no padding, no flush
                assert len(current["pixels"]) < n, \
                    f"cycle {cycle}: first after a full frame without its flush"
                close(False)
            current = {"pixels": [], "flush": []}
        assert current is not None, f"cycle {cycle}: beat outside a frame"
        if len(current["pixels"]) < n:
            current["pixels"].append(pix)
            if len(current["pixels"]) == n:
                current["last"] = cycle
        else:
            assert payload == 0, f"cycle {cycle}: flush beat with payload {payload:#x}"
            current["flush"].append(cycle)
        if len(current["pixels"]) == n and len(current["flush"]) == flush:
            cycles = current["last"] + 1 + np.arange(flush)
            assert current["flush"] == cycles.tolist(), "flush beats not one per clock"
            close(True)
            current = None
    assert current is None, "the run ended inside a frame"
    return frames


def _identify(frames, cams_l, cams_r):
    """Each output frame as the camera frame index it holds: ``k`` (complete, both
    sides equal to camera frame k bit for bit) or ``"k!p"`` (aborted: p pixels, both
    sides equal to the first p pixels of camera frame k)."""
    cams = np.concatenate([cams_l.reshape(len(cams_l), -1, 2),
                           cams_r.reshape(len(cams_r), -1, 2)], axis=2)  # (k, W*H, 4)
    seq = []
    for pix, complete in frames:
        p = len(pix)
        match = [k for k in range(len(cams)) if (cams[k, :p] == pix).all()]
        assert match, f"{'complete' if complete else 'aborted'} frame of {p} pixels " \
                      "is no camera frame (or prefix of one)"
        seq.append(match[0] if complete else f"{match[0]}!{p}")
    return seq


def test_stereo_clean_frames_bit_exact():
    cams_l, cams_r = _frames(5, 1), _frames(5, 2)
    # the right camera starts 250 cycles earlier with a 5 % slower PCLK (21 ns)
    wave_l = camera_waveform(cams_l, TIMING, start_delay=250)
    wave_r = camera_waveform(cams_r, TIMING, start_delay=0)
    beats, counters = _run_stereo(wave_l, wave_r, right_ns=21, right_phase_ns=0,
                                  fifo_depth=256, threshold=16)
    frames = _split(beats)
    assert _identify(frames, cams_l, cams_r) == [0, 1, 2, 3, 4]
    assert counters["frames"] == 5 and counters["faults"] == 0 and counters["stale"] == 0
    assert counters["started"] == [5, 5] and counters["overruns"] == [0, 0]


def _fault_case(kind):
    """Left camera leads by 200 cycles; frame 1 of one camera is damaged."""
    cams_l, cams_r = _frames(4, 3), _frames(4, 4)
    wave_l = camera_waveform(cams_l, TIMING, start_delay=0)
    wave_r = camera_waveform(cams_r, TIMING, start_delay=200)
    reset_at = None
    if kind == "cut_frame":
        wave_l = cut_frame(wave_l, 1, 3)
    elif kind == "href_glitch":       # right camera, last line: caught by the next sof
        wave_r = href_glitch(wave_r, 1, H - 1, 2 * W - 2)
    elif kind == "href_glitch_odd":   # chroma byte of a pair, mid line
        wave_l = href_glitch(wave_l, 1, 2, 21)
    elif kind == "vsync_in_line":
        wave_l = vsync_in_line(wave_l, 1, 2, 10)
    elif kind == "stop_leading":
        wave_l = stop_frame(wave_l, 1)
    elif kind == "stop_lagging":
        wave_r = stop_frame(wave_r, 1)
    elif kind == "reset":
        reset_at = wave_l.cycle(1, 4) * CAM_NS
    return cams_l, cams_r, wave_l, wave_r, reset_at


# damaged frame 1 -> what comes out ("1!p": aborted after its first p pixels, no
# padding, no flush); the next frame (2) is always complete and bit-exact again
FAULTS = {
    "cut_frame": [0, f"1!{3 * W}", 2, 3],                 # lines 0-2 got through
    "href_glitch": [0, f"1!{H * W - 1}", 2, 3],           # last pixel lost
    "href_glitch_odd": [0, f"1!{2 * W + 10}", 2, 3],      # pixel 10 of line 2 lost
    "vsync_in_line": [0, f"1!{2 * W + 5}", 2, 3],         # bytes 10-12 of line 2 lost
    "stop_leading": [0, 2, 3],
    "stop_lagging": [0, 2, 3],
    "reset": [0, 2, 3],
}


@pytest.mark.parametrize("kind", list(FAULTS))
def test_stereo_fault_resynchronises_next_frame(kind):
    cams_l, cams_r, wave_l, wave_r, reset_at = _fault_case(kind)
    beats, counters = _run_stereo(wave_l, wave_r, reset_at_ns=reset_at,
                                  fifo_depth=256, threshold=16, max_skew=96)
    frames = _split(beats)
    expected = FAULTS[kind]
    assert _identify(frames, cams_l, cams_r) == expected
    aborted = sum(isinstance(k, str) for k in expected)
    if kind == "reset":
        assert any(b[0] == "reset" for b in beats)
        # counters restart with the reset: frames 2 and 3 after it
        assert counters["frames"] == 2 and counters["faults"] == 0
    else:
        # frames counts completed frames only
        assert counters["frames"] == len(expected) - aborted
        assert counters["faults"] == aborted
    if kind.startswith("stop"):
        assert counters["stale"] == 1
    assert counters["overruns"] == [0, 0]


# cameras at full rate (short blanking, one word every two PCLK cycles most of the
# time), 6 PCLK cycles apart, behind 16-word FIFOs
FAST = CameraTiming(vsync_cycles=20, front_porch=4, hblank=4, back_porch=10)


@pytest.mark.parametrize("cut, overruns", [("leading", [0, 1]), ("lagging", [1, 0])],
                         ids=["cut_leading", "cut_lagging"])
def test_stereo_abort_keeps_next_frame_with_small_fifo(cut, overruns):
    """Why an aborted frame is not padded: frame 1 of one camera is cut after 3 lines
    and the 16-word FIFOs cannot hold the other camera's rest of frame 1 (72 words),
    so that camera overruns on frame 1 (harmless: its capture restarts at frame 2).

    * cut leading (left) camera: the cut shows when its frame-2 ``sof`` arrives.
      Padding the 72 missing pixels took 72 ``sync`` clocks, in which it wrote 18+
      words of frame 2 into its FIFO: it overran and frame 2 was lost as well.
    * cut lagging (right) camera: the left FIFO, full of frame-1 words, faces an
      empty one; unless that aborts the frame at once, the left frame-2 ``sof``
      meets a full FIFO (the right frame-2 ``sof`` comes 6 cycles later) and
      frame 2 is lost.

    Now frame 2 is paired at once and bit-exact in both cases."""
    cams_l, cams_r = _frames(4, 11), _frames(4, 12)
    wave_l = camera_waveform(cams_l, FAST, start_delay=0)
    wave_r = camera_waveform(cams_r, FAST, start_delay=6)
    if cut == "leading":
        wave_l = cut_frame(wave_l, 1, 3)
    else:
        wave_r = cut_frame(wave_r, 1, 3)
    beats, counters = _run_stereo(wave_l, wave_r, fifo_depth=16, threshold=4, max_skew=8)
    assert _identify(_split(beats), cams_l, cams_r) == [0, f"1!{3 * W}", 2, 3]
    assert counters["frames"] == 3 and counters["faults"] == 1
    assert counters["stale"] == 0 and counters["overruns"] == overruns


def test_domain_renaming_reaches_every_register():
    """After DomainRenamer, each capture (its start/pause synchronisers included) is
    clocked by its camera's PCLK only, and the synchroniser's own logic by ``sync``."""
    import re
    from amaranth.back import rtlil
    top = _StereoTop(fifo_depth=16, threshold=4)
    ports = [*top.pins, top.start, top.pause, top.sync.o_stream.valid,
             *[cd.clk for cd in top.domains], *[cd.rst for cd in top.domains]]
    text = rtlil.convert(top, ports=ports)
    clocks = {}
    for module in text.split("\nmodule ")[1:]:
        name = module.split("\n")[0].strip().lstrip("\\")
        clocks[name] = set(re.findall(r"connect \\CLK \\?(\S+)", module))
    for side in ("left", "right"):
        for sub in ("", ".start_sync", ".pause_sync"):
            assert clocks[f"top.capture_{side}{sub}"] == {f"cam_{side}_clk"}
    assert clocks["top.sync"] == {"clk"}


@pytest.mark.parametrize("make, name", [
    (lambda: StereoSynchronizer(18, 4, fifo_depth=100), "fifo_depth must be a power of two"),
    (lambda: StereoSynchronizer(16, 4, fifo_depth=8), "fifo_depth"),
    (lambda: StereoSynchronizer(16, 4, fifo_depth=1 << 17), "fifo_depth"),
    (lambda: StereoSynchronizer(16, 4, threshold=0), "threshold"),
    (lambda: StereoSynchronizer(16, 4, threshold=65), r"threshold must be in \[1, 64\]"),
    (lambda: StereoSynchronizer(64, 64, fifo_depth=16, threshold=17), r"\[1, 16\]"),
    (lambda: StereoSynchronizer(16, 4, max_skew=0), "max_skew"),
    (lambda: StereoSynchronizer(16, 4, fifo_depth=32, threshold=8, max_skew=33), "max_skew"),
    (lambda: StereoSynchronizer(16, 4, flush=-1), "flush"),
    (lambda: StereoSynchronizer(16, 4, flush=(1 << 20) + 1), "flush"),
    (lambda: StereoSynchronizer(15, 4), "width must be even"),
    (lambda: StereoSynchronizer(16, 4, left_domain=""), "left_domain"),
    (lambda: StereoSynchronizer(16, 4, right_domain=3), "right_domain"),
])
def test_bad_parameters_raise_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()
