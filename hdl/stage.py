"""What every pixel stage of the pipeline declares about its timing and memory
(the stream convention in :mod:`hdl`), so that the pipeline adds them up
(:class:`hdl.gesture_pipeline.GesturePipeline`) and the benchmarks print them."""
from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

__all__ = ["PixelStage", "StageTiming"]


class StageTiming(NamedTuple):
    """``lag`` and ``cycles`` of a stage (see :class:`PixelStage`), computed from its
    parameters alone by the ``*_timing`` function beside each component, which
    the component itself uses: the figures without building hardware."""
    lag: int
    cycles: int


@runtime_checkable
class PixelStage(Protocol):
    """A component that emits one output beat per input beat.

    The window stages (:class:`~hdl.median3x3.Median3x3`,
    :class:`~hdl.stereo_matcher.StereoMatcher`, :class:`~hdl.opening.Opening`, ...)
    and the per-pixel ones (:class:`~hdl.ycbcr422.YCbCr422To444`,
    :class:`~hdl.segmentation.HandSegmentation`) all have these, as class or
    instance attributes fixed when the component is made.
    """

    @property
    def lag(self) -> int:
        """Beats of look-ahead: the output beat refers to the raster position
        ``lag`` beats before the input beat, so a frame needs ``lag`` flush beats
        after it (``r * width + r`` for a window of radius r; 0 per pixel)."""

    @property
    def cycles(self) -> int:
        """Clock cycles from an input beat to its output beat (idle gaps keep)."""

    @property
    def memory_bits(self):
        """Bits of memory the stage holds (row buffers, delay lines): an int, or
        a dict of named parts (the matcher)."""
