"""Scene difficulties of the renderer: what real footage does to the
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
forearm            True / False      a bare forearm joined to the wrist, skin-coloured,
                                     its disparity sloping from the hand's - 1 at the
                                     wrist to the torso's + 1 at the elbow (below the
                                     chest), so part of it lies inside the band; a
                                     non-skin sleeve on its last third
clutter            True / False      skin-toned things in the room: a wooden board on
                                     the wall and a second person's face further back
                                     (both pass the Cb/Cr box, outside the band)
intruder           True / False      a skin-coloured ball at the hand's depth (its
                                     disparity - 2, inside the band) rolls into the
                                     picture and out again for a third of the clip,
                                     clear of the hand's path
defocus            0 .. 2            everything but the hand is blurred, sigma = defocus
                                     x |d - d_hand| / 10 px (the background most)
hand_scale         0.8 .. 1.2        the hand (and forearm) this much larger or smaller
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
from dataclasses import asdict, dataclass

import numpy as np

from sim.model.validation import check_number

__all__ = ["Difficulties", "RANGES", "SWITCHES", "SKIN_TONE_EDGES", "SCENES", "HARD",
           "HARD_PERSON", "preset", "camera_gains"]

#: Allowed range of each numeric difficulty.
RANGES = {"exposure_drift": (0.0, 0.5), "flicker": (0.0, 0.2), "motion_blur": (0.0, 1.0),
          "skin_tone": (-1.0, 1.0), "defocus": (0.0, 2.0), "hand_scale": (0.8, 1.2)}
#: The switches (True / False).
SWITCHES = ("forearm", "clutter", "intruder", "misaligned")
#: Hand (Cb, Cr) at skin_tone -1, 0 and +1.
SKIN_TONE_EDGES = {-1: (79.0, 135.0), 0: (104.0, 153.0), 1: (125.0, 171.0)}


@dataclass(frozen=True)
class Difficulties:
    """The scene difficulties (module docstring); validated on construction."""
    exposure_drift: float = 0.0
    flicker: float = 0.0
    motion_blur: float = 0.0
    skin_tone: float = 0.0
    forearm: bool = False
    clutter: bool = False
    intruder: bool = False
    defocus: float = 0.0
    hand_scale: float = 1.0
    misaligned: bool = False

    def __post_init__(self):
        for name, (lo, hi) in RANGES.items():
            object.__setattr__(self, name, check_number(name, getattr(self, name), lo, hi))
        for name in SWITCHES:
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be True or False, got {getattr(self, name)!r}")

    @property
    def any(self) -> bool:
        """Whether any difficulty is on (else the scene is the easy one)."""
        return self != Difficulties()

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


#: The scenes of ``--scene``: ``easy`` has no difficulty; ``hard`` has every
#: difficulty but the misalignment (which needs its calibration to be undone), with each
#: person's skin tone and hand size drawn from the seed (:func:`preset`).
SCENES = ("easy", "hard")
HARD = dict(exposure_drift=0.15, flicker=0.03, motion_blur=0.5, forearm=True, clutter=True,
            intruder=True, defocus=0.8)
#: The ranges the hard scene draws each person's skin tone and hand size from.
HARD_PERSON = {"skin_tone": (-0.8, 0.8), "hand_scale": (0.9, 1.1)}


def preset(scene: str, seed: int) -> Difficulties:
    """The difficulties of ``scene`` (:data:`SCENES`) for the person of ``seed``."""
    if scene not in SCENES:
        raise ValueError(f"scene must be one of {', '.join(SCENES)}, got {scene!r}")
    if scene == "easy":
        return Difficulties()
    rng = np.random.default_rng([int(seed), 18])
    person = {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in HARD_PERSON.items()}
    return Difficulties(**HARD, **person)
