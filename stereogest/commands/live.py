"""Watch the system work: the golden model and the recogniser run frame by
frame on two webcams (camera indices), two video files or a clip, and a local
page (127.0.0.1 only) shows both cameras, the six stages of thesis Table 22
(the board's VGA choices), the trajectory and the last recognised gesture with
its NXT telegram, refreshed as frames arrive. Open the printed address in a
browser; Ctrl-C stops. When the source ends (a clip's or video's last frame,
--frames reached, or Ctrl-C on any source, webcams included) with a gesture
still flagged, that gesture ends there and is named, as 'stereogest pipeline'
names a gesture a clip ends inside; --json lists the recognised gestures (the
latest 1,000). --loop replays a clip without end. 320x240 keeps up with 15
frames/s or more on a 2-core machine (benchmarks/bench_live.py)."""
from __future__ import annotations

import sys
import threading

from stereogest.commands import add_camera_options, add_hand_tracking_option, add_json_switch

NAME = "live"
HELP = "live view: golden model and recogniser on webcams, videos or a clip, in a browser"


def add_arguments(p):
    add_camera_options(p, required=False)
    p.add_argument("--clip", metavar="CLIP", default=None,
                   help="replay a clip instead ('stereogest render' or 'stereogest clip')")
    p.add_argument("--width", type=int, default=None,
                   help="frame width for --left/--right (even, 96..4096; default: 320; a "
                        "clip has its own)")
    p.add_argument("--height", type=int, default=None,
                   help="frame height for --left/--right (64..4096; default: 240)")
    p.add_argument("--port", type=int, default=8642,
                   help="port of the page on 127.0.0.1 (0..65535; 0: any free port)")
    p.add_argument("--fps", type=int, default=None,
                   help="replay rate of a clip or videos, 1..1000 (default: their own; "
                        "cameras run at theirs)")
    p.add_argument("--fast", action="store_true",
                   help="replay a clip or videos as fast as the model goes")
    p.add_argument("--frames", type=int, default=None,
                   help="stop after this many frame pairs and exit (1..1800)")
    p.add_argument("--loop", action="store_true",
                   help="replay the clip from its start whenever it ends, until Ctrl-C "
                        "(or --frames): a page that runs for hours (with --clip only)")
    p.add_argument("--posture-model", metavar="POSTURE.json", default=None,
                   help="posture classifier for the page's current posture (default: the one "
                        "shipped in sw_hps/models)")
    p.add_argument("--model", metavar="MODEL.json", default=None,
                   help="HMM model file (default: the one shipped in sw_hps/models)")
    p.add_argument("--threads", type=int, default=1,
                   help="worker threads for the stereo cost stage, 1..64 (default 1: at "
                        "320x240 one thread beat two on a 2-core machine in CPU and wall "
                        "time, benchmarks/bench_live.py)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--spotting", choices=("thesis", "continuous"), default="thesis",
                   help="thesis: a gesture between rests (default); continuous: the board's "
                        "continuous spotting, gestures one after another (the model shipped "
                        "for it unless --model)")
    add_hand_tracking_option(p)
    add_json_switch(p)


def _looped(clip, frames):
    """The clip's frame pairs from the start again each time it ends; ``frames``
    pairs in all (None: without end)."""
    n = 0
    while frames is None or n < frames:
        yield clip.left[n % clip.frames], clip.right[n % clip.frames]
        n += 1


def run(args) -> int:
    import time

    from sim.footage import MAX_FRAMES, StereoSource
    from sim.model.validation import check_int
    from sim.model.pipeline import PipelineParams
    from stereogest.live import LiveServer, LiveSession, run_source

    if (args.clip is None) == (args.left is None and args.right is None) or \
            (args.clip is None and (args.left is None or args.right is None)):
        raise ValueError("give either --clip CLIP or both --left and --right")
    for option, value in (("--width", args.width), ("--height", args.height)):
        if args.clip is not None and value is not None:
            raise ValueError(f"{option} applies to --left/--right; a clip keeps its own size")
    if args.loop and args.clip is None:
        raise ValueError("--loop replays a clip: only with --clip")
    if args.fps is not None:
        check_int("--fps", args.fps, 1, 1000)
    if args.frames is not None:
        check_int("--frames", args.frames, 1, MAX_FRAMES)
    check_int("--port", args.port, 0, 65535)
    check_int("--threads", args.threads, 1, 64)
    from stereogest.pipeline_outputs import load_models_with_postures
    models, posture_model = load_models_with_postures(args.model, args.spotting,
                                                      args.posture_model)
    if args.clip is not None:
        from sim.clip import load_clip
        clip = load_clip(args.clip)
        width, height, native_fps = clip.width, clip.height, clip.fps
        if args.loop:
            pairs = _looped(clip, args.frames)
        else:
            count = clip.frames if args.frames is None else min(args.frames, clip.frames)
            pairs = ((clip.left[n], clip.right[n]) for n in range(count))
        source, closer = f"clip {args.clip}" + (", looped" if args.loop else ""), None
    else:
        width, height = args.width or 320, args.height or 240
        closer = StereoSource(args.left, args.right, width=width, height=height,
                              frames=args.frames)
        pairs = closer
        native_fps = None if closer.camera else (closer.fps or 30)
        source = f"{closer.sources[0].kind} and {closer.sources[1].kind}"
    params = PipelineParams.for_frame(width, hand_tracking=args.hand_tracking)
    try:
        params.validate(width, height)
        session = LiveSession(params, models, threads=args.threads, spotting=args.spotting,
                              width=width, posture_model=posture_model)
        server = LiveServer(session, width, height, args.port)
    except BaseException:
        if closer is not None:
            closer.close()
        raise
    print(f"live view of {source} ({width}x{height}) on {server.url} (Ctrl-C stops)",
          flush=True)
    fps = None if args.fast else (args.fps or native_fps)

    def progress(s):
        if not args.quiet and s.frames % 30 == 0:
            st = s.state
            print(f"  frame {st['frame']}, {st['fps']} frames/s, last recognised "
                  f"{st['recognised'] or 'nothing'}", file=sys.stderr, flush=True)

    stop = threading.Event()
    worker_error = []

    def work():
        try:
            run_source(session, pairs, fps=fps, stop=stop, on_frame=progress)
        except ValueError as exc:
            worker_error.append(exc)

    worker = threading.Thread(target=work, daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.2)
        if worker_error:
            raise worker_error[0]
        state, _ = session.snapshot()
        print(f"{session.frames} frame pairs; last recognised: "
              f"{state['recognised'] or 'none'}"
              + (f" (NXT telegram {state['telegram']})" if state["telegram"] else ""),
              flush=True)
        if args.frames is None:
            print("the source ended; the page shows its last frame (Ctrl-C stops)", flush=True)
            while True:
                time.sleep(1)
    except KeyboardInterrupt:
        stop.set()
        worker.join(5)
    finally:
        server.close()
        if closer is not None:
            closer.close()
    if args.json:
        import json
        state, _ = session.snapshot()
        print(json.dumps({"source": source, "width": width, "height": height,
                          "frames": session.frames, "recognised": state["recognised"],
                          "telegram": state["telegram"], "gestures": session.gestures}),
              flush=True)
    return 0
