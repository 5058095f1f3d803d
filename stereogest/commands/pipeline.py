"""Run the golden model of the whole FPGA pipeline over a stereo clip (from
'stereogest render', or your own footage from 'stereogest clip'): per frame,
4:2:2 to 4:4:4, median, stereo matching, skin and disparity segmentation,
opening and centroid; per clip, moving average, gesture spotting and
orientation symbols; then the board application's HMMs name the gesture.
Writes OUTDIR/trajectory.csv and pictures of every stage for chosen frames. The
spotting threshold Tm is scaled to the frame width and the hold set as in
'stereogest demo' (PipelineParams.for_frame)."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

NAME = "pipeline"
HELP = "golden model of the FPGA pipeline over a clip: trajectory.csv and stage pictures"

STAGES = ("left", "right", "disparity", "skin", "band", "opening")
#: What a run writes, deleted from a reused output folder first.
STALE = ("frame_*_*.png", "trajectory.csv", "trajectory.png", "summary.json")


def add_arguments(p):
    p.add_argument("clip", metavar="CLIP",
                   help="clip directory written by 'stereogest render' or 'stereogest clip'")
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
    p.add_argument("--spot-threshold", type=int, default=None, metavar="PX",
                   help="gesture spotting threshold Tm in pixels (default: the thesis' 30 "
                        "scaled to the frame width)")
    p.add_argument("--spot-hold", type=int, default=None, metavar="FRAMES",
                   help="still frames that end a gesture (default: as 'stereogest demo')")
    p.add_argument("--model", metavar="MODEL.json", default=None,
                   help="HMM model file of the board application that names the gesture "
                        "(default: the trained model shipped in sw_hps/models)")
    p.add_argument("--json", action="store_true",
                   help="print the result (with 'recognised') as a JSON last line")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def parse_frames(text: str | None, frames: int, motion: tuple[int, int] | None) -> list[int]:
    """Frames to draw: ``text`` ("3,10,40"), or by default a rest frame, the middle
    of the motion and its end (the first, middle and last frame without truth)."""
    if text is None and motion is None:
        return sorted({0, frames // 2, frames - 1})
    if text is None:
        first, last = motion
        chosen = {max(0, first - 5), (first + last) // 2, min(frames - 1, last)}
        return sorted(chosen)
    try:
        chosen = sorted({int(tok) for tok in text.split(",") if tok.strip()})
    except ValueError:
        raise ValueError(f"--frames must be comma-separated integers, got {text!r}") from None
    if not chosen:
        raise ValueError(f"--frames must list at least one frame number, got {text!r}")
    bad = [n for n in chosen if not 0 <= n < frames]
    if bad:
        raise ValueError(f"--frames must be in [0, {frames - 1}], got {bad}")
    return chosen


def write_outputs(outdir: Path, clip, trajectory, kept, params, seconds: float,
                  recognised: str | None = None, telegram: str | None = None) -> dict:
    """trajectory.csv, frame_NNNN_<stage>.png, frame_NNNN_sheet.png (the stages
    labelled, for people), trajectory.png, summary.json."""
    from sim.images import write_png
    from sim.pictures import disparity_picture, mask_picture, stage_sheet, trajectory_picture

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
        centroid = tuple(trajectory.centroid[n]) if trajectory.area[n] else None
        panels = {"left camera": st.left, "right camera": st.right,
                  "disparity": st.disparity, "skin (Cb/Cr box)": st.skin,
                  "disparity band": st.band, "opening": st.opened}
        write_png(outdir / f"frame_{n:04d}_sheet.png",
                  stage_sheet(n, panels, centroid, bool(trajectory.flag[n]),
                              params.max_disparity), bits=8)
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
               "recognised": recognised, "telegram": telegram,
               "seconds": round(seconds, 2), "params": params.as_dict()}
    tmp = outdir / "summary.json.part"
    tmp.write_text(json.dumps(summary, indent=2) + "\n")
    tmp.replace(outdir / "summary.json")
    return summary


def progress_printer(quiet: bool):
    start = time.perf_counter()

    def show(done: int, total: int) -> None:
        if quiet or not (done == total or done % 10 == 0):
            return
        rate = done / max(1e-9, time.perf_counter() - start)
        print(f"  frame {done}/{total} ({rate:.1f} frames/s)", file=sys.stderr, flush=True)
    return show


def shipped_model_path() -> Path:
    """The trained HMM model shipped with the board application (``make model``
    rebuilds it)."""
    import sw_hps
    return Path(sw_hps.__file__).parent / "models" / "gestures7.json"


def recognise(models, trajectory):
    """The board application on a trajectory (a simulated FIFO): the last
    recognised gesture (None) and its NXT telegram (hex, or None)."""
    from sw_hps.app import run_on_trajectory
    board = run_on_trajectory(models, trajectory.smoothed[:, 0], trajectory.smoothed[:, 1],
                              trajectory.flag, pixels=False)
    recognised = board.recognised[-1] if board.recognised else None
    telegram = board.telegrams[-1].hex(" ") if board.telegrams else None
    return recognised, telegram


def warn_if_empty(trajectory, params, width: int, height: int, quiet: bool = False) -> None:
    """Say on stderr when the opening found no hand at all, or no gesture was
    flagged (the results then name no gesture, which is not an error)."""
    if not trajectory.area.any():
        print(f"warning: the opening found no hand in any of {len(trajectory.area)} frames "
              f"(at {width}x{height} a {params.opening_size}x{params.opening_size} opening "
              f"can erase a small hand; try a larger frame)", file=sys.stderr)
    elif not trajectory.flag.any():
        print(f"warning: no gesture was flagged (the hand never moved Tm = "
              f"{params.spot_threshold} px within {params.spot_window} frames)",
              file=sys.stderr)


def run(args) -> int:
    from sim.clip import load_clip
    from sim.footage import check_option
    from sim.model.pipeline import PipelineParams
    from stereogest.commands import OutputDir
    from sw_hps.hmm import load_models

    clip = load_clip(args.clip)
    frames = clip.left.shape[0]
    chosen = set(parse_frames(args.frames, frames, clip.motion_frames))
    models = load_models(args.model or shipped_model_path())
    overrides = {k: v for k, v in (("spot_threshold", args.spot_threshold),
                                   ("spot_hold", args.spot_hold)) if v is not None}
    params = PipelineParams.for_frame(clip.width, **overrides)
    params.validate(clip.width, clip.height)
    if args.threads is not None:
        check_option("--threads", args.threads, 1, 64)
    with OutputDir(args.output, stale=STALE) as outdir:
        return _run(args, clip, params, models, chosen, outdir)


def _run(args, clip, params, models, chosen, outdir) -> int:
    from sim.model.pipeline import run_clip
    if not args.quiet:
        print(f"  spotting: Tm = {params.spot_threshold} px (thesis 30 at 640 wide, scaled to "
              f"{clip.width}), end after {params.spot_hold} still frames", file=sys.stderr,
              flush=True)
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
    warn_if_empty(trajectory, params, clip.width, clip.height, args.quiet)
    recognised, telegram = recognise(models, trajectory)
    summary = write_outputs(outdir, clip, trajectory, kept, params, seconds,
                            recognised=recognised, telegram=telegram)
    print(f"{summary['frames']} frames in {seconds:.1f} s, {summary['gesture_frames']} flagged "
          f"as gesture; symbols: {summary['symbols'] or '(none)'}")
    print(f"recognised: {recognised or 'none'}"
          + (f" (NXT telegram {telegram})" if telegram else "")
          + (f"; the clip is labelled {clip.gesture}" if clip.gesture else ""))
    print(f"trajectory and stage pictures in {args.output}")
    if args.json:
        print(json.dumps({"clip": str(args.clip), **{key: summary[key] for key in (
            "gesture", "frames", "gesture_frames", "symbols", "recognised", "telegram",
            "seconds")}}))
    return 0
