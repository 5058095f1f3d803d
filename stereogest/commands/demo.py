"""The main job: render a synthetic stereo clip of one of the seven thesis
gestures, run the golden model of the FPGA pipeline over it, play the
per-frame (x, y, gesture flag) stream into the unmodified board application
(sw_hps) through a simulated FIFO peripheral, and print the recognised gesture,
the NXT telegram and where the pictures of every stage are. The last line is
JSON with gesture (rendered), recognised and telegram (hex)."""
from __future__ import annotations

import json
import time
from pathlib import Path

NAME = "demo"
#: The trained model shipped with the board application (``make model`` rebuilds it).
DEFAULT_MODEL = "thesis7.json"
HELP = "render a gesture clip and run the pipeline over it (the main job)"


def add_arguments(p):
    from sim.gesture_shapes import GESTURE_NAMES
    p.add_argument("--gesture", choices=GESTURE_NAMES, default="rotate-right",
                   help="which thesis gesture to render (Fig. 16)")
    p.add_argument("--seed", type=int, default=1, help="scene and timing seed")
    p.add_argument("--width", type=int, default=640, help="frame width in pixels (even)")
    p.add_argument("--height", type=int, default=480, help="frame height in pixels (even)")
    p.add_argument("-o", "--output", metavar="OUTDIR", default="demo-out",
                   help="directory for the clip (OUTDIR/clip) and the pictures (OUTDIR/pipeline)")
    p.add_argument("--model", metavar="MODEL.json", default=None,
                   help="HMM model file for the board application (default: the trained "
                        "model shipped in sw_hps/models/thesis7.json)")
    p.add_argument("--threads", type=int, default=None,
                   help="worker threads for the stereo cost stage (default: CPUs, at most 4)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def run(args) -> int:
    from sim.clip import save_clip
    from sim.model.pipeline import PipelineParams, run_clip
    from sim.render import render_clip
    from stereogest.commands.pipeline import parse_frames, progress_printer, write_outputs
    from sw_hps.app import run_on_trajectory
    from sw_hps.hmm import load_models

    import sw_hps
    models = load_models(args.model or Path(sw_hps.__file__).parent / "models" / DEFAULT_MODEL)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    clip = render_clip(args.gesture, args.seed, args.width, args.height)
    clip_dir = save_clip(clip, out / "clip")
    print(f"rendered {args.gesture} (seed {args.seed}): {clip.frames} frames of "
          f"{clip.width}x{clip.height}, motion in frames {clip.motion_frames[0]}-"
          f"{clip.motion_frames[1]} -> {clip_dir}")
    params = PipelineParams()
    chosen = set(parse_frames(None, clip.frames, tuple(clip.motion_frames)))
    trajectory, kept = run_clip(clip.left, clip.right, params, keep=chosen.__contains__,
                                progress=progress_printer(args.quiet), threads=args.threads)
    pictures = out / "pipeline"
    summary = write_outputs(pictures, clip, trajectory, kept, params,
                            time.perf_counter() - start)
    flagged = trajectory.flag.nonzero()[0]
    span = f"{flagged[0]}-{flagged[-1]}" if flagged.size else "none"
    print(f"gesture flagged in frames {span} (truth: motion {clip.motion_frames[0]}-"
          f"{clip.motion_frames[1]})")
    print(f"orientation symbols (0=right 2=up 4=left 6=down): {summary['symbols'] or '(none)'}")
    print(f"stage pictures and trajectory.csv in {pictures}")
    board = run_on_trajectory(models, trajectory.smoothed[:, 0], trajectory.smoothed[:, 1],
                              trajectory.flag, pixels=False)
    recognised = board.recognised[-1] if board.recognised else None
    telegram = board.telegrams[-1].hex(" ") if board.telegrams else None
    print(f"board application: recognised {recognised or 'nothing'}"
          + (f", NXT telegram {telegram}" if telegram else ""))
    print(json.dumps({"gesture": args.gesture, "recognised": recognised, "telegram": telegram,
                      "frames": clip.frames, "flagged": int(trajectory.flag.sum()),
                      "symbols": summary["symbols"],
                      "seconds": round(time.perf_counter() - start, 1)}))
    return 0
