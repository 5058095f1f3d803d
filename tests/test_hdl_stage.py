# amaranth: UnusedElaboratable=no
"""hdl/stage.py: every pixel stage declares the PixelStage protocol, and the
``*_timing`` function beside each component gives, from its parameters alone,
the lag and cycles of the built component; the memory the stages declare (from
their memory functions) is the memory they build."""
import numpy as np
import pytest

from hdl.census import SparseCensus, census_timing
from hdl.column_sum import ColumnSum, column_sum_timing
from hdl.lrcc import LeftRightCheck, lrcc_timing
from hdl.median3x3 import Median3x3, median_timing
from hdl.morphology import BinaryMorphology, morphology_timing
from hdl.opening import Opening, opening_timing
from hdl.rectify import Rectifier, rectify_timing
from hdl.segmentation import HandSegmentation
from hdl.selectors import DisparitySelectors, selectors_timing
from hdl.shd import SumOfHammingDistances, shd_timing
from hdl.stage import PixelStage, StageTiming
from hdl.window import window_memory_bits
from hdl.stereo_matcher import StereoMatcher, matcher_timing
from hdl.window import WindowGenerator, window_timing
from hdl.window_sum import WindowSum, window_sum_timing
from hdl.ycbcr422 import YCbCr422To444
from sim.model.census import census_bits
from sim.model.rectify import identity_grid

W, H = 48, 12
CROSS5 = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool)

CASES = [
    (lambda: SparseCensus(width=W, height=H, census_window=5), census_timing(W, 5)),
    (lambda: ColumnSum(width=W, height=H, hamming_window=5, max_disparity=4, max_term=8),
     column_sum_timing(W, 5)),
    (lambda: WindowSum(width=W, height=H, hamming_window=7, max_disparity=4, max_term=40),
     window_sum_timing(7)),
    (lambda: SumOfHammingDistances(width=W, height=H, census_bits=census_bits(5),
                                   hamming_window=5, max_disparity=8),
     shd_timing(W, census_bits(5), 5)),
    (lambda: DisparitySelectors(width=W, height=H, max_disparity=8, cost_bits=10),
     selectors_timing(8)),
    (lambda: LeftRightCheck(width=W, height=H, max_disparity=8), lrcc_timing(8)),
    (lambda: Median3x3(width=W, height=H), median_timing(W)),
    (lambda: WindowGenerator(width=W, height=H, pixel_bits=8, window=7), window_timing(W, 7)),
    (lambda: BinaryMorphology(width=W, height=H, element="square", size=5),
     morphology_timing(W, np.ones((5, 5), bool))),
    (lambda: Opening(width=W, height=H, element=CROSS5), opening_timing(W, CROSS5)),
    (lambda: StereoMatcher(width=W, height=H, census_window=3, hamming_window=5,
                           max_disparity=8, external_flush=True), matcher_timing(W, 3, 5, 8)),
    (lambda: Rectifier(width=W, height=H, grid=identity_grid(W, H), lanes=3, max_shift_x=4,
                       max_shift_y=2), rectify_timing(W, 4, 2)),
    (lambda: StereoMatcher(width=W, height=H, census_window=3, hamming_window=5,
                           max_disparity=8, disparity_median=False, external_flush=True),
     matcher_timing(W, 3, 5, 8, disparity_median=False)),
]


@pytest.mark.parametrize("make, timing", CASES,
                         ids=[type(make()).__name__ + str(i) for i, (make, _) in enumerate(CASES)])
def test_timing_function_equals_the_built_stage(make, timing):
    stage = make()
    assert isinstance(timing, StageTiming)
    assert (stage.lag, stage.cycles) == tuple(timing)


@pytest.mark.parametrize("make", [case[0] for case in CASES] + [
    lambda: YCbCr422To444(width=W, height=H),
    lambda: HandSegmentation(width=W, height=H, max_disparity=8, band_low=2)])
def test_every_pixel_stage_declares_the_protocol(make):
    stage = make()
    assert isinstance(stage, PixelStage)
    assert stage.lag >= 0 and stage.cycles >= 1
    bits = stage.memory_bits
    assert isinstance(bits, (int, dict))


@pytest.mark.parametrize("make", [case[0] for case in CASES] + [
    lambda: HandSegmentation(width=W, height=H, max_disparity=8, band_low=2,
                             skin_delay_beats=100, skin_delay_cycles=5)])
def test_memory_bits_are_the_memories_built(make):
    """``memory_bits`` (computed from the stage's parameters: the children are
    built in ``elaborate``) adds up to the memories of the elaborated design."""
    from amaranth.back import rtlil

    from hdl.synthesis import component_ports
    from soc.resources import memory_bits
    stage = make()
    declared = stage.memory_bits
    total = sum(declared.values()) if isinstance(declared, dict) else declared
    built = memory_bits(rtlil.convert(stage, ports=component_ports(stage)))
    assert total == sum(built.values())
    if isinstance(stage, (WindowGenerator, Median3x3, SparseCensus)):
        assert total > 0


@pytest.mark.parametrize("window, pixel_bits, separation", [(1, 8, 0), (3, 8, 0), (7, 3, 0),
                                                           (5, 8, 5), (3, 1, 7), (7, 8, 3)])
def test_window_memory_bits_is_the_generator_s(window, pixel_bits, separation):
    """The formula against the memories the generator builds."""
    from amaranth.back import rtlil

    from hdl.synthesis import component_ports
    from soc.resources import memory_bits
    dut = WindowGenerator(width=W, height=H, pixel_bits=pixel_bits, window=window,
                          separation=separation)
    built = memory_bits(rtlil.convert(dut, ports=component_ports(dut)))
    assert window_memory_bits(W, window=window, pixel_bits=pixel_bits,
                              separation=separation) == sum(built.values())


def test_the_protocol_is_not_satisfied_by_anything():
    assert not isinstance(object(), PixelStage)


@pytest.mark.parametrize("make, timing", CASES,
                         ids=[type(make()).__name__ + str(i) for i, (make, _) in enumerate(CASES)])
def test_timing_function_equals_the_simulated_stage(make, timing):
    """The figures measured in Amaranth's simulator, not read back from the
    component: with no idle cycles, output beat 0 leaves ``cycles`` clock cycles
    after input beat 0, and the output beat marked ``first`` is number ``lag``."""
    from verif.streams import field, pack, run_stream
    stage = make()
    layout_in, layout_out = stage.i_stream.payload.shape(), stage.o_stream.payload.shape()
    beats = [pack(layout_in, {"first": 1})] + [0] * (W * H + timing.lag)
    cycles = []
    out = run_stream(stage, beats, out_cycles=cycles, extra_cycles=timing.cycles + 4)
    assert cycles[0] == timing.cycles
    assert list(field(layout_out, out, "first")).index(1) == timing.lag
