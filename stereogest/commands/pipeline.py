"""Run the golden model of the whole FPGA pipeline over a stereo clip (from
'stereogest render'): per frame, 4:2:2 to 4:4:4, median, stereo matching,
skin and disparity segmentation, opening and centroid; per clip, moving
average, gesture spotting and orientation symbols. Writes OUTDIR/trajectory.csv
and pictures of every stage for chosen frames."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

NAME = "pipeline"
HELP = "golden model of the FPGA pipeline over a clip: trajectory.csv and stage pictures"

STAGES = ("left", "right", "disparity", "skin", "band", "opening")


def add_arguments(p):
    p.add_argument("clip", metavar="CLIP", help="clip directory written by 'stereogest render'")
    p.add_argument("-o", "--output", metavar="OUTDIR", required=True,
                   help="output directory (created): trajectory.csv, stage pictures, summary.json")
    p.add_argument("--frames", metavar="LIST", default=None,
                   help="comma-separated frame numbers to draw stage pictures for "
                        "(default: a rest frame, the middle of the motion and its end)")
    p.add_argument("--threads", type=int, default=None,
                   help="worker threads for the stereo cost stage (default: CPUs, at most 4)")
    p.add_argument("--backend", choices=("model", "verilator"), default="model",
                   help="model: the numpy golden model (default); verilator: the Amaranth "
                        "GesturePipeline's Verilog under Verilator, fed the clip as camera "
                        "pin waveforms (same trajectory.csv; stage pictures from the model "
                        "backend only)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def parse_frames(text: str | None, frames: int, motion: tuple[int, int]) -> list[int]:
    if text is None:
        first, last = motion
        chosen = {max(0, first - 5), (first + last) // 2, min(frames - 1, last)}
        return sorted(chosen)
    try:
        chosen = sorted({int(tok) for tok in text.split(",") if tok.strip()})
    except ValueError:
        raise ValueError(f"--frames must be comma-separated integers, got {text!r}") from None
    bad = [n for n in chosen if not 0 <= n < frames]
    if bad:
        raise ValueError(f"--frames must be in [0, {frames - 1}], got {bad}")
    return chosen


def write_outputs(outdir: Path, clip, trajectory, kept, params, seconds: float) -> dict:
    """trajectory.csv, frame_NNNN_<stage>.png, trajectory.png, summary.json."""
    from sim.images import write_png
    from sim.pictures import disparity_picture, mask_picture, trajectory_picture

    outdir.mkdir(parents=True, exist_ok=True)
    scale = 1 << params.frac_bits
    lines = ["frame,x,y,flag,symbol"]
    for n in range(len(trajectory.flag)):
        x, y = trajectory.smoothed[n] / scale
        lines.append(f"{n},{x:.4f},{y:.4f},{int(trajectory.flag[n])},{int(trajectory.symbol[n])}")
    tmp = outdir / "trajectory.csv.part"
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(outdir / "trajectory.csv")
    for n, st in kept.items():
        pictures = {"left": st.left, "right": st.right,
                    "disparity": disparity_picture(st.disparity, params.max_disparity),
                    "skin": mask_picture(st.skin), "band": mask_picture(st.band),
                    "opening": mask_picture(st.opened)}
        for stage in STAGES:
            write_png(outdir / f"frame_{n:04d}_{stage}.png", pictures[stage], bits=8)
    background = next(iter(kept.values())).left if kept else None
    if background is not None:
        write_png(outdir / "trajectory.png",
                  trajectory_picture(background, trajectory.smoothed, trajectory.flag,
                                     params.frac_bits), bits=8)
    symbols = [int(s) for s in trajectory.symbol if s >= 0]
    summary = {"clip": str(clip.path) if getattr(clip, "path", None) else None,
               "gesture": clip.gesture, "frames": len(trajectory.flag),
               "gesture_frames": int(trajectory.flag.sum()),
               "symbols": "".join(str(s) for s in symbols),
               "seconds": round(seconds, 2), "params": params.as_dict()}
    (outdir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def progress_printer(quiet: bool):
    start = time.perf_counter()

    def show(done: int, total: int) -> None:
        if quiet or not (done == total or done % 10 == 0):
            return
        rate = done / max(1e-9, time.perf_counter() - start)
        print(f"  frame {done}/{total} ({rate:.1f} frames/s)", file=sys.stderr, flush=True)
    return show


def run(args) -> int:
    from sim.clip import load_clip
    from sim.model.pipeline import PipelineParams, run_clip

    clip = load_clip(args.clip)
    frames = clip.left.shape[0]
    chosen = set(parse_frames(args.frames, frames, tuple(clip.motion_frames)))
    params = PipelineParams()
    start = time.perf_counter()
    if getattr(args, "backend", "model") == "verilator":
        from verif.pipeline import run_clip_hardware
        params.validate(clip.left.shape[2] // 2, clip.left.shape[1])
        if not args.quiet:
            print("  building / running the Verilated pipeline ...", file=sys.stderr, flush=True)
        trajectory, stats = run_clip_hardware(clip.left, clip.right, params)
        kept = {}
        if not args.quiet:
            print(f"  {stats['cycles']} pipeline cycles, {stats['cycles_per_second']:.0f} "
                  f"cycles/s", file=sys.stderr, flush=True)
    else:
        trajectory, kept = run_clip(clip.left, clip.right, params, keep=chosen.__contains__,
                                    progress=progress_printer(args.quiet), threads=args.threads)
    seconds = time.perf_counter() - start
    summary = write_outputs(Path(args.output), clip, trajectory, kept, params, seconds)
    print(f"{summary['frames']} frames in {seconds:.1f} s, {summary['gesture_frames']} flagged "
          f"as gesture; symbols: {summary['symbols'] or '(none)'}")
    print(f"trajectory and stage pictures in {args.output}")
    return 0
