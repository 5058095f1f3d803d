"""End-to-end recognition figure (docs/design/soc.md): rendered clips of the seven
thesis gestures, each through the Verilated FPGA side and the unmodified board
application (what ``stereogest demo`` does for one clip), with seeds not used
in development (2001 onwards; the demo's default is seed 1; seeds 1-3 and
900-901 chose the frame size and the spotting hold; 1001-1005 showed the
split gestures that made us look at the hold, so they are not used either).

Every clip also checks the hardware against the golden model: the FIFO words
the application pops, the UART bytes against its telegram and the VGA frame.

Run: ``python benchmarks/demo_accuracy.py [--width 320 --height 240]
[--per-gesture 5] [--first-seed 2001] [--gesture NAME ...] [--jobs 2]
[--scheduler ADDRESS] [--json FILE] [--backend model] [--scene easy|hard]
[--difficulty NAME=VALUE ...] [--hand-tracking | --compare]``

``--scene`` and ``--difficulty`` (e.g. ``forearm=1``, ``motion_blur=0.5``) render
the clips with the scene difficulties of :mod:`sim.difficulties` (the person's
skin tone and hand size of ``hard`` come from each seed). Besides the
recognised fraction every clip reports the centroid error against the rendered
truth (mean and 95th percentile over the frames where both exist) and its
flagged spans (0: the gesture was missed, 2 or more: split).
(``--backend model``: the golden model, bit-exact with the hardware, instead of
Verilator). ``--hand-tracking`` runs the pipeline with the centroid's hand
tracking (:data:`sim.model.pipeline.HAND_TRACKING_640`); ``--compare`` (golden
model only) runs every clip once up to the opening and reports both centroids,
the thesis' and the hand tracking's. The clips run on ``--jobs`` local processes or, with
``--scheduler tcp://host:8786``, on the workers of a running Dask cluster; each
worker builds (or reuses, from its build cache) the Verilated system itself, so
remote workers need the project installed, not a shared disk. Prints a
Markdown table, the accuracy and the wall time, and a final JSON line.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import time
from contextlib import ExitStack
from pathlib import Path

import numpy as np

GESTURES = ("forward", "back", "right", "left", "rotate-right", "rotate-left", "stop")


def _models(path):
    from stereogest.pipeline_outputs import shipped_model_path
    from sw_hps.hmm import load_models
    return load_models(path or shipped_model_path())


def difficulties_of(scene, overrides, seed):
    """The clip's :class:`sim.difficulties.Difficulties`: the scene's preset for
    ``seed`` with ``overrides`` (name -> value) on top."""
    import dataclasses

    from sim.difficulties import preset
    return dataclasses.replace(preset(scene, seed), **dict(overrides))


def track_figures(clip, trajectory) -> dict:
    """Centroid error against the truth and the flagged spans of a clip."""
    from sim.evaluate import track_errors
    return track_errors(clip.hand_xy, trajectory)


def one_clip(job):
    """The rows of one clip: one per pipeline of ``tracking`` (False: the
    thesis', True: with hand tracking)."""
    gesture, seed, width, height, backend, model, scene, overrides, tracking = job
    difficulties = difficulties_of(scene, overrides, seed)
    if backend == "model":
        return model_clip(gesture, seed, width, height, model, difficulties, tracking)
    (hand_tracking,) = tracking
    from sim.model.pipeline import PipelineParams
    from sim.render import render_clip
    from verif.end_to_end import clip_end_to_end
    from verif.system import build_system

    models = _models(model)
    params = PipelineParams.for_frame(width, hand_tracking=hand_tracking)
    exe = build_system(width, height, params)     # cached: built once per machine
    start, cpu = time.perf_counter(), _cpu_seconds()
    clip = render_clip(gesture, seed, width, height, difficulties=difficulties)
    played, _, extra, result = clip_end_to_end(clip, models, params, threads=1, exe=exe)
    return [{"gesture": gesture, "seed": seed, "hand_tracking": hand_tracking,
             "frames": clip.frames, "held": extra,
            **track_figures(clip, _first(played, clip.frames)),
            "recognised": result.recognised,
            "all_recognised": [r.get("class_name") for r in result.results
                               if r.get("outcome") == "recognised"],
            "telegram": result.uart_bytes.hex(" "),
            "fifo_matches_model": result.fifo_matches_model,
            "vga_mismatches": result.vga_mismatches,
            "uart_matches_telegram": result.uart_matches_telegram,
            "cycles": result.cycles, "seconds": round(time.perf_counter() - start, 1),
            "cpu_seconds": round(_cpu_seconds() - cpu, 1)}]


def _cpu_seconds() -> float:
    """CPU seconds of this process and its finished children (the Verilated
    harness runs as one)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _first(trajectory, frames):
    """The trajectory's first ``frames`` frames (the hold-still frames left out)."""
    from sim.model.pipeline import Trajectory
    return Trajectory(*(None if getattr(trajectory, f) is None else getattr(trajectory, f)[:frames]
                        for f in Trajectory._fields))


def model_clip(gesture, seed, width, height, model=None, difficulties=None,
               tracking=(False,)):
    """The golden model instead of the hardware (bit-exact with it), the
    application on a simulated FIFO, as ``stereogest demo --backend model``; the
    clip runs once up to the opening, then through the centroid of each
    pipeline of ``tracking``."""
    from sim.model.centroid import centroid
    from sim.model.pipeline import PipelineParams, process_frame, track
    from sim.render import render_clip
    from sw_hps.simulated import run_on_trajectory

    models = _models(model)
    variants = [PipelineParams.for_frame(width, hand_tracking=t) for t in tracking]
    start, cpu = time.perf_counter(), _cpu_seconds()
    clip = render_clip(gesture, seed, width, height, difficulties=difficulties)
    centroids = [[] for _ in variants]
    for n in range(clip.frames):
        opened = process_frame(clip.left[n], clip.right[n], variants[0], threads=1).opened
        for params, found in zip(variants, centroids):
            found.append(centroid(opened, previous=found[-1] if found else None,
                                  track_gate=params.track_gate, hand_rows=params.hand_rows))
    seconds = round(time.perf_counter() - start, 1)
    cpu_seconds = round(_cpu_seconds() - cpu, 1)
    rows = []
    for hand_tracking, params, found in zip(tracking, variants, centroids):
        found = np.array(found, np.int64).reshape(-1, 3)
        trajectory = track(found[:, :2], found[:, 2], params)
        board = run_on_trajectory(models, trajectory.smoothed[:, 0], trajectory.smoothed[:, 1],
                                  trajectory.flag, pixels=False)
        rows.append({"gesture": gesture, "seed": seed, "hand_tracking": hand_tracking,
                     "frames": clip.frames, "held": 0,
                     **track_figures(clip, trajectory),
                     "recognised": board.recognised[-1] if board.recognised else None,
                     "all_recognised": board.recognised,
                     "telegram": board.telegrams[-1].hex(" ") if board.telegrams else "",
                     "fifo_matches_model": None, "vga_mismatches": None,
                     "uart_matches_telegram": None, "cycles": 0, "seconds": seconds,
                     "cpu_seconds": cpu_seconds})
    return rows


def _run(jobs, processes, scheduler):
    """Rows of :func:`one_clip` as they finish: local processes, or the workers
    of the Dask cluster at ``scheduler``."""
    if scheduler is None and processes == 1:
        yield from map(one_clip, jobs)          # in this process
        return
    if scheduler is None:
        with multiprocessing.get_context("fork").Pool(processes) as pool:
            yield from pool.imap_unordered(one_clip, jobs)
        return
    from recognition.crossval import dask_client
    with ExitStack() as stack:
        try:
            client = stack.enter_context(dask_client(scheduler))
        except ValueError as exc:           # the connection only, not the clips' errors
            raise SystemExit(f"demo_accuracy: --{exc}") from None
        from distributed import as_completed
        for future in as_completed(client.map(one_clip, jobs, pure=False)):
            yield future.result()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--per-gesture", type=int, default=5)
    ap.add_argument("--first-seed", type=int, default=2001)
    ap.add_argument("--gesture", action="append", choices=GESTURES,
                    help="only these gestures (repeatable; default all seven)")
    ap.add_argument("--jobs", type=int, default=2, help="local processes (default 2)")
    ap.add_argument("--scheduler", metavar="ADDRESS", default=None,
                    help="run the clips on a Dask cluster (tcp://host:8786) instead")
    ap.add_argument("--json", metavar="FILE", default=None)
    ap.add_argument("--model", metavar="MODEL.json", default=None,
                    help="board model file (default: the demo's, sw_hps/models/gestures7.json)")
    ap.add_argument("--backend", choices=("verilator", "model"), default="verilator",
                    help="model: the golden model only (minutes instead of hours)")
    ap.add_argument("--scene", choices=("easy", "hard"), default="easy",
                    help="scene difficulties (sim/difficulties.py)")
    ap.add_argument("--difficulty", action="append", default=[], metavar="NAME=VALUE",
                    help="one difficulty on top of the scene (repeatable), e.g. forearm=1")
    pipeline = ap.add_mutually_exclusive_group()
    pipeline.add_argument("--hand-tracking", action="store_true",
                          help="the centroid's hand tracking on (PipelineParams.for_frame)")
    pipeline.add_argument("--compare", action="store_true",
                          help="(--backend model) the thesis' centroid and the hand "
                               "tracking's on the same clips")
    args = ap.parse_args(argv)
    if args.compare and args.backend != "model":
        ap.error("--compare needs --backend model")
    from sim.difficulties import RANGES, SWITCHES
    overrides = []
    for item in args.difficulty:
        name, _, value = item.partition("=")
        if name in SWITCHES:
            if value not in ("0", "1"):
                ap.error(f"--difficulty {item}: {name} takes 0 or 1")
            overrides.append((name, value == "1"))
        elif name in RANGES:
            try:
                overrides.append((name, float(value)))
            except ValueError:
                ap.error(f"--difficulty {item}: {name} takes a number")
        else:
            ap.error(f"--difficulty {item}: no such difficulty (one of "
                     f"{', '.join((*RANGES, *SWITCHES))})")
    try:
        difficulties_of(args.scene, overrides, args.first_seed)
    except ValueError as exc:
        ap.error(f"--difficulty: {exc}")
    if args.jobs < 1 or args.per_gesture < 1:
        ap.error(f"--jobs and --per-gesture must be >= 1, got {args.jobs} and "
                 f"{args.per_gesture}")

    from sim.model.pipeline import PipelineParams
    from verif.system import build_system

    start = time.perf_counter()
    tracking = (False, True) if args.compare else (args.hand_tracking,)
    hardware = args.backend == "verilator"
    if hardware and args.scheduler is None:
        print(f"building the Verilated system at {args.width}x{args.height} ...", flush=True)
        build_system(args.width, args.height,
                     PipelineParams.for_frame(args.width, hand_tracking=args.hand_tracking))
    gestures = args.gesture or GESTURES
    jobs = [(g, args.first_seed + k, args.width, args.height, args.backend, args.model,
             args.scene, tuple(overrides), tracking)
            for k in range(args.per_gesture) for g in gestures]
    rows = []
    print("| gesture | seed | pipeline | frames | recognised | centroid error mean / p95 (px) "
          "| flagged spans | FIFO = model | VGA = model | UART = telegram | CPU s |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    for clip_rows in _run(jobs, args.jobs, args.scheduler):
        for row in clip_rows:
            rows.append(row)
            vga = None if row["vga_mismatches"] is None else row["vga_mismatches"] == 0
            checks = [row["fifo_matches_model"], vga, row["uart_matches_telegram"]]
            print(f"| {row['gesture']} | {row['seed']} | {_pipeline_name(row['hand_tracking'])} "
                  f"| {row['frames']}+{row['held']} | "
                  f"{row['recognised']} | {row['centroid_error_mean']} / "
                  f"{row['centroid_error_p95']} | {row['flag_spans']} | "
                  + " | ".join("-" if c is None else str(c) for c in checks)
                  + f" | {row['cpu_seconds']} |", flush=True)
    wall = time.perf_counter() - start
    summary = {"backend": args.backend, "width": args.width, "height": args.height,
               "scene": args.scene, "difficulties": dict(overrides),
               "clips": len(jobs), "cpu_seconds": round(sum(
                   r["cpu_seconds"] for r in rows if r["hand_tracking"] == tracking[0]), 1),
               "wall_seconds": round(wall, 1), "jobs": args.jobs,
               "scheduler": args.scheduler}
    print()
    for hand_tracking in tracking:
        mine = [r for r in rows if r["hand_tracking"] == hand_tracking]
        figures = summarise(mine, hardware)
        summary[_pipeline_name(hand_tracking)] = figures
        print(f"{_pipeline_name(hand_tracking)}: recognised {figures['correct']} of "
              f"{figures['clips']} clips ({100 * figures['accuracy']:.1f} %); centroid error "
              f"mean {figures['centroid_error_mean']} px, 95th percentile (mean over clips) "
              f"{figures['centroid_error_p95']} px; spotting: {figures['spotting']['missed']} "
              f"missed, {figures['spotting']['split']} split"
              + (f"; hardware = golden model on every clip: {figures['hardware_exact']}"
                 if hardware else ""))
    print(f"{'hardware and golden model' if hardware else 'golden model only'}; "
          f"{summary['cpu_seconds']} CPU s, wall time {wall / 60:.1f} min with "
          + (f"the cluster at {args.scheduler}" if args.scheduler else f"{args.jobs} jobs"))
    summary["rows"] = sorted(rows, key=lambda r: (GESTURES.index(r["gesture"]), r["seed"],
                                                  r["hand_tracking"]))
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=1) + "\n")
    print(json.dumps({k: v for k, v in summary.items() if k != "rows"}))
    return 0 if all(summary[_pipeline_name(t)]["accuracy"] == 1 for t in tracking) else 1


def _pipeline_name(hand_tracking: bool) -> str:
    return "hand tracking" if hand_tracking else "thesis"


def summarise(rows, hardware: bool) -> dict:
    """Recognised fraction, centroid error and spotting errors of some clips'
    rows (one pipeline's)."""
    correct = sum(r["recognised"] == r["gesture"] and r["all_recognised"] == [r["gesture"]]
                  for r in rows)
    means = [r["centroid_error_mean"] for r in rows if r["centroid_error_mean"] is not None]
    p95s = [r["centroid_error_p95"] for r in rows if r["centroid_error_p95"] is not None]
    return {"clips": len(rows), "correct": correct, "accuracy": correct / len(rows),
            "centroid_error_mean": round(float(np.mean(means)), 2) if means else None,
            "centroid_error_p95": round(float(np.mean(p95s)), 2) if p95s else None,
            "spotting": {"missed": sum(r["flag_spans"] == 0 for r in rows),
                         "split": sum(r["flag_spans"] > 1 for r in rows)},
            "hardware_exact": all(r["fifo_matches_model"] and r["vga_mismatches"] == 0
                                  and r["uart_matches_telegram"] for r in rows)
            if hardware else None}


if __name__ == "__main__":
    raise SystemExit(main())
