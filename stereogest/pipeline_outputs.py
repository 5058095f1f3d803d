"""What the commands that run the pipeline over a clip share (``pipeline``,
``demo``, ``live``): the frames to draw, the files they write (trajectory.csv,
stage pictures and sheets, trajectory.png, summary.json), progress lines, the
warnings of an empty run, the board application on a trajectory and the model
shipped with it."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

__all__ = ["STAGES", "STALE", "parse_frames", "write_outputs", "progress_printer",
           "shipped_model_path", "recognise", "warn_if_empty"]

STAGES = ("left", "right", "disparity", "skin", "band", "opening")
#: What a run writes, deleted from a reused output folder first.
STALE = ("frame_*_*.png", "trajectory.csv", "trajectory.png", "summary.json")


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
                  recognised: str | None = None, telegram: str | None = None,
                  gestures: list | None = None, clip_path=None) -> dict:
    """trajectory.csv, frame_NNNN_<stage>.png, frame_NNNN_sheet.png (the stages
    labelled, for people), trajectory.png, summary.json (``clip``: the clip's
    folder, ``clip_path``)."""
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
    summary = {"clip": str(clip_path) if clip_path is not None else None,
               "gesture": clip.gesture, "frames": len(trajectory.flag),
               "gesture_frames": int(trajectory.flag.sum()),
               "symbols": "".join(str(s) for s in symbols),
               "recognised": recognised, "telegram": telegram,
               "gestures": gestures if gestures is not None else [],
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


#: Spotting modes of the board application (``python -m sw_hps --spotting``).
SPOTTING_MODES = ("thesis", "continuous")


def shipped_model_path(spotting: str = "thesis") -> Path:
    """The trained HMM model shipped with the board application for a
    spotting mode (``make model`` rebuilds them)."""
    import sw_hps
    name = {"thesis": "gestures7.json", "continuous": "continuous7.json"}[spotting]
    return Path(sw_hps.__file__).parent / "models" / name


def shipped_posture_model_path() -> Path:
    """The posture classifier shipped with the board application (``make model``)."""
    import sw_hps
    return Path(sw_hps.__file__).parent / "models" / "posture.json"


def load_posture_model(path=None):
    """The posture classifier at ``path`` (None: the shipped one), refused with a
    ``ValueError`` naming the file as the board application refuses it."""
    from sw_hps.posture import read_posture_model
    return read_posture_model(shipped_posture_model_path() if path is None else path)


def frame_postures(model, trajectory) -> list:
    """Each frame's posture name (None: refused, no hand, or no posture record)
    by ``model`` from the trajectory's posture records."""
    from sw_hps.posture import record_posture
    if model is None or trajectory.posture is None or not len(trajectory.posture):
        return [None] * len(trajectory.flag)
    return [record_posture(model, words) for words in trajectory.posture]


def add_postures(entries: list[dict], postures: list, first_frame: int = 0) -> list[dict]:
    """``entries`` (:func:`recognised_gestures`) with ``posture``, the posture held
    over most of the gesture's frames (``postures``: :func:`frame_postures`;
    None when it is refused or unknown there), and ``posture_share``, the
    share of its frames in it."""
    from sw_hps.posture import held_posture
    out = []
    for entry in entries:
        if "posture" in entry:           # named by the posture commands already
            out.append(entry)
            continue
        first, last = entry.get("first"), entry.get("last")
        span = postures[first - first_frame:last - first_frame + 1] \
            if first is not None and last is not None else []
        name, share = held_posture(span)
        out.append(dict(entry, posture=name, posture_share=share))
    return out


def load_board_models(path=None, spotting: str = "thesis"):
    """The models at ``path`` (None: the shipped ones of that spotting mode),
    refused with a ``ValueError`` naming the file if the board application
    would refuse them (``sw_hps.app.check_models``; continuous spotting:
    ``sw_hps.streaming.check_streaming_models``), before any work is done."""
    from sw_hps.app import check_models
    from sw_hps.hmm import load_models
    from sw_hps.streaming import check_streaming_models
    path = shipped_model_path(spotting) if path is None else path
    models = load_models(path)
    try:
        models = check_models(models)
        return check_streaming_models(models) if spotting == "continuous" else models
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def load_models_with_postures(path=None, spotting: str = "thesis", posture_path=None):
    """:func:`load_board_models` and :func:`load_posture_model`, refused with a
    ``ValueError`` (as the board refuses them) when the model file's
    ``postures`` entry names a posture the posture model does not know:
    ``(models, posture_model)``."""
    from sw_hps.posture_commands import check_posture_classes
    models = load_board_models(path, spotting)
    posture_model = load_posture_model(posture_path)
    where = f"{shipped_model_path(spotting) if path is None else path}: postures"
    check_posture_classes(models.postures, posture_model.class_names, where=where)
    return models, posture_model


