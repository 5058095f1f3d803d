"""Continuous spotting on rendered sessions (issue 28): ``--sessions`` clips of
``--per-session`` gestures in a random order, one after another with pauses
of 0-15 frames (:func:`sim.render.render_sequence`; scene seeds 500 onwards,
people the shipped model's corpus and the defaults' choice never saw), through
the golden model of the whole pipeline and the board's continuous spotting
(:func:`stereogest.pipeline_outputs.stream_results`, the code ``python -m
sw_hps --spotting continuous`` runs on each record), scored against each
clip's truth (:func:`stereogest.pipeline_outputs.sequence_score`).

``--distractors`` puts non-gesture motion (:mod:`sim.distractors`) before
every gesture; ``--idle-frames N`` also renders N frames of distractors only
(clips of at most ``--idle-clip`` frames, scene seeds 900 onwards) and counts
the commands named in them: the false commands per 10 minutes of motion that
is no gesture. ``--isolated N`` also runs the end-to-end figure's protocol
(one gesture between rests per clip, :mod:`benchmarks.demo_accuracy`'s seeds
2001 onwards, N per gesture) through the continuous spotting: a clip counts
when its gesture is named once and nothing else is. ``--scene hard`` renders every difficulty (and the pipeline
then tracks the hand, ``--hand-tracking``).

A model with a ``postures`` entry (:mod:`sw_hps.posture_commands`) gets each
frame's posture from the shipped posture classifier on the golden model's
posture records, as the board gets it from the posture slave: the gestures
are rendered in its first command posture and the distractors with their
kinds' hands, a share of them in that posture (:func:`sim.render.render_sequence`;
in frames narrower than :data:`sw_hps.posture_commands.MIN_FRAME_WIDTH`, where
the board sets the posture commands aside, in the open hand and none in it);
stops by posture count as commands. ``--stops N`` also renders N holds of
the stop posture between rests (scene seeds 700 onwards) and reports the
frames from the posture's first frame to the stop telegram.

Run: ``python benchmarks/continuous_sessions.py [--sessions 10] [--per-session 8]
[--width 320 --height 240] [--distractors] [--idle-frames 18000] [--scene hard]
[--model MODEL.json] [--json FILE]``. Prints the figures (and CPU seconds).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from sim.gesture_shapes import GESTURE_NAMES
from sim.model.pipeline import PipelineParams, run_clip
from sim.difficulties import preset
from sim.render import render_sequence
from stereogest.pipeline_outputs import (command_posture, frame_postures,
                                         load_models_with_postures, sequence_score,
                                         stream_results)

ROOT = Path(__file__).resolve().parents[1]
FIRST_SEED = 500
#: Scene seeds of the distractor-only clips.
FIRST_IDLE_SEED = 900


ISOLATED_FIRST_SEED = 2001
#: Scene seeds of the stop-posture holds.
FIRST_STOP_SEED = 700


def spot_rendered(render, models, params, width: int, cpu: dict):
    """``render()``'s clip through the golden model of the whole pipeline and the
    board's continuous spotting: ``(clip, results)``; the CPU seconds of each
    part are added to ``cpu``. ``models``: (gesture models, posture model);
    each frame's posture is given when the models have posture commands."""
    models, posture_model = models
    t = time.process_time()
    clip = render()
    cpu["render"] += time.process_time() - t
    t = time.process_time()
    trajectory, _ = run_clip(clip.left, clip.right, params)
    cpu["model"] += time.process_time() - t
    t = time.process_time()
    postures = frame_postures(posture_model, trajectory) \
        if models.postures is not None else None
    cpu["posture"] += time.process_time() - t
    t = time.process_time()
    results = stream_results(models, trajectory, width, postures=postures)
    cpu["spotting"] += time.process_time() - t
    return clip, results


def stop_holds(models, params, width: int, height: int, count: int, scene: str,
               cpu: dict) -> dict:
    """``count`` holds of the stop posture between rests in the command posture:
    the frames from the posture's first frame to the stop telegram, stops
    missed, and any other command named."""
    from sim.render import render_hold
    options = models[0].postures
    latencies, missed, other = [], 0, 0
    for k in range(count):
        seed = FIRST_STOP_SEED + k
        rng = np.random.default_rng(seed)
        hold = int(rng.integers(15, 46))
        clip, results = spot_rendered(
            lambda: render_hold(options["stop"], seed, width, height, before=20, hold=hold,
                                after=20, around=options["command"][0],
                                difficulties=preset(scene, seed)),
            models, params, width, cpu)
        stops = [r for r in results if r.get("by_posture")]
        other += len(results) - len(stops)
        if stops:
            latencies.append(stops[0]["named_at"] - clip.motion_frames[0])
        else:
            missed += 1
    print(f"stop holds: {count - missed} of {count} stopped, {other} other commands",
          flush=True)
    return {"holds": count, "stopped": count - missed, "other_commands": other,
            "latencies": latencies,
            "latency_median_frames": float(np.median(latencies)) if latencies else None,
            "latency_p95_frames": float(np.percentile(latencies, 95)) if latencies else None}


