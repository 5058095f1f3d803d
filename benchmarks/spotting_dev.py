"""Choosing the continuous spotter's options on development seeds: rendered
sessions (scene seeds ``--seed`` onwards, never the benchmark's 500 onwards)
and clips of distractors alone (``--idle-seed`` onwards) go once through the
golden model of the whole pipeline and the shipped posture classifier; each
clip's records, postures and truth are kept in ``--cache`` (one ``.npz`` per
clip), so that spotting variants (``--set KEY=VALUE`` on the model's
``spotting`` or ``postures`` entry) are judged in seconds. Prints F1, the
false commands and every error: what was named where, against the truth and
the distractor it overlapped (and the posture that distractor was made in).
A kept clip is not rendered again: delete the cache when the pipeline, the
renderer or the models' command posture change.

Run: ``python benchmarks/spotting_dev.py [--sessions 10] [--idle-clips 6]
[--width 640 --height 480] [--set postures.release_frames=3 ...] [--json FILE]``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _cached(path: Path, render, posture_model, params):
    """The clip's records, postures and truth, rendered and run once."""
    from sim.model.pipeline import run_clip
    from stereogest.pipeline_outputs import frame_postures
    if path.exists():
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
        return json.loads(str(data.pop("truth"))), data
    clip = render()
    trajectory, _ = run_clip(clip.left, clip.right, params)
    postures = frame_postures(posture_model, trajectory)
    truth = {"sequence": [list(s) for s in clip.sequence],
             "distractors": [list(d) for d in clip.distractors or ()],
             "postures": list(clip.postures) if clip.postures else [],
             "frames": int(clip.frames)}
    data = {"smoothed": np.asarray(trajectory.smoothed, np.int64),
            "area": np.asarray(trajectory.area, np.int64),
            "postures": np.array([p or "" for p in postures])}
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_suffix(".part.npz")        # a clip is kept whole or not at all
    np.savez_compressed(part, truth=json.dumps(truth), **data)
    part.replace(path)
    return truth, data


def _spot(models, data, width):
    from types import SimpleNamespace

    from stereogest.pipeline_outputs import stream_results
    trajectory = SimpleNamespace(smoothed=data["smoothed"], area=data["area"])
    postures = [p or None for p in data["postures"].tolist()]
    return stream_results(models, trajectory, width, postures=postures)


def _set(models, assignments):
    """``models`` with ``KEY=VALUE`` (``spotting.X`` or ``postures.X``) applied."""
    import dataclasses

    from sw_hps.continuous import check_spotting
    from sw_hps.posture_commands import check_posture_commands
    spotting = dict(models.spotting)
    postures = dict(models.postures) if models.postures else None
    for item in assignments:
        key, _, text = item.partition("=")
        entry, _, name = key.partition(".")
        if entry not in ("spotting", "postures") or not name:
            raise ValueError(f"{key!r} must be spotting.OPTION or postures.OPTION")
        try:
            value = json.loads(text)
        except ValueError:
            raise ValueError(f"{item!r}: the value must be JSON (5, 0.5, [\"asl0\"])") \
                from None
        if entry == "spotting":
            spotting[name] = value
        elif postures is None:
            raise ValueError(f"{key!r}: the model has no postures entry")
        else:
            postures[name] = value
    return dataclasses.replace(models, spotting=check_spotting(spotting),
                               postures=check_posture_commands(postures))


