"""Scene difficulties of the renderer (issue 18): what real footage does to the
thesis' method and the easy scene never does. Each is off (0 / False) by
default, so a scene without them is bit for bit the easy one.

=================  ================  =================================================
option             range             what it does
=================  ================  =================================================
exposure_drift     0 .. 0.5          each camera's gain wanders slowly (one period over
                                     the clip, its own phase): Y' = g(n) Y with
                                     g = 1 +- exposure_drift (auto-exposure at work)
flicker            0 .. 0.2          and jitters frame by frame, uniform in +-flicker,
                                     independently per camera (mains flicker)
motion_blur        0 .. 1            the shutter is open for this fraction of the frame
                                     interval: the hand is averaged over its path around
                                     the frame time (truth: the hand at the frame time)
skin_tone          -1 .. 1           the hand's Cb/Cr moved from the default tone
                                     (Cb 104, Cr 153) towards the thesis' box edges:
                                     -1 at (79, 135), +1 at (125, 171), both just inside
                                     Cb 77..127, Cr 133..173; its texture keeps some
                                     pixels beyond the edge
misaligned         True / False      the cameras of :class:`sim.calibration.StereoRig`
                                     (lens distortion, under a degree of roll, pitch and
                                     yaw, principal points apart) see the scene; truth
                                     stays in the rectified (rendered) frame, which
                                     ``--calibration`` with that rig's calibration
                                     restores
=================  ================  =================================================
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from sim.model.validation import check_number

__all__ = ["Difficulties", "RANGES", "SKIN_TONE_EDGES", "camera_gains"]

#: Allowed range of each numeric difficulty.
RANGES = {"exposure_drift": (0.0, 0.5), "flicker": (0.0, 0.2), "motion_blur": (0.0, 1.0),
          "skin_tone": (-1.0, 1.0)}
#: Hand (Cb, Cr) at skin_tone -1, 0 and +1.
SKIN_TONE_EDGES = {-1: (79.0, 135.0), 0: (104.0, 153.0), 1: (125.0, 171.0)}


@dataclass(frozen=True)
class Difficulties:
    """The scene difficulties (module docstring); validated on construction."""
    exposure_drift: float = 0.0
    flicker: float = 0.0
    motion_blur: float = 0.0
    skin_tone: float = 0.0
    misaligned: bool = False

    def __post_init__(self):
        for name, (lo, hi) in RANGES.items():
            object.__setattr__(self, name, check_number(name, getattr(self, name), lo, hi))
        if not isinstance(self.misaligned, bool):
            raise ValueError(f"misaligned must be True or False, got {self.misaligned!r}")

    @property
    def any(self) -> bool:
        """Whether any difficulty is on (else the scene is the easy one)."""
        return any(getattr(self, f.name) for f in fields(self))

    def as_dict(self) -> dict:
        return asdict(self)

    def skin_chroma(self) -> tuple[float, float]:
        """The hand's base (Cb, Cr) for :attr:`skin_tone`."""
        t = self.skin_tone
        edge = SKIN_TONE_EDGES[1 if t >= 0 else -1]
        base = SKIN_TONE_EDGES[0]
        return tuple(b + abs(t) * (e - b) for b, e in zip(base, edge))


def camera_gains(difficulties: Difficulties, frames: int, rng: np.random.Generator):
    """(2, frames) gains of the left and right cameras' Y: a slow drift of
    amplitude ``exposure_drift`` (one period over the clip, a seeded phase per
    camera) times a per-frame flicker uniform in ``+-flicker``."""
    gains = np.ones((2, frames))
    n = np.arange(frames)
    for camera in range(2):
        phase = rng.uniform(0, 2 * math.pi)
        drift = difficulties.exposure_drift * np.sin(2 * math.pi * n / max(frames, 1) + phase)
        jitter = rng.uniform(-1, 1, frames) * difficulties.flicker
        gains[camera] = (1 + drift) * (1 + jitter)
    return gains