def command_posture(models, frame_width: int):
    """The posture rendered gestures are made in for ``models`` (gesture models
    and posture model, as :func:`load_models_with_postures` gives them): their
    first command posture, or None (the renderer's open hand) without posture
    commands or in frames too narrow for them, where the board sets them aside
    and a person need not hold a posture."""
    from sw_hps.posture_commands import postures_for_frame
    options = postures_for_frame(getattr(models[0], "postures", None), frame_width)
    return options["command"][0] if options is not None and options["command"] else None


def spot(models, posture_model, trajectory, frame_width: int, spotting: str) -> list[dict]:
    """The board application's results on a trajectory in a spotting mode
    (:func:`stream_results` or :func:`board_results`), each frame's posture
    by ``posture_model`` given to it as the posture slave gives it."""
    if spotting == "continuous":
        postures = frame_postures(posture_model, trajectory) if posture_model is not None \
            else None
        return stream_results(models, trajectory, frame_width, postures=postures)
    from sw_hps.posture_commands import postures_for_frame
    needs = postures_for_frame(getattr(models, "postures", None), frame_width) is not None
    return board_results(models, trajectory, posture_model=posture_model if needs else None)


def flagged_spans(flag) -> list[tuple[int, int]]:
    """First and last frame of every run of flagged frames, in order."""
    flag = np.asarray(flag, bool).astype(np.int8)
    edges = np.diff(np.concatenate([[0], flag, [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(),
                    (np.flatnonzero(edges == -1) - 1).tolist()))


def board_results(models, trajectory, first_frame: int = 0, posture_model=None) -> list[dict]:
    """The board application on a trajectory (a simulated FIFO; a gesture
    still flagged at the trajectory's end ends there, as the FIFO then holds
    still frames): :func:`gesture_entries` of what it finished. With
    ``posture_model`` a simulated posture slave gives it each frame's posture
    record as the core does (needed by models with a ``postures`` entry)."""
    from sw_hps.simulated import run_on_trajectory
    records = trajectory.posture if posture_model is not None else None
    if posture_model is not None and (records is None or not len(records)):
        raise ValueError("the trajectory has no posture records (the pipeline ran without "
                         "its posture path)")
    board = run_on_trajectory(models, trajectory.smoothed[:, 0], trajectory.smoothed[:, 1],
                              trajectory.flag, pixels=False, posture_records=records,
                              posture_model=posture_model)
    return gesture_entries([r.to_dict() for r in board.results], trajectory.flag, first_frame,
                           commands=posture_model is not None)


def gesture_entries(results: list[dict], flag, first_frame: int = 0,
                    commands: bool = False) -> list[dict]:
    """The board application's results (``GestureResult.to_dict()``, in order)
    beside the flagged runs of ``flag`` they came from: one entry per gesture,
    with ``outcome`` (recognised, rejected or dropped), ``name`` (None unless
    recognised), ``first`` and ``last`` (its flagged frames, numbered from
    ``first_frame``), ``telegram`` (hex, None unless sent) and ``score`` (the
    named class' log-likelihood, None unless recognised); with ``commands``
    (the application applied posture commands) also the verdict's
    ``posture``, ``posture_share``, ``power`` and ``by_posture``."""
    spans = flagged_spans(flag)
    # the application finishes one gesture per flagged run, in order (a stop by
    # posture is no flagged run)
    gestures = [r for r in results if not r.get("by_posture")]
    if len(spans) != len(gestures):
        spans = [(None, None)] * len(gestures)
    spans = iter(spans)
    out = []
    for r in results:
        first, last = (None, None) if r.get("by_posture") else next(spans)
        recognised = r["outcome"] == "recognised"
        score = r["scores"][r["class_index"]] if recognised and r["scores"] else None
        out.append({
            "outcome": r["outcome"], "name": r["class_name"] if recognised else None,
            "first": None if first is None else first + first_frame,
            "last": None if last is None else last + first_frame,
            "telegram": r["telegram"] if r["sent"] else None,
            "score": None if score is None else round(float(score), 3),
            # the posture commands' verdict (without them add_postures names the posture)
            **{key: r[key] for key in ("posture", "posture_share", "power", "by_posture")
               if commands and r.get(key) not in (None, False)}})
    return out


def stream_results(models, trajectory, frame_width: int, first_frame: int = 0,
                   postures=None) -> list[dict]:
    """The board application's continuous spotting (``--spotting continuous``:
    :class:`sw_hps.streaming.StreamSpotter`, what it runs on each record of the
    FIFO's streaming mode) on a trajectory's records, the source's end
    flushing: entries like :func:`board_results` (every one recognised; the
    threshold model refuses the rest). ``postures``: each frame's posture
    (:func:`frame_postures`), which models with a ``postures`` entry need;
    their entries carry ``posture``, ``posture_share``, ``power`` and
    ``by_posture`` (a stop by posture)."""
    from sw_hps.streaming import StreamSpotter
    from sw_hps.telegram import GESTURE_NAMES, telegram
    spotter = StreamSpotter(models, frame_width)
    if postures is None or spotter.commands is None:
        if spotter.commands is not None:
            raise ValueError("the model file's postures entry needs each frame's posture "
                             "(a posture model)")
        postures = [None] * len(trajectory.area)
    named = []
    for (x, y), area, posture in zip(trajectory.smoothed, trajectory.area, postures):
        named += spotter.take(int(x), int(y), bool(area), posture)
    named += spotter.flush()
    posture_keys = spotter.commands is not None
    return [{"outcome": "recognised", "name": d.name, "first": d.first + first_frame,
             "last": d.last + first_frame, "named_at": d.named_at + first_frame,
             "telegram": telegram(d.name, power=d.power).hex(" ")
             if d.name in GESTURE_NAMES else None,
             "score": round(float(d.score), 3),
             **({"posture": d.posture, "posture_share": d.posture_share, "power": d.power,
                 "by_posture": d.by_posture} if posture_keys else {})} for d in named]


def sequence_score(results: list[dict], sequence) -> dict:
    """The named gestures (:func:`board_results` / :func:`stream_results`
    entries, recognised ones) against a rendered sequence's truth
    (``Clip.sequence``), matched as :func:`recognition.continuous.match_detections`
    matches (right label, overlapping the true span by half the shorter):
    true gestures, named, correct, false commands and, per matched gesture,
    the frames from its true end to its naming (``named_at``; the last
    flagged frame in the thesis mode)."""
    from types import SimpleNamespace

    from recognition.continuous import match_detections
    named = [SimpleNamespace(name=r["name"], first=r["first"], last=r["last"],
                             named_at=r.get("named_at", r["last"]))
             for r in results if r["outcome"] == "recognised"]
    spans = [(a, b) for _, a, b in sequence]
    matched, latencies = match_detections(named, spans, [g for g, _, _ in sequence])
    return {"true": len(spans), "named": len(named),
            "correct": sum(k >= 0 for k in matched), "false": sum(k < 0 for k in matched),
            "latencies": [int(v) for v in latencies]}


def recognised_gestures(results: list[dict]) -> list[dict]:
    """The recognised entries of :func:`board_results` as ``--json`` lists
    them: ``name``, ``first``, ``last``, ``telegram``, ``score``."""
    return [{key: r[key] for key in ("name", "first", "last", "telegram", "score")
             + tuple(k for k in ("posture", "posture_share", "power", "by_posture") if k in r)}
            for r in results if r["outcome"] == "recognised"]


def recognise(models, trajectory):
    """The board application on a trajectory (a simulated FIFO): the last
    recognised gesture (None) and its NXT telegram (hex, or None)."""
    gestures = recognised_gestures(board_results(models, trajectory))
    if not gestures:
        return None, None
    return gestures[-1]["name"], gestures[-1]["telegram"]


def lost_stage(stages, params) -> str:
    """Which stage lost the hand in frames where the opening found none
    (``stages``: :class:`sim.model.pipeline.FrameStages` of some of them)."""
    stages = list(stages)
    if not any(s.skin.any() for s in stages):
        return (f"the skin mask is empty: no pixel has Cb in {list(params.skin_cb)} and Cr in "
                f"{list(params.skin_cr)} (lighting, white balance or no hand in view)")
    if not any(s.band.any() for s in stages):
        return (f"the disparity band is empty: nothing lies at the hand's depth "
                f"({params.band_low} < d < {params.band_high or params.max_disparity - 2}; "
                f"are the two cameras showing the same picture, or is the hand too far?)")
    if not any(s.hand.any() for s in stages):
        return (f"skin and the disparity band never overlap: the skin lies outside "
                f"{params.band_low} < d < {params.band_high or params.max_disparity - 2} "
                f"(the hand too far or too near; disparities shrink with the frame size)")
    return (f"the {params.opening_size}x{params.opening_size} opening erased the hand: it is "
            f"too small in the frame (a larger frame or a nearer hand)")


def warn_if_empty(trajectory, params, width: int, height: int, quiet: bool = False,
                  stages=None) -> None:
    """Say on stderr when the opening found no hand at all, naming the stage
    that lost it where some frames' ``stages`` are known, or when no gesture
    was flagged (the results then name no gesture, which is not an error)."""
    if not trajectory.area.any():
        why = lost_stage(stages, params) if stages else \
            "no stage pictures to tell which stage lost it (--backend model has them)"
        print(f"warning: no hand found in any of {len(trajectory.area)} frames at "
              f"{width}x{height}: {why}", file=sys.stderr)
    elif not trajectory.flag.any():
        print(f"warning: no gesture was flagged (the hand never moved Tm = "
              f"{params.spot_threshold} px within {params.spot_window} frames)",
              file=sys.stderr)
