"""Speed of the live view (stereogest/live.py, issue 15): frames per second of
:class:`stereogest.live.LiveSession` (every pixel stage of the golden model,
the tracker, the recogniser when a gesture ends, the nine JPEG pictures of the
page) on a rendered gesture at 320x240, against the target of 15 frames/s.

CPU seconds of this process (all threads) per frame, and frames per wall
second, for each number of stereo threads asked for; the machine is shared, so
the CPU figure is the one to compare.

Run: ``python benchmarks/bench_live.py [--frames N] [--width W --height H]``;
prints a table and a final JSON line.
"""
from __future__ import annotations

import argparse
import json
import time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=90, help="frames to process (>= 10)")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    args = ap.parse_args(argv)
    if args.frames < 10:
        ap.error(f"--frames must be at least 10, got {args.frames}")
    from sim.model.pipeline import PipelineParams
    from sim.render import render_clip
    from stereogest.pipeline_outputs import shipped_model_path
    from stereogest.live import LiveSession
    from sw_hps.hmm import load_models

    clip = render_clip("rotate-right", 1, args.width, args.height, n_pre_rest=10)
    models = load_models(shipped_model_path())
    params = PipelineParams.for_frame(args.width)
    frames = min(args.frames, clip.frames)
    result = {"width": args.width, "height": args.height, "frames": frames, "runs": {}}
    print(f"live session, rendered rotate-right at {args.width}x{args.height}, {frames} frames")
    for threads in (1, 2):
        session = LiveSession(params, models, threads=threads)
        session.step(clip.left[0], clip.right[0])          # imports, first allocations
        cpu, wall = time.process_time(), time.perf_counter()
        for n in range(1, frames):
            session.step(clip.left[n], clip.right[n])
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        run = {"cpu_seconds_per_frame": round(cpu / (frames - 1), 4),
               "frames_per_cpu_second": round((frames - 1) / cpu, 1),
               "frames_per_wall_second": round((frames - 1) / wall, 1)}
        result["runs"][threads] = run
        print(f"  stereo threads {threads}: {run['cpu_seconds_per_frame'] * 1000:.1f} CPU-ms "
              f"per frame ({run['frames_per_cpu_second']} frames per CPU-second), "
              f"{run['frames_per_wall_second']} frames per wall second", flush=True)
    best = max(r["frames_per_wall_second"] for r in result["runs"].values())
    result["target_frames_per_second"] = 15
    result["met"] = best >= 15
    print(f"target 15 frames/s: {'met' if result['met'] else 'NOT met'} ({best} at best)")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
