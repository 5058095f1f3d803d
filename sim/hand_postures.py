"""The rendered hand's postures (thesis §10.1, future work: "the configuration
of the hand"): which fingers are extended or curled, where the thumb is, how
far the fingers spread.

The ten ASL digits of the real photos (``asl0`` .. ``asl9``) and ``fist``;
``open``, ``point`` and ``v`` are other names of ``asl5``, ``asl1`` and
``asl2``. The renderer (:class:`sim.render.StereoScene`) draws a posture with
the person's own palm size, finger length and width and skin tone, a roll of
the whole hand and small changes from frame to frame.
"""
from __future__ import annotations

from typing import NamedTuple

__all__ = ["FINGERS", "HandPosture", "POSTURES", "POSTURE_NAMES", "POSTURE_ALIASES",
           "DEFAULT_POSTURE", "COMMAND_POSTURE", "OTHER_HANDS", "HAND_SHAPES",
           "HAND_SHAPE_NAMES", "resolve_posture", "resolve_hand", "extended_fingers",
           "ROLL_RANGE"]

#: The four fingers in order across the palm (thumb apart).
FINGERS = ("index", "middle", "ring", "little")
#: Largest roll of the hand a scene draws (degrees either way).
ROLL_RANGE = (-30, 30)


class HandPosture(NamedTuple):
    """How a hand is held.

    ``extension`` per finger of :data:`FINGERS`: 1 straight, about 0.25 curled
    into the palm (a knuckle shows above it), between: bent towards the thumb.
    ``thumb``: ``"out"`` (to the side), ``"in"`` (folded across the palm), or
    the finger whose tip it touches (``"index"`` .. ``"little"``).
    ``spread``: how far the fingertips fan out (1.25 is the open hand's).
    """

    extension: tuple
    thumb: str
    spread: float


#: The postures, by name (the digits as the real photos show them).
POSTURES = {
    "asl0": HandPosture((0.55, 0.55, 0.55, 0.5), "index", 0.7),
    "asl1": HandPosture((1.0, 0.25, 0.25, 0.25), "in", 1.25),
    "asl2": HandPosture((1.0, 1.0, 0.25, 0.25), "in", 1.7),
    "asl3": HandPosture((1.0, 1.0, 0.25, 0.25), "out", 1.6),
    "asl4": HandPosture((1.0, 1.0, 1.0, 1.0), "in", 1.3),
    "asl5": HandPosture((1.0, 1.0, 1.0, 1.0), "out", 1.6),
    "asl6": HandPosture((1.0, 1.0, 1.0, 0.3), "little", 1.5),
    "asl7": HandPosture((1.0, 1.0, 0.3, 1.0), "ring", 1.5),
    "asl8": HandPosture((1.0, 0.3, 1.0, 1.0), "middle", 1.5),
    "asl9": HandPosture((0.35, 1.0, 1.0, 1.0), "index", 1.5),
    "fist": HandPosture((0.25, 0.25, 0.25, 0.25), "in", 1.0),
}
POSTURE_NAMES = tuple(POSTURES)
POSTURE_ALIASES = {"open": "asl5", "point": "asl1", "v": "asl2"}
#: What a clip without a named posture shows: the open hand (the renderer's
#: original hand, four fingers together and the thumb out).
DEFAULT_POSTURE = "asl5"
#: The posture ``stereogest render`` makes gestures in unless told otherwise:
#: the shipped continuous model's first command posture (a test keeps them
#: equal).
COMMAND_POSTURE = "asl1"
#: Hands that are no posture class: what a hand does between commands
#: (:mod:`sim.distractors`): loosely bent fingers, fingers curled apart to
#: scratch, fingers and thumb closing round a cup.
OTHER_HANDS = {
    "relaxed": HandPosture((0.8, 0.72, 0.66, 0.6), "out", 1.15),
    "claw": HandPosture((0.6, 0.6, 0.6, 0.6), "out", 1.35),
    "grasp": HandPosture((0.5, 0.5, 0.5, 0.45), "out", 0.9),
}
#: Every hand the renderer draws, by name.
HAND_SHAPES = {**POSTURES, **OTHER_HANDS}
HAND_SHAPE_NAMES = tuple(HAND_SHAPES)


def resolve_posture(name) -> str:
    """The posture's name in :data:`POSTURE_NAMES` (aliases resolved).

    Raises
    ------
    ValueError
        Naming the allowed postures.
    """
    if isinstance(name, str):
        name = POSTURE_ALIASES.get(name, name)
        if name in POSTURES:
            return name
    raise ValueError(f"posture must be one of {', '.join(POSTURE_NAMES + tuple(POSTURE_ALIASES))}"
                     f", got {name!r}")


def resolve_hand(name) -> str:
    """The hand's name in :data:`HAND_SHAPE_NAMES` (a posture's aliases resolved);
    ``ValueError`` naming them."""
    if isinstance(name, str) and name in OTHER_HANDS:
        return name
    try:
        return resolve_posture(name)
    except ValueError:
        raise ValueError(f"hand must be one of "
                         f"{', '.join(HAND_SHAPE_NAMES + tuple(POSTURE_ALIASES))}, "
                         f"got {name!r}") from None


def extended_fingers(name: str) -> int:
    """Fingers held out (0-5, thumb included when it is out) of a posture or
    another hand of :data:`HAND_SHAPES`."""
    posture = HAND_SHAPES[resolve_hand(name)]
    return sum(e >= 0.9 for e in posture.extension) + (posture.thumb == "out")