def isolated_clips(models, params, width: int, height: int, per_gesture: int, scene: str,
                   cpu: dict) -> dict:
    """Today's protocol (rest, one gesture, rest) through the continuous spotting."""
    from sim.render import render_clip
    right, rows = 0, []
    for gesture in GESTURE_NAMES:
        for k in range(per_gesture):
            seed = ISOLATED_FIRST_SEED + k
            _, results = spot_rendered(
                lambda: render_clip(gesture, seed, width, height,
                                    difficulties=preset(scene, seed),
                                    posture=command_posture(models, width)),
                models, params, width, cpu)
            named = [r["name"] for r in results]
            ok = named == [gesture]
            right += ok
            rows.append({"gesture": gesture, "seed": seed, "named": named, "right": ok})
    print(f"isolated clips: {right} of {len(rows)} named once and right", flush=True)
    return {"clips": len(rows), "right": right, "rows": rows}


def idle_commands(models, params, width: int, height: int, frames: int, clip_frames: int,
                  scene: str, cpu: dict) -> dict:
    """Commands named in ``frames`` frames of distractors only (no gesture: every
    one is a false command), rendered in clips of ``clip_frames``."""
    false, clips, kinds = 0, [], {}
    done = 0
    for k in range(-(-frames // clip_frames)):
        n = min(clip_frames, frames - done)
        seed = FIRST_IDLE_SEED + k
        clip, results = spot_rendered(
            lambda: render_sequence([], seed, width, height, pause=(0, 15), distractors=True,
                                    frames=n, difficulties=preset(scene, seed),
                                    command=command_posture(models, width)),
            models, params, width, cpu)
        named = [r for r in results if r["outcome"] == "recognised"]
        for r in named:     # which distractor (or pause) each false command overlapped
            hit = [kind for kind, a, b in clip.distractors if a <= r["last"] and r["first"] <= b]
            key = (hit[0] if hit else "pause") + (" (stop posture)" if r.get("by_posture")
                                                  else "")
            kinds[key] = kinds.get(key, 0) + 1
        false += len(named)
        done += n
        clips.append({"seed": seed, "frames": n, "false_commands": len(named),
                      "named": [{k: r[k] for k in ("name", "first", "last")} for r in named],
                      "distractors": [[kind, a, b] for kind, a, b in clip.distractors]})
        print(f"idle clip {k + 1} (seed {seed}, {n} frames): {len(named)} commands", flush=True)
    minutes = frames / 30 / 60
    return {"frames": frames, "minutes": round(minutes, 2), "false_commands": false,
            "false_commands_per_10_min": 10 * false / minutes, "by_distractor": kinds,
            "clips": clips}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sessions", type=int, default=10)
    ap.add_argument("--per-session", type=int, default=8)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--distractors", action="store_true",
                    help="non-gesture motion before every gesture")
    ap.add_argument("--idle-frames", type=int, default=0,
                    help="frames of distractors only (18000 = 10 minutes at 30 fps)")
    ap.add_argument("--idle-clip", type=int, default=900,
                    help="frames per distractor-only clip (memory)")
    ap.add_argument("--isolated", type=int, default=0, metavar="N",
                    help="also N clips per gesture of one gesture between rests")
    ap.add_argument("--scene", choices=("easy", "hard"), default="easy",
                    help="hard: every difficulty, with the pipeline's hand tracking")
    ap.add_argument("--stops", type=int, default=0, metavar="N",
                    help="also N holds of the stop posture (models with posture commands)")
    ap.add_argument("--model", default=None, help="default: sw_hps/models/continuous7.json")
    ap.add_argument("--posture-model", default=None,
                    help="default: sw_hps/models/posture.json")
    ap.add_argument("--json", default=str(ROOT / "build" / "continuous_sessions.json"))
    args = ap.parse_args(argv)
    for option, value, lo, hi in (("--sessions", args.sessions, 0, 1000),
                                  ("--per-session", args.per_session, 1, 100),
                                  ("--idle-frames", args.idle_frames, 0, 1_000_000),
                                  ("--idle-clip", args.idle_clip, 100, 100_000),
                                  ("--isolated", args.isolated, 0, 100),
                                  ("--stops", args.stops, 0, 1000)):
        if not lo <= value <= hi:
            ap.error(f"{option} must be in {lo}..{hi}, got {value}")
    models = load_models_with_postures(args.model, "continuous", args.posture_model)
    if args.stops and (models[0].postures is None or models[0].postures["stop"] is None):
        ap.error("--stops needs a model with a stop posture (its postures entry)")
    hard = args.scene == "hard"
    params = PipelineParams.for_frame(args.width, hand_tracking=hard)
    totals = dict(true=0, named=0, correct=0, false=0)
    latencies, between, frames, sessions = [], 0, 0, []
    cpu = {"render": 0.0, "model": 0.0, "posture": 0.0, "spotting": 0.0}
    for k in range(args.sessions):
        seed = FIRST_SEED + k
        rng = np.random.default_rng(seed)
        names = [str(n) for n in rng.choice(GESTURE_NAMES, args.per_session)]
        clip, results = spot_rendered(
            lambda: render_sequence(names, seed, args.width, args.height, pause=(0, 15),
                                    distractors=args.distractors,
                                    postures=[command_posture(models, args.width)]
                                    * len(names),
                                    command=command_posture(models, args.width),
                                    difficulties=preset(args.scene, seed)),
            models, params, args.width, cpu)
        score = sequence_score(results, clip.sequence)
        for key in totals:
            totals[key] += score[key]
        latencies += score["latencies"]
        inside = sum(b - a + 1 for _, a, b in clip.sequence)
        between += clip.frames - inside
        frames += clip.frames
        sessions.append({"seed": seed, "gestures": names, "frames": clip.frames,
                         **{key: score[key] for key in totals}})
        print(f"session {k + 1}/{args.sessions} (seed {seed}): {score['correct']} of "
              f"{score['true']} right, {score['false']} false", flush=True)
    precision = totals["correct"] / totals["named"] if totals["named"] else 0.0
    recall = totals["correct"] / totals["true"] if totals["true"] else 0.0
    f1 = 2 * totals["correct"] / (totals["true"] + totals["named"]) \
        if totals["true"] + totals["named"] else 0.0
    minutes = between / 30 / 60
    idle = idle_commands(models, params, args.width, args.height, args.idle_frames,
                         args.idle_clip, args.scene, cpu) if args.idle_frames else None
    isolated = isolated_clips(models, params, args.width, args.height, args.isolated,
                              args.scene, cpu) if args.isolated else None
    stops = stop_holds(models, params, args.width, args.height, args.stops, args.scene,
                       cpu) if args.stops else None
    report = {"sessions": sessions, "width": args.width, "height": args.height,
              "isolated": isolated, "stops": stops,
              "postures": models[0].postures,
              "distractors": args.distractors, "scene": args.scene, "idle": idle,
              **totals, "precision": precision, "recall": recall, "f1": f1,
              "frames": frames, "between_gesture_frames": between,
              "false_commands_per_10_min": 10 * totals["false"] / minutes if minutes else None,
              "latency_median_frames": float(np.median(latencies)) if latencies else None,
              "latency_p95_frames": float(np.percentile(latencies, 95)) if latencies else None,
              "cpu_s": {key: round(v, 1) for key, v in cpu.items()},
              "spotting_us_per_frame": round(1e6 * cpu["spotting"] / frames, 1)
              if frames else None}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    print(f"{args.sessions} rendered sessions of {args.per_session} gestures at "
          f"{args.width}x{args.height}, pauses 0-15 frames"
          f"{', distractors' if args.distractors else ''}, {args.scene} scene, "
          f"{frames} frames:")
    if args.sessions:
        print(f"  F1 {100 * f1:.2f} %  precision {100 * precision:.2f} %  recall "
              f"{100 * recall:.2f} %")
        print(f"  false commands {totals['false']} ({report['false_commands_per_10_min']:.1f} "
              f"per 10 minutes of the {between} frames outside the gestures' motion at 30 fps)")
        print(f"  latency from a gesture's end to its name: median "
              f"{report['latency_median_frames']} frames, 95th percentile "
              f"{report['latency_p95_frames']}")
    if isolated is not None:
        print(f"  isolated gestures between rests: {isolated['right']} of "
              f"{isolated['clips']} named once and right")
    if stops is not None:
        print(f"  stop posture held: {stops['stopped']} of {stops['holds']} stopped, latency "
              f"from its first frame median {stops['latency_median_frames']} frames, 95th "
              f"percentile {stops['latency_p95_frames']}; {stops['other_commands']} other "
              "commands")
    if idle is not None:
        print(f"  distractors only: {idle['false_commands']} commands in {idle['frames']} "
              f"frames ({idle['minutes']} minutes at 30 fps): "
              f"{idle['false_commands_per_10_min']:.1f} per 10 minutes; by distractor "
              f"{idle['by_distractor']}")
    print(f"  CPU s: {report['cpu_s']}; spotting {report['spotting_us_per_frame']} us per frame")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
