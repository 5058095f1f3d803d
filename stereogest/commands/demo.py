"""The main job, cameras to robot command: render a synthetic stereo clip of one
of the seven thesis gestures; simulate the generated Verilog of the whole FPGA
side (soc.core.StereogestCore: camera capture to the Avalon FIFO slave, the
UART and the VGA view) under Verilator, fed the clip as camera pin waveforms;
run the unmodified board application (sw_hps) against those registers through
a simulated-bus backend; print the recognised gesture and the NXT telegram
bytes seen on the UART pin. The golden model runs beside it: it draws a picture
of every stage and checks the FIFO words and the VGA frame. The last line is
JSON with gesture (rendered), recognised and telegram (hex), and gestures:
every gesture the application recognised (name, first and last flagged frame,
telegram, score).

The exit status is 1 when the demo fails its own gesture: the board
application recognised another gesture, or none, than the one rendered (or
the one a --clip is labelled with; unlabelled footage has none to fail), and
with --backend verilator also when the hardware and the golden model disagree.

``--backend model`` runs the golden model only (the application then reads a
simulated FIFO), for a quick look."""
from __future__ import annotations

import json
import sys
import time

from stereogest.commands import add_json_switch

NAME = "demo"
#: Frames of rest before the gesture: enough for the moving average and the
#: spotting window (K = 8) to settle; the renderer's own choice (about a
#: second) adds some 20 frames, a minute of the Verilated system.
DEFAULT_PRE_REST = 10
HELP = "render a gesture clip and run it from camera pins to robot command (the main job)"


def add_arguments(p):
    from hdl.gesture_pipeline import VIDEO_STAGES
    from sim.gesture_shapes import GESTURE_NAMES
    p.add_argument("--gesture", choices=GESTURE_NAMES, default="rotate-right",
                   help="which thesis gesture to render (Fig. 16)")
    p.add_argument("--sequence", metavar="NAME[@POSTURE][,...]", default=None,
                   help="render these gestures one after another instead of --gesture "
                        "(with --pause frames of rest between them), each in the posture "
                        "after its @ (default: --posture's); the demo fails unless "
                        "every one is named, once, and nothing else")
    from stereogest.commands import add_posture_option
    add_posture_option(p)
    p.add_argument("--pause", metavar="MIN-MAX", default="0-15",
                   help="--sequence: frames of rest between two gestures (default 0-15)")
    p.add_argument("--spotting", choices=("thesis", "continuous"), default="thesis",
                   help="the board application's spotting (python -m sw_hps --spotting): "
                        "thesis (default) or continuous (the FIFO's streaming mode; the "
                        "model shipped for it unless --model)")
    p.add_argument("--clip", metavar="CLIP", default=None,
                   help="run this clip (from 'stereogest render' or 'stereogest clip', your "
                        "own footage) instead of rendering one; --gesture, --seed, "
                        "--pre-rest, --width and --height then do not apply")
    from stereogest.commands import DEFAULT_SEED
    p.add_argument("--seed", type=int, default=DEFAULT_SEED,
                   help="scene and timing seed (>= 0)")
    from sim.render import MAX_SEGMENT_FRAMES
    p.add_argument("--pre-rest", type=int, default=DEFAULT_PRE_REST, metavar="FRAMES",
                   help=f"frames of rest before the gesture, 0-{MAX_SEGMENT_FRAMES} (default "
                        f"{DEFAULT_PRE_REST}; -1: the renderer's seeded value)")
    p.add_argument("--width", type=int, default=640, help="frame width in pixels (even)")
    p.add_argument("--height", type=int, default=480, help="frame height in pixels (even)")
    p.add_argument("-o", "--output", metavar="OUTDIR", default="demo-out",
                   help="directory for the clip (OUTDIR/clip), the stage pictures "
                        "(OUTDIR/pipeline) and the VGA frame (OUTDIR/vga.png)")
    p.add_argument("--backend", choices=("verilator", "model"), default="verilator",
                   help="verilator: the whole FPGA side's Verilog (default); model: the "
                        "golden model only, the application on a simulated FIFO")
    p.add_argument("--stage", choices=VIDEO_STAGES, default="opening",
                   help="pipeline stage shown on the VGA view (SW[9:7], thesis Table 22)")
    p.add_argument("--model", metavar="MODEL.json", default=None,
                   help="HMM model file for the board application (default: the trained "
                        "model shipped in sw_hps/models/gestures7.json)")
    p.add_argument("--posture-model", metavar="POSTURE.json", default=None,
                   help="posture classifier naming each gesture's posture (default: the one "
                        "shipped in sw_hps/models)")
    p.add_argument("--threads", type=int, default=None,
                   help="worker threads for the golden model's stereo cost stage "
                        "(default: CPUs, at most 4)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    from stereogest.commands import (add_calibration_options, add_hand_tracking_option,
                                     add_scene_options, add_vga_scale_option)
    add_vga_scale_option(p)
    add_calibration_options(p)
    add_hand_tracking_option(p)
    add_scene_options(p)
    add_json_switch(p, always=True)


