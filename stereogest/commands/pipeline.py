"""Run the golden model of the whole FPGA pipeline over a stereo clip (from
'stereogest render', or your own footage from 'stereogest clip'): per frame,
4:2:2 to 4:4:4, median, stereo matching, skin and disparity segmentation,
opening and centroid; per clip, moving average, gesture spotting and
orientation symbols; then the board application's HMMs name the gesture.
Writes OUTDIR/trajectory.csv and pictures of every stage for chosen frames. The
spotting threshold Tm is scaled to the frame width and the hold set as in
'stereogest demo' (PipelineParams.for_frame). With --calibration both cameras
are rectified first (hdl/rectify.py and its model). --spotting continuous names
the gestures as 'python -m sw_hps --spotting continuous' does on the FIFO's
streaming mode (one after another, no rest needed; the model shipped for it,
sw_hps/models/continuous7.json, unless --model); --json lists every gesture,
with the posture held over most of it (the shipped posture classifier, unless
--posture-model)."""
from __future__ import annotations

import json
import sys
import time

from stereogest.pipeline_outputs import (SPOTTING_MODES, STALE, add_postures, frame_postures,
                                         load_models_with_postures, parse_frames,
                                         progress_printer, recognised_gestures, sequence_score,
                                         spot, warn_if_empty, write_outputs)

NAME = "pipeline"
HELP = "golden model of the FPGA pipeline over a clip: trajectory.csv and stage pictures"

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
    p.add_argument("--posture-model", metavar="POSTURE.json", default=None,
                   help="posture classifier that names each gesture's posture from the "
                        "frames' posture records (default: the one shipped in sw_hps/models)")
    p.add_argument("--spotting", choices=SPOTTING_MODES, default="thesis",
                   help="thesis: the FPGA's spotting flag marks each gesture (default); "
                        "continuous: the board's continuous spotting on every frame")
    p.add_argument("--json", action="store_true",
                   help="print the result (with 'recognised') as a JSON last line")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    from stereogest.commands import add_calibration_options, add_hand_tracking_option
    add_calibration_options(p)
    add_hand_tracking_option(p)


def run(args) -> int:
    from sim.clip import load_clip
    from sim.model.validation import check_int
    from sim.model.pipeline import PipelineParams
    from stereogest.commands import OutputDir, load_rectification

    clip = load_clip(args.clip)
    frames = clip.left.shape[0]
    chosen = set(parse_frames(args.frames, frames, clip.motion_frames))
    models = load_models_with_postures(args.model, args.spotting, args.posture_model)
    overrides = {k: v for k, v in (("spot_threshold", args.spot_threshold),
                                   ("spot_hold", args.spot_hold)) if v is not None}
    params = PipelineParams.for_frame(clip.width, hand_tracking=args.hand_tracking,
                                      **overrides)
    params.validate(clip.width, clip.height)
    if args.threads is not None:
        check_int("--threads", args.threads, 1, 64)
    rectification = load_rectification(args, clip.width, clip.height)
    with OutputDir(args.output, stale=STALE) as outdir:
        return _run(args, clip, params, models, chosen, outdir, rectification)


def _run(args, clip, params, models, chosen, outdir, rectification=None) -> int:
    from sim.model.pipeline import run_clip
    models, posture_model = models
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
        trajectory, stats = run_clip_hardware(clip.left, clip.right, params,
                                              rectification=rectification)
        kept = {}
        if not args.quiet:
            print(f"  {stats['cycles']} pipeline cycles, {stats['cycles_per_second']:.0f} "
                  f"cycles/s", file=sys.stderr, flush=True)
    else:
        trajectory, kept = run_clip(clip.left, clip.right, params, keep=chosen.__contains__,
                                    progress=progress_printer(args.quiet), threads=args.threads,
                                    rectification=rectification)
    seconds = time.perf_counter() - start
    warn_if_empty(trajectory, params, clip.width, clip.height, args.quiet,
                  stages=kept.values())
    results = spot(models, posture_model, trajectory, clip.width, args.spotting)
    gestures = add_postures(recognised_gestures(results), frame_postures(posture_model, trajectory))
    truth = sequence_score(results, clip.sequence) if clip.sequence is not None else None
    recognised, telegram = (gestures[-1]["name"], gestures[-1]["telegram"]) if gestures \
        else (None, None)
    summary = write_outputs(outdir, clip, trajectory, kept, params, seconds, clip_path=args.clip,
                            recognised=recognised, telegram=telegram, gestures=gestures)
    print(f"{summary['frames']} frames in {seconds:.1f} s, {summary['gesture_frames']} flagged "
          f"as gesture; symbols: {summary['symbols'] or '(none)'}")
    print(f"recognised: {recognised or 'none'}"
          + (f" (NXT telegram {telegram})" if telegram else "")
          + (f"; the clip is labelled {clip.gesture}" if clip.gesture else ""))
    print(f"trajectory and stage pictures in {args.output}")
    if truth is not None:
        print(f"against the sequence's truth: {truth['correct']} of {truth['true']} gestures "
              f"named right, {truth['false']} false command(s)")
    if args.json:
        print(json.dumps({"clip": str(args.clip), **{key: summary[key] for key in (
            "gesture", "frames", "gesture_frames", "symbols", "recognised", "telegram",
            "gestures", "seconds")}, **({"truth": truth} if truth is not None else {})}))
    return 0
