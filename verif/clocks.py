"""The clocks and camera drive shared by the Verilated harnesses
(:mod:`verif.pipeline`, :mod:`verif.system`): one description of the clock
periods and phases, one way to turn a clip into the two cameras' pin
waveforms.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Clocks", "clip_timing", "camera_waveforms", "LEFT_START_DELAY", "RIGHT_LAG"]

#: Camera cycles the left camera idles (VSYNC high) before its first frame...
LEFT_START_DELAY = 64
#: ...and how many more the right one does: the cameras are not in step.
RIGHT_LAG = 300


@dataclass(frozen=True)
class Clocks:
    """Clock periods and first rising edges in picoseconds.

    The pipeline runs at 100 MHz; the cameras' PCLK at twice that (one pixel
    per pipeline clock inside a line, YCbCr 4:2:2 being two bytes a pixel),
    the right camera's in antiphase to the left one's; all edges on a 2.5 ns
    grid, so a harness evaluates the model 4 times per pipeline cycle
    (arbitrary phases cost up to 10 evaluations). The whole system adds the
    configuration clock (50 MHz) and the VGA pixel clock (25 MHz, the PLL's
    output); the pipeline harness has neither.
    """
    sync_ps: int = 10_000
    left_ps: int = 5_000
    left_phase_ps: int = 0
    right_ps: int = 5_000
    right_phase_ps: int = 2_500
    config_ps: int = 20_000
    vga_ps: int = 40_000

    @property
    def sync_hz(self) -> float:
        return 1e12 / self.sync_ps

    def camera_args(self) -> list[str]:
        """The harnesses' command-line arguments for the pipeline and camera clocks."""
        return [str(v) for v in (self.sync_ps, self.left_ps, self.left_phase_ps, self.right_ps,
                                 self.right_phase_ps)]


def clip_timing(width: int, height: int, flush: int, clocks: Clocks = Clocks()):
    """Camera blanking for a clip run: vertical blanking long enough for the
    pipeline's flush (in camera cycles), short horizontal blanking."""
    from sim.camera import CameraTiming
    ratio = max(1, -(-clocks.sync_ps // min(clocks.left_ps, clocks.right_ps)))
    vblank = flush * ratio + 2 * width * ratio + 64
    return CameraTiming(vsync_cycles=64, front_porch=vblank // 2, hblank=max(16, width // 8),
                        back_porch=vblank // 2)


def camera_waveforms(left_frames, right_frames, timing):
    """The two cameras' pin waveforms (:func:`sim.camera.camera_waveform`) of a
    clip, the right camera starting :data:`RIGHT_LAG` cycles after the left."""
    from sim.camera import camera_waveform
    return (camera_waveform(list(left_frames), timing, start_delay=LEFT_START_DELAY),
            camera_waveform(list(right_frames), timing,
                            start_delay=LEFT_START_DELAY + RIGHT_LAG))