def gesture_failure(gesture: str | None, recognised: str | None,
                    class_names=()) -> str | None:
    """Why the demo failed its own gesture, or None if it did not.

    Parameters
    ----------
    gesture : str or None
        The gesture rendered (or a clip's label); None for unlabelled footage,
        which has no gesture to fail.
    recognised : str or None
        The gesture the board application recognised last; None for none.
    class_names : sequence of str
        The model's classes, to say when it cannot recognise ``gesture`` at all.

    Returns
    -------
    str or None
        One line for ``stereogest demo: error:``.
    """
    if gesture is None or recognised == gesture:
        return None
    got = f"recognised {recognised}" if recognised else "recognised nothing"
    why = ("" if not class_names or gesture in class_names
           else f" (the model has no class {gesture}: {', '.join(class_names)})")
    return f"the clip shows {gesture} but the board application {got}{why}"


def _say(quiet: bool):
    def say(text: str) -> None:
        if not quiet:
            print(text, file=sys.stderr, flush=True)
    return say


def run(args) -> int:
    from sim.model.pipeline import PipelineParams
    from sim.model.validation import check_int
    from sim.render import HEIGHT_RANGE, MAX_SEGMENT_FRAMES, WIDTH_RANGE
    from stereogest.commands import OutputDir, load_rectification, vga_scale_of

    # Every option checked before anything is created or rendered.
    if args.threads is not None:
        check_int("--threads", args.threads, 1, 64)
    args.vga_scale = vga_scale_of(args)
    from stereogest.commands import scene_difficulties
    difficulties = scene_difficulties(args)
    if args.clip is not None and difficulties.any:
        raise ValueError("--scene and the difficulty options apply to a rendered clip, not "
                         "to --clip")
    args.difficulties = difficulties
    if args.clip is None:
        check_int("--seed", args.seed, 0, 2 ** 63 - 1)
        for option, value, (lo, hi) in (("--width", args.width, WIDTH_RANGE),
                                        ("--height", args.height, HEIGHT_RANGE)):
            check_int(option, value, lo, hi)
            if value % 2:
                raise ValueError(f"{option} must be even, in [{lo}, {hi}], got {value}")
    from stereogest.commands import resolve_posture_option
    args.posture = resolve_posture_option(args.posture)
    if not -1 <= args.pre_rest <= MAX_SEGMENT_FRAMES:
        raise ValueError(f"--pre-rest must be in -1..{MAX_SEGMENT_FRAMES}, got "
                         f"{args.pre_rest}")
    if args.sequence is not None:
        from recognition.streams import check_range
        from sim.gesture_shapes import GESTURE_NAMES
        if args.clip is not None:
            raise ValueError("--sequence renders a clip; it does not apply with --clip")
        from stereogest.commands import parse_sequence
        args.sequence, args.postures = parse_sequence(args.sequence, args.posture)
        if not all(n in GESTURE_NAMES for n in args.sequence):
            raise ValueError(f"--sequence: names must be among {', '.join(GESTURE_NAMES)}, "
                             f"got {','.join(args.sequence)!r}")
        args.pause = check_range("--pause", args.pause, 0, MAX_SEGMENT_FRAMES)
    say = _say(args.quiet)
    from stereogest.pipeline_outputs import load_models_with_postures
    models, posture_model = load_models_with_postures(args.model, args.spotting,
                                                      args.posture_model)
    if args.clip is not None:
        from sim.clip import load_clip
        clip = load_clip(args.clip)
        width, height = clip.width, clip.height
    else:
        clip, width, height = None, args.width, args.height
    params = PipelineParams.for_frame(width, hand_tracking=args.hand_tracking)
    params.validate(width, height)
    rectification = load_rectification(args, width, height)
    with OutputDir(args.output) as out:
        return _demo(args, clip, params, (models, posture_model), say, out, rectification)