def main(argv=None) -> int:
    from sim.difficulties import preset
    from sim.gesture_shapes import GESTURE_NAMES
    from sim.model.pipeline import PipelineParams
    from sim.render import HEIGHT_RANGE, WIDTH_RANGE, render_sequence
    from types import SimpleNamespace

    from recognition.continuous import match_detections
    from stereogest.pipeline_outputs import (command_posture, load_models_with_postures,
                                             sequence_score)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sessions", type=int, default=10)
    ap.add_argument("--per-session", type=int, default=8)
    ap.add_argument("--seed", type=int, default=300)
    ap.add_argument("--idle-clips", type=int, default=6)
    ap.add_argument("--idle-frames", type=int, default=600)
    ap.add_argument("--idle-seed", type=int, default=330)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--scene", choices=("easy", "hard"), default="easy")
    ap.add_argument("--model", default=None)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--only", default=None, help="render these clips only: s300,i330,...")
    ap.add_argument("--cache", default=str(ROOT / "build" / "spotting_dev"))
    ap.add_argument("--quiet", action="store_true", help="no error list")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    for option, value, lo, hi in (("--sessions", args.sessions, 0, 100),
                                  ("--per-session", args.per_session, 1, 100),
                                  ("--idle-clips", args.idle_clips, 0, 100),
                                  ("--idle-frames", args.idle_frames, 100, 3000)):
        if not lo <= value <= hi:
            ap.error(f"{option} must be in {lo}..{hi}, got {value}")
    for option, value, (lo, hi) in (("--width", args.width, WIDTH_RANGE),
                                    ("--height", args.height, HEIGHT_RANGE)):
        if value % 2 or not lo <= value <= hi:
            ap.error(f"{option} must be even, in {lo}..{hi} (the renderer's), got {value}")
    clips = {f"s{args.seed + k}" for k in range(args.sessions)} | \
        {f"i{args.idle_seed + k}" for k in range(args.idle_clips)}
    only = set(args.only.split(",")) if args.only else None
    if only is not None and only - clips:
        ap.error(f"--only: {', '.join(sorted(only - clips))} not among this run's clips "
                 "(sSEED for --seed .. --seed + --sessions - 1, iSEED for the idle clips)")
    try:
        params = PipelineParams.for_frame(args.width, hand_tracking=args.scene == "hard")
    except ValueError as exc:
        ap.error(f"--width: {exc}")
    models, posture_model = load_models_with_postures(args.model, "continuous", None)
    try:
        models = _set(models, args.set)
    except ValueError as exc:
        ap.error(f"--set: {exc}")
    command = command_posture((models, posture_model), args.width)
    cache = Path(args.cache) / f"{args.width}x{args.height}-{args.scene}"
    totals = dict(true=0, named=0, correct=0, false=0)
    errors, idle_false, idle_frames, latencies = [], 0, 0, []
    cpu = time.process_time()
    for k in range(args.sessions):
        seed = args.seed + k
        if only is not None and f"s{seed}" not in only:
            continue
        names = [str(n) for n in np.random.default_rng(seed).choice(GESTURE_NAMES,
                                                                     args.per_session)]
        truth, data = _cached(
            cache / f"s{seed}.npz",
            lambda: render_sequence(names, seed, args.width, args.height, pause=(0, 15),
                                    distractors=True, postures=[command] * len(names),
                                    command=command, difficulties=preset(args.scene, seed)),
            posture_model, params)
        results = _spot(models, data, args.width)
        score = sequence_score(results, [tuple(s) for s in truth["sequence"]])
        for key in totals:
            totals[key] += score[key]
        latencies += score["latencies"]
        # matched as the score matches them (recognition.continuous.match_detections)
        named = [r for r in results if r["outcome"] == "recognised"]
        matched, _ = match_detections(
            [SimpleNamespace(named_at=r["named_at"], **{k: r[k] for k in ("name", "first",
                                                                           "last")})
             for r in named], [(a, b) for _, a, b in truth["sequence"]],
            [g for g, _, _ in truth["sequence"]])
        for k, (g, a, b) in enumerate(truth["sequence"]):
            if k not in matched:
                near = [(r["name"], r["first"], r["last"]) for r in named
                        if r["first"] <= b and a <= r["last"]]
                errors.append(f"s{seed} missed {g} {a}-{b}: named over it {near}")
        for r, hit in zip(named, matched):
            if hit < 0:
                errors.append(f"s{seed} false {r['name']} {r['first']}-{r['last']} over "
                              f"{_describe(r, truth)}")
    for k in range(args.idle_clips):
        seed = args.idle_seed + k
        if only is not None and f"i{seed}" not in only:
            continue
        truth, data = _cached(
            cache / f"i{seed}.npz",
            lambda: render_sequence([], seed, args.width, args.height, pause=(0, 15),
                                    distractors=True, frames=args.idle_frames,
                                    difficulties=preset(args.scene, seed), command=command),
            posture_model, params)
        named = [r for r in _spot(models, data, args.width) if r["outcome"] == "recognised"]
        idle_false += len(named)
        idle_frames += truth["frames"]
        for r in named:
            errors.append(f"i{seed} false {r['name']} {r['first']}-{r['last']} over "
                          f"{_describe(r, truth)}")
    f1 = 2 * totals["correct"] / (totals["true"] + totals["named"]) \
        if totals["true"] + totals["named"] else 0.0
    report = {**totals, "f1": round(f1, 4), "idle_false": idle_false, "idle_frames": idle_frames,
              "latency_median": float(np.median(latencies)) if latencies else None,
              "latency_p95": float(np.percentile(latencies, 95)) if latencies else None,
              "set": args.set, "errors": errors,
              "cpu_s": round(time.process_time() - cpu, 1)}
    if not args.quiet:
        for line in errors:
            print(" ", line)
    print(f"F1 {100 * f1:.2f} % ({totals['correct']} of {totals['true']} right, "
          f"{totals['false']} false); distractors alone: {idle_false} in {idle_frames} frames; "
          f"latency median {report['latency_median']} p95 {report['latency_p95']}; "
          f"{' '.join(args.set) or 'as shipped'}; {report['cpu_s']} CPU s")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    return 0


def _describe(r, truth) -> str:
    """The distractors and gestures a false command overlapped, with the
    posture the truth says the hand held over most of it."""
    parts = []
    for kind, a, b in truth["distractors"]:
        if a <= r["last"] and r["first"] <= b:
            held = truth["postures"][a:b + 1] if truth["postures"] else []
            top = max(set(held), key=held.count) if held else "?"
            parts.append(f"{kind}[{a}-{b}, {top}]")
    for g, a, b in truth["sequence"]:
        if a <= r["last"] and r["first"] <= b:
            parts.append(f"gesture {g}[{a}-{b}]")
    return ", ".join(parts) or "pause"


if __name__ == "__main__":
    raise SystemExit(main())
