"""Should the thesis' rest-gesture-rest loop use posture commands by default?
The shipped thesis model (``gestures7.json``) as it ships, and with the
shipped continuous model's ``postures`` entry added, on the same rendered
clips at 640x480 through the golden model of the whole pipeline and the board
application's thesis loop (:func:`stereogest.pipeline_outputs.board_results`,
with the posture slave simulated when the model has posture commands):

* ``--isolated N`` clips per gesture of one gesture between rests, made in
  the command posture (scene seeds 3001 onwards): named once and right;
* ``--idle-clips K`` clips of ``--idle-clip`` frames of distractors alone,
  their kinds' hands and a share in the command posture (scene seeds 3101
  onwards): every command named there (stops by posture included) is false.

Run: ``python benchmarks/thesis_postures.py [--isolated 2] [--idle-clips 3]
[--json FILE]``. Prints both rows and the CPU seconds.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

from sim.difficulties import preset
from sim.gesture_shapes import GESTURE_NAMES
from sim.model.pipeline import PipelineParams, run_clip
from sim.render import render_clip, render_sequence
from stereogest.pipeline_outputs import (board_results, load_models_with_postures,
                                         recognised_gestures)

ROOT = Path(__file__).resolve().parents[1]
ISOLATED_FIRST_SEED = 3001
IDLE_FIRST_SEED = 3101
WIDTH, HEIGHT = 640, 480


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--isolated", type=int, default=2, metavar="N",
                    help="clips per gesture of one gesture between rests (default 2)")
    ap.add_argument("--idle-clips", type=int, default=3, metavar="K",
                    help="clips of distractors alone (default 3)")
    ap.add_argument("--idle-clip", type=int, default=600, metavar="FRAMES",
                    help="frames per distractor clip (default 600 = 20 s)")
    ap.add_argument("--json", default=str(ROOT / "build" / "thesis_postures.json"))
    args = ap.parse_args(argv)
    for option, value, lo, hi in (("--isolated", args.isolated, 0, 100),
                                  ("--idle-clips", args.idle_clips, 0, 100),
                                  ("--idle-clip", args.idle_clip, 100, 3000)):
        if not lo <= value <= hi:
            ap.error(f"{option} must be in {lo}..{hi}, got {value}")
    plain, posture_model = load_models_with_postures(None, "thesis")
    postures = load_models_with_postures(None, "continuous")[0].postures
    gated = dataclasses.replace(plain, postures=postures)
    command = postures["command"][0]
    params = PipelineParams.for_frame(WIDTH)
    started = time.process_time()
    rows = {"as shipped": dict(right=0, clips=0, false=0), "with posture commands":
            dict(right=0, clips=0, false=0, stops=0)}

    def both(clip):
        trajectory, _ = run_clip(clip.left, clip.right, params)
        return {"as shipped": board_results(plain, trajectory),
                "with posture commands": board_results(gated, trajectory,
                                                       posture_model=posture_model)}

    for gesture in GESTURE_NAMES:
        for k in range(args.isolated):
            seed = ISOLATED_FIRST_SEED + k
            results = both(render_clip(gesture, seed, WIDTH, HEIGHT, posture=command,
                                       difficulties=preset("easy", seed)))
            named = {name: [e["name"] for e in recognised_gestures(entries)]
                     for name, entries in results.items()}
            for name, names in named.items():
                rows[name]["clips"] += 1
                rows[name]["right"] += names == [gesture]
            print(f"{gesture} (seed {seed}): "
                  + "; ".join(f"{name}: {names}" for name, names in named.items()), flush=True)
    for k in range(args.idle_clips):
        seed = IDLE_FIRST_SEED + k
        results = both(render_sequence([], seed, WIDTH, HEIGHT, pause=(0, 15), distractors=True,
                                       frames=args.idle_clip, difficulties=preset("easy", seed),
                                       command=command))
        named = {name: recognised_gestures(entries) for name, entries in results.items()}
        for name, commands in named.items():
            rows[name]["false"] += len(commands)
            if "stops" in rows[name]:
                rows[name]["stops"] += sum(bool(e.get("by_posture")) for e in commands)
        print(f"distractors (seed {seed}): " + "; ".join(
            f"{name}: {len(commands)} commands" for name, commands in named.items()), flush=True)
    minutes = args.idle_clips * args.idle_clip / 30 / 60
    for row in rows.values():
        row["false_per_10_min"] = round(10 * row["false"] / minutes, 1) if minutes else None
    report = {"width": WIDTH, "height": HEIGHT, "command_posture": command, "postures": postures,
              "isolated_per_gesture": args.isolated, "idle_minutes": round(minutes, 2),
              "rows": rows, "cpu_s": round(time.process_time() - started, 1)}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    for name, row in rows.items():
        print(f"{name}: {row['right']} of {row['clips']} isolated gestures named once and "
              f"right; {row['false']} commands in {minutes:.1f} minutes of distractors alone"
              + (f" ({row['stops']} stops by posture)" if "stops" in row else ""))
    print(f"{report['cpu_s']} CPU s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