def _demo(args, clip, params, models, say, out, rectification=None) -> int:
    models, posture_model = models
    from sim.clip import save_clip
    from sim.images import write_png
    from sim.model.pipeline import run_clip
    from sim.render import render_clip
    from stereogest.pipeline_outputs import (STALE, add_postures, frame_postures,
                                             gesture_entries, parse_frames,
                                             progress_printer, recognised_gestures,
                                             sequence_score, spot, write_outputs)

    start = time.perf_counter()
    if args.clip is not None:
        motion = (f", motion in frames {clip.motion_frames[0]}-{clip.motion_frames[1]}"
                  if clip.has_truth else "")
        print(f"clip {args.clip}: {clip.frames} frames of {clip.width}x{clip.height}"
              + (f", labelled {clip.gesture}" if clip.gesture else "") + motion)
    else:
        if args.sequence is not None:
            from sim.render import render_sequence
            clip = render_sequence(args.sequence, args.seed, args.width, args.height,
                                   postures=args.postures,
                                   pause=args.pause, difficulties=args.difficulties)
            what = ", ".join(f"{g} {a}-{b}" for g, a, b in clip.sequence)
        else:
            clip = render_clip(args.gesture, args.seed, args.width, args.height,
                               n_pre_rest=None if args.pre_rest < 0 else args.pre_rest,
                               posture=args.posture,
                               difficulties=args.difficulties)
            what = f"{args.gesture}, motion in frames {clip.motion_frames[0]}-" \
                f"{clip.motion_frames[1]}"
        if rectification is not None:
            # what the calibrated cameras would see of the rendered (aligned) view
            import dataclasses

            from sim.calibration import camera_frames, load_calibration
            calib = load_calibration(args.calibration)
            clip = dataclasses.replace(clip, left=camera_frames(clip.left, calib, "left"),
                                       right=camera_frames(clip.right, calib, "right"))
        clip_dir = save_clip(clip, out / "clip")
        print(f"rendered {what} (seed {args.seed}): {clip.frames} frames of "
              f"{clip.width}x{clip.height} -> {clip_dir}")
    print(f"spotting: Tm = {params.spot_threshold} px (thesis 30 at 640 wide, scaled to the "
          f"width), end after {params.spot_hold} still frames")

    chosen = set(parse_frames(None, clip.frames, clip.motion_frames))
    say("golden model:")
    if args.backend == "model":
        trajectory, kept = run_clip(clip.left, clip.right, params, keep=chosen.__contains__,
                                    progress=progress_printer(args.quiet), threads=args.threads,
                                    rectification=rectification)
    else:
        from verif.end_to_end import clip_end_to_end
        trajectory, kept, extra, result = clip_end_to_end(
            clip, models, params, stage=args.stage, keep=chosen, threads=args.threads,
            model_progress=progress_printer(args.quiet), progress=say,
            rectification=rectification, vga_scale=args.vga_scale, spotting=args.spotting,
            posture_model=posture_model)
    pictures = out / "pipeline"
    for pattern in STALE:                # a reused folder: no old picture passes for new
        for old in pictures.glob(pattern):
            old.unlink()
    summary = write_outputs(pictures, clip, trajectory, kept, params,
                            time.perf_counter() - start,
                            clip_path=args.clip if args.clip is not None else clip_dir)
    flagged = trajectory.flag.nonzero()[0]
    span = f"{flagged[0]}-{flagged[-1]}" if flagged.size else "none"
    truth = (f" (truth: motion {clip.motion_frames[0]}-{clip.motion_frames[1]})"
             if clip.has_truth else "")
    print(f"golden model: gesture flagged in frames {span}{truth}; orientation symbols "
          f"(0=right 2=up 4=left 6=down): {summary['symbols'] or '(none)'}")
    print(f"stage pictures and trajectory.csv in {pictures}")
    report = {"gesture": clip.gesture, "frames": clip.frames, "width": clip.width,
              "height": clip.height, "backend": args.backend,
              "flagged": int(trajectory.flag.sum()), "symbols": summary["symbols"]}

    postures = frame_postures(posture_model, trajectory)
    continuous = args.spotting == "continuous"
    model_results = spot(models, posture_model, trajectory, clip.width, args.spotting)
    if args.backend == "model":
        entries = model_results
        gestures = add_postures(recognised_gestures(entries), postures)
        recognised, telegram = (gestures[-1]["name"], gestures[-1]["telegram"]) if gestures \
            else (None, None)
        print(f"board application (simulated FIFO): recognised {recognised or 'nothing'}"
              + (f", NXT telegram {telegram}" if telegram else ""))
    else:
        if extra:
            print(f"the gesture was still flagged at the last frame: the cameras held the "
                  f"hand still for {extra} more frames (trajectory.csv includes them)")
        write_png(out / "vga.png", result.vga, bits=8)
        recognised = result.recognised
        if continuous:
            entries = [dict(r, outcome="recognised") for r in result.results]
        else:
            from sw_hps.posture_commands import postures_for_frame
            entries = gesture_entries(result.results, trajectory.flag, commands=postures_for_frame(
                getattr(models, "postures", None), clip.width) is not None)
        gestures = add_postures(recognised_gestures(entries), postures)
        # the application on the hardware names what it names on the model's records
        # (not the posture share: that is over the frames whose posture record the
        # application read, which its polling against the simulation decides)
        agree = _named(entries) == _named(model_results)
        print("board application on the hardware: "
              + ("the same gestures and spans as on the golden model's records" if agree
                 else "DIFFERENT gestures from the golden model's records"))
        uart_hex = result.uart_bytes.hex(" ")
        cps = result.stats.get("cycles_per_second", 0)
        print(f"hardware: {result.cycles:,} pipeline cycles in {result.seconds:.1f} s "
              f"({cps:,.0f} cycles/s), LEDR = {result.leds:010b}")
        print(f"FIFO words popped by the application: {len(result.popped)}, "
              + ("equal to the golden model's" if result.fifo_matches_model else
                 f"DIFFERENT from the golden model's {len(result.expected)}"))
        mism = result.vga_mismatches
        print(f"VGA frame ({args.stage}, {'full' if args.vga_scale == 1 else 'half'} "
              f"resolution, {out / 'vga.png'}): "
              + ("equal to the golden model's picture" if mism == 0 else
                 f"{mism} pixels differ from the golden model's picture"))
        from sw_hps.posture import BUS_ACCESSES_PER_RECORD
        posture_ok = result.posture_matches_model
        if posture_ok is not None:
            print(f"posture record of the last frame (posture slave, "
                  f"{BUS_ACCESSES_PER_RECORD} bus accesses): "
                  + ("equal to the golden model's" if posture_ok else
                     "DIFFERENT from the golden model's"))
        board_postures = [(r["class_name"], r["posture"], r["posture_share"])
                          for r in result.results if r["outcome"] == "recognised"]
        if posture_model is not None and board_postures:
            print("board application's postures (read from the posture slave as it ran): "
                  + ", ".join(f"{name} in {posture or 'no posture'}"
                              + (f" ({share:.0%} of its frames)" if share is not None else "")
                              for name, posture, share in board_postures))
            report["board_postures"] = [{"name": n, "posture": p, "posture_share": sh}
                                        for n, p, sh in board_postures]
        print(f"UART TX pin: {uart_hex or 'nothing'}"
              + (" (the application's telegrams)" if result.uart_matches_telegram
                 else " (DIFFERENT from the application's telegrams "
                 f"{result.telegrams.hex(' ') or None})"))
        if len(result.recognised_all) > 1:
            print(f"board application: {len(result.recognised_all)} gestures recognised: "
                  f"{', '.join(result.recognised_all)}; the last one counts")
        telegram = result.telegram.hex(" ") if result.telegram else None
        print(f"board application: recognised {recognised or 'nothing'}"
              + (f", NXT telegram {telegram}" if telegram else ""))
        report.update(fifo_matches_model=result.fifo_matches_model, vga_mismatches=mism,
                      uart_matches_telegram=result.uart_matches_telegram,
                      vga_scale=args.vga_scale,
                      hardware_seconds=round(result.seconds, 1), cycles=result.cycles,
                      held_frames=extra, recognised_all=result.recognised_all,
                      uart=result.uart_bytes.hex(" "), gestures_match_model=agree,
                      posture_matches_model=posture_ok)
        if not (result.fifo_matches_model and mism == 0 and result.uart_matches_telegram
                and agree and posture_ok is not False):
            report.update(recognised=recognised, telegram=telegram, gestures=gestures)
            print(json.dumps(report))
            print("stereogest demo: error: the hardware and the golden model disagree "
                  "(see above)", file=sys.stderr)
            return 1
    report.update(recognised=recognised, telegram=telegram, gestures=gestures,
                  spotting=args.spotting, seconds=round(time.perf_counter() - start, 1))
    failure = None
    if clip.sequence is not None:
        score = sequence_score(entries, clip.sequence)
        report["truth"] = score
        print(f"against the sequence: {score['correct']} of {score['true']} gestures named "
              f"right, {score['false']} false command(s)")
        if score["correct"] < score["true"] or score["false"]:
            failure = (f"the board application named {score['correct']} of the "
                       f"{score['true']} rendered gestures right and sent {score['false']} "
                       f"false command(s)")
    print(json.dumps(report))
    if clip.sequence is None:
        failure = gesture_failure(clip.gesture, recognised, models.class_names)
    if failure is not None:     # a demo that misses its own gesture has failed
        print(f"stereogest demo: error: {failure}", file=sys.stderr)
        return 1
    return 0


def _named(entries) -> list[dict]:
    """The recognised gestures of ``entries`` without their posture share."""
    from stereogest.pipeline_outputs import recognised_gestures
    return [{k: v for k, v in g.items() if k != "posture_share"}
            for g in recognised_gestures(entries)]
