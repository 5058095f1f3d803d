"""Rendered postures as a DATA.npz of pictures (:mod:`recognition.posture`):
each person (seed) holds each posture still in front of the chest, and the
frame goes through the golden model of the whole pipeline as a still hand in
a stream (:func:`present_still`).

Per picture the file keeps ``image``, the left camera's view about the hand
as RGB; ``mask``, the pipeline's posture mask there (skin AND the disparity
band after the 3x3 opening, within the hand tracking's window in the hard
scene); and ``features``, those of the frame's posture record as the board
decodes it, which the training and scoring use (a photo has no disparity and
no record; a rendered frame has both). ``subject`` is the person's seed, so
that people are held out whole.
"""
from __future__ import annotations

import numpy as np

__all__ = ["render_postures", "posture_still", "present_still", "STILL_FRAMES", "CROP_SHARE"]

#: Frames a still hand is presented for: the first has no previous centroid
#: (no hand tracking's window, the descriptor's reference empty), the second is
#: windowed about the first's centroid, the third about its own; the
#: reference, predicted from two frames' references, is then the fourth's own
#: and the fifth is a still hand in a stream.
STILL_FRAMES = 5
#: The picture's side as a share of the frame's height (the rendered hand with
#: its fingers spread and a roll fits in it).
CROP_SHARE = 0.4


def posture_still(name: str, seed: int, *, width: int = 640, height: int = 480,
                  scene: str = "easy"):
    """The person of ``seed`` holding posture ``name`` still in front of the
    chest in ``scene`` (:data:`sim.difficulties.SCENES`): the scene and the
    pipeline parameters its frames go through (the demo's for the frame size,
    hand tracking in the hard scene)."""
    from sim.difficulties import preset
    from sim.model.pipeline import PipelineParams
    from sim.render import StereoScene
    person = StereoScene("stop", int(seed), width, height, posture=name, n_pre_rest=2,
                         n_motion=2, n_post_rest=0, difficulties=preset(scene, int(seed)))
    return person, PipelineParams.for_frame(width, hand_tracking=scene == "hard")


def present_still(left, right, params, frames: int = STILL_FRAMES):
    """The pipeline's golden model (:func:`sim.model.pipeline.process_frame`)
    on the same stereo frame ``frames`` times, each about the previous one's
    centroid and posture reference: the last frame's stages."""
    from sim.model.pipeline import process_frame
    stages = None
    for _ in range(frames):
        stages = process_frame(left, right, params,
                               **({} if stages is None else stages.following()))
    return stages


def render_postures(postures, seeds, *, width: int = 640, height: int = 480,
                    scene: str = "easy", progress=None) -> dict:
    """The arrays of a DATA.npz: ``image`` (N, S, S, 3) uint8, ``mask`` (N, S,
    S) bool (the posture mask), ``features`` (N, FEATURES) (the posture
    record's), ``label`` (indices of ``class_names`` = ``postures``),
    ``subject`` (the seeds), one picture per (seed, posture), S =
    :data:`CROP_SHARE` of ``height``.

    The frame is the scene's first (the hand at rest), presented to the
    pipeline's golden model (the demo's parameters for the frame size, hand
    tracking in the hard scene) by :func:`present_still`.
    """
    from sim.footage import frame_to_bgr
    from sim.hand_postures import resolve_hand
    from sw_hps.posture import decode_posture_words, record_features
    names = [resolve_hand(p) for p in postures]
    side = int(round(CROP_SHARE * height)) // 2 * 2
    images, masks, features, labels, subjects = [], [], [], [], []
    for done, seed in enumerate(seeds):
        for label, name in enumerate(names):
            person, params = posture_still(name, seed, width=width, height=height,
                                           scene=scene)
            left, right = person.stereo_frame(0)
            stages = present_still(left, right, params)
            cx, cy = (int(v) for v in person.hand_anchor[0])
            x0 = min(max(cx - side // 2, 0), width - side)
            y0 = min(max(cy - side // 2 - side // 8, 0), height - side)   # fingers above
            window = (slice(y0, y0 + side), slice(x0, x0 + side))
            images.append(frame_to_bgr(left)[window][..., ::-1])
            masks.append(stages.posture_mask[window])
            features.append(record_features(decode_posture_words(stages.posture_words())))
            labels.append(label)
            subjects.append(int(seed))
        if progress is not None:
            progress(done + 1, len(seeds))
    return {"image": np.array(images, np.uint8), "mask": np.array(masks, bool),
            "features": np.array(features, float).reshape(len(labels), -1),
            "label": np.array(labels, np.int64), "class_names": np.array(names),
            "subject": np.array(subjects, np.int64)}
