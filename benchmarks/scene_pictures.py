"""The pictures of the scene difficulties (docs/figures/scenes.md): for the easy
scene, each difficulty alone and the hard scene, one frame of a rendered
gesture a quarter into its motion: the left camera and the opening stage of
the golden model side by side (the cross: the centroid the pipeline finds).

Run: ``python benchmarks/scene_pictures.py [-o docs/difficulties] [--width 320
--height 240] [--gesture right --seed 2001]``; writes ``<name>.png`` per scene.
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

#: One picture each: the difficulty at a telling value.
ALONE = {"exposure_drift": 0.5, "flicker": 0.2, "motion_blur": 1.0, "skin_tone": 1.0,
         "hand_scale": 1.2, "forearm": True, "clutter": True, "intruder": True,
         "defocus": 2.0, "misaligned": True}


def scenes(seed: int) -> dict:
    from sim.difficulties import Difficulties, preset
    out = {"easy": Difficulties()}
    out.update({name: Difficulties(**{name: value}) for name, value in ALONE.items()})
    out["hard"] = preset("hard", seed)
    return out


def picture(gesture, seed, width, height, difficulties):
    from sim.model.pipeline import PipelineParams, process_frame
    from sim.model.ycbcr import ycbcr422_to_444
    from sim.pictures import stage_sheet
    from sim.render import StereoScene
    scene = StereoScene(gesture, seed, width, height, difficulties=difficulties)
    first, last = scene.motion_span
    frame = first + (last - first) // 4          # moving fast (the middle is the turn)
    inside = np.flatnonzero(scene.intruder_in_view)
    if inside.size:                      # a frame with the ball in view
        frame = int(inside[len(inside) // 2])
    left, right = scene.stereo_frame(frame)
    stages = process_frame(left, right, PipelineParams.for_frame(width))
    c = stages.centroid
    # the two panels of stage_sheet's picture, side by side instead of stacked
    sheet = stage_sheet(frame, {"left camera": ycbcr422_to_444(left)[0],
                                "opening": stages.opened},
                        centroid=None if c.area == 0 else (c.x, c.y))
    title, cell = 30, (sheet.shape[0] - 30) // 2
    top, bottom = sheet[title:title + cell], sheet[title + cell:title + 2 * cell]
    heading = np.full((title, 2 * sheet.shape[1], 3), sheet[0, -1], np.uint8)
    heading[:, :sheet.shape[1]] = sheet[:title]
    return np.concatenate([heading, np.concatenate([top, bottom], axis=1)], axis=0)


def main(argv=None) -> int:
    from sim.images import write_png
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(ROOT / "docs" / "difficulties"))
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--gesture", default="right")
    ap.add_argument("--seed", type=int, default=2001)
    args = ap.parse_args(argv)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    start = time.process_time()
    for name, difficulties in scenes(args.seed).items():
        write_png(out / f"{name}.png", picture(args.gesture, args.seed, args.width,
                                               args.height, difficulties))
        print(f"{name}: {dataclasses.asdict(difficulties)}", flush=True)
    print(f"{len(scenes(args.seed))} pictures in {out}, "
          f"{time.process_time() - start:.1f} CPU-s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
