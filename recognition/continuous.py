"""Continuous recognition measured (issue 28): the board's
:class:`sw_hps.continuous.ContinuousRecogniser` run over joined streams
(:mod:`recognition.streams`) of people its models never saw.

* :func:`spot_stream`: one stream through the symboliser and the recogniser,
  frame by frame, as the board runs it; the source's end flushes.
* :func:`match_detections`: a detection counts when its label is right and it
  overlaps the true span by at least half of the shorter of the two; each
  true gesture is matched at most once. Unmatched detections are false
  commands (a wrong label, a gesture named twice, a command in a transit).
* :func:`leave_one_subject_out`: per subject, discrete models trained on the
  other subjects' isolated gestures, then that subject's gestures joined into
  streams and spotted. Nothing is tuned on the held-out subject: the threshold
  model's ``threshold_bias`` and then the ``end_delay`` are chosen by
  :func:`calibrate_spotting` on the training subjects alone (two halves, each
  spotted by models of the other), unless given; ``max_gap`` and
  ``max_gap_share`` are learned from the training gestures.
"""
from __future__ import annotations

import numpy as np

from recognition.datasets import TrajectorySet
from recognition.hmm_train import train_models
from recognition.streams import GestureStream, distractor_stream, gesture_extent, subject_streams
from sim.distractors import DISTRACTOR_KINDS
from sw_hps.continuous import SPOTTING_DEFAULTS, ContinuousRecogniser, Detection
from sw_hps.orientation import DistanceSymbols

__all__ = ["spot_stream", "symbol_gap", "symbol_gap_share", "GAP_QUANTILE", "match_detections", "leave_one_subject_out", "stream_summary",
           "idle_stream",
           "calibrate_spotting", "train_continuous", "stream_pixels", "distance_sequences",
           "BIAS_GRID", "END_DELAY_GRID", "FRONT_ENDS"]

#: Threshold biases :func:`calibrate_spotting` tries (log-likelihood per symbol).
BIAS_GRID = (-2.0, -1.5, -1.25, -1.0, -0.75, -0.5, -0.25, 0.0)
#: End delays (frames) :func:`calibrate_spotting` tries. A vocabulary whose
#: gestures are pieces of one another (the $1 set: a longer gesture over the
#: same symbols must get the time to win) needs a longer one than the robot
#: gestures, whose figures did not move from 1 to 8 frames (development data,
#: :data:`sw_hps.continuous.SPOTTING_DEFAULTS`).
END_DELAY_GRID = (2, 4, 8)


#: How positions become the integers the symboliser counts in: ``pen``
#: rounds them; ``camera`` runs them through the FPGA's centroid smoothing
#: (the moving average of :func:`sim.model.pipeline.track`) and keeps the
#: whole pixels of its 10.8 output, what the board reads from the FIFO.
FRONT_ENDS = ("pen", "camera")


def stream_pixels(points, front_end: str = "pen", present=None) -> np.ndarray:
    """(T, 2) integer positions of a per-frame stream of pixel positions as
    the symboliser gets them (:data:`FRONT_ENDS`); ``present`` (T,) bool: the
    frames with a hand in view (None: all), which the camera's smoothing
    averages over."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if front_end == "pen":
        return np.rint(points).astype(np.int64)
    if front_end == "camera":
        from sim.model.pipeline import PipelineParams, track
        params = PipelineParams()
        areas = np.ones(len(points), np.int64) if present is None \
            else np.asarray(present, dtype=np.int64)
        smoothed = track(np.floor(np.maximum(points, 0)).astype(np.int64), areas,
                         params).smoothed
        return smoothed >> params.frac_bits
    raise ValueError(f"front_end must be one of {', '.join(FRONT_ENDS)}, got {front_end!r}")


def distance_sequences(data: TrajectorySet, step: int, front_end: str = "pen") -> list:
    """The symbols of each trajectory of ``data`` at ``step`` pixels of travel."""
    symbolise = DistanceSymbols(step)
    return [symbolise.symbols(stream_pixels(t, front_end)) for t in data.trajectories()]


#: Share of the training gestures :func:`symbol_gap` keeps whole: chosen on
#: the development corpus (synthetic, seed 11; 0.995 against 1.0 and 0.99,
#: leave one subject out with distractors: F1 96.4 % against 92.6 % and 96.4 %,
#: 15 against 40 and 14 commands per 10 minutes of distractors alone).
GAP_QUANTILE = 0.995


def _symbol_frames(data: TrajectorySet, step: int, front_end: str) -> list:
    """Per trajectory of ``data``: the frames of its symbols (``step`` pixels
    of travel per symbol)."""
    out = []
    for trajectory in data.trajectories():
        symbolise = DistanceSymbols(step)
        out.append(np.array([f for f, p in enumerate(stream_pixels(trajectory, front_end))
                             if symbolise.push(p) is not None], np.int64))
    return out


def _longest_wait(frames, quantile: float | None) -> int:
    longest = [int(np.diff(f).max()) if len(f) > 1 else 0 for f in frames]
    quantile = GAP_QUANTILE if quantile is None else quantile
    return int(np.ceil(np.quantile(longest, quantile))) if longest else 0


def _wait_share(frames, quantile: float | None) -> float:
    shares = [float(np.diff(f).max()) / float(f[-1] - f[0])
              for f in frames if len(f) > 2 and f[-1] > f[0]]
    quantile = GAP_QUANTILE if quantile is None else quantile
    return min(1.0, float(np.ceil(1000 * np.quantile(shares, quantile)) / 1000)) \
        if shares else 0.0


def symbol_gap(data: TrajectorySet, step: int, front_end: str = "pen",
               quantile: float | None = None) -> int:
    """The spotting option ``max_gap`` (:mod:`sw_hps.continuous`) learned from
    gestures: per trajectory of ``data`` the longest wait, in frames, between
    two successive symbols (``step`` pixels of travel per symbol), and of
    those the ``quantile`` (1: the longest, so that no training gesture would
    be cut), rounded up."""
    return _longest_wait(_symbol_frames(data, step, front_end), quantile)


def symbol_gap_share(data: TrajectorySet, step: int, front_end: str = "pen",
                     quantile: float | None = None) -> float:
    """The spotting option ``max_gap_share`` (:mod:`sw_hps.continuous`)
    learned from gestures: per trajectory of ``data`` with three or more
    symbols, its longest wait between two successive symbols over its span
    (first symbol to last, frames), and of those the ``quantile``, rounded up
    to a thousandth (0: no trajectory has three symbols)."""
    return _wait_share(_symbol_frames(data, step, front_end), quantile)


def _learned_gaps(frames, spotting: dict | None) -> dict:
    """``max_gap`` (:func:`symbol_gap`) and ``max_gap_share``
    (:func:`symbol_gap_share`) from the training gestures' symbol ``frames``,
    each unless ``spotting`` gives it."""
    given = spotting or {}
    learned = {}
    if "max_gap" not in given:
        learned["max_gap"] = _longest_wait(frames, None)
    if "max_gap_share" not in given:
        learned["max_gap_share"] = _wait_share(frames, None)
    return learned


def spot_stream(recogniser: ContinuousRecogniser, points, step: int,
                front_end: str = "pen", present=None) -> list[Detection]:
    """The gestures ``recogniser`` names in one stream of positions (one per
    frame, in pixels, made integers by ``front_end``, :data:`FRONT_ENDS`).
    A frame whose ``present`` is false (no hand in view) flushes, as the
    board's :class:`sw_hps.streaming.StreamSpotter` does."""
    recogniser.reset()
    symbols = DistanceSymbols(step)
    named = []
    present = np.ones(len(points), bool) if present is None else np.asarray(present, bool)
    points = stream_pixels(points, front_end, present)
    for frame, (point, seen) in enumerate(zip(points, present)):
        if not seen:
            symbols.reset()
            named += recogniser.flush(frame)
            continue
        named += recogniser.step(frame, symbols.push(point))
    named += recogniser.flush(len(points) - 1)
    return named


def match_detections(detections, spans, labels):
    """``(matched, latencies)``: per detection the index of the true gesture it
    matches (-1: a false command); per matched true gesture the frames from its
    true last frame to the frame it was named."""
    spans = np.asarray(spans).reshape(-1, 2)
    used = np.zeros(len(spans), bool)
    matched, latencies = [], []
    for det in detections:
        hit = -1
        for k, ((first, last), label) in enumerate(zip(spans, labels)):
            if used[k] or label != det.name:
                continue
            overlap = min(last, det.last) - max(first, det.first) + 1
            shorter = min(last - first + 1, det.last - det.first + 1)
            if overlap >= 0.5 * shorter:
                hit = k
                break
        if hit >= 0:
            used[hit] = True
            latencies.append(det.named_at - int(spans[hit][1]))
        matched.append(hit)
    return matched, latencies


def stream_summary(true_count: int, detections: int, correct: int, latencies,
                   transit_frames: int, false_commands: int, fps: float = 30.0) -> dict:
    """Precision, recall, F1, latency quantiles and false commands per 10 minutes
    of motion between gestures (at ``fps``)."""
    precision = correct / detections if detections else 1.0
    recall = correct / true_count if true_count else 1.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0
    lat = np.asarray(latencies, dtype=np.float64)
    minutes = transit_frames / fps / 60.0
    return {"gestures": true_count, "detections": detections, "correct": correct,
            "precision": precision, "recall": recall, "f1": f1,
            "latency_median_frames": float(np.median(lat)) if lat.size else None,
            "latency_p95_frames": float(np.percentile(lat, 95)) if lat.size else None,
            "false_commands": false_commands, "between_gesture_frames": transit_frames,
            "false_commands_per_10_min": (10.0 * false_commands / minutes) if minutes else None}


def _spot_counts(recogniser, streams, step,
                 front_end: str = "pen") -> tuple[int, int, int, list, int, int]:
    """(true, detections, correct, latencies, between-gesture frames, false)."""
    true = det = correct = between = false = 0
    latencies = []
    for stream in streams:
        found = spot_stream(recogniser, stream.points, step, front_end, stream.present)
        matched, lat = match_detections(found, stream.spans, stream.labels)
        true += len(stream.spans)
        det += len(found)
        correct += sum(k >= 0 for k in matched)
        false += sum(k < 0 for k in matched)
        between += _between_frames(stream)
        latencies += lat
    return true, det, correct, latencies, between, false


def calibrate_spotting(data: TrajectorySet, sequences, *, states: int, step: int,
                       emission_floor: float, per_stream: int, pause, seed: int,
                       spotting: dict, grid=BIAS_GRID, delays=END_DELAY_GRID,
                       front_end: str = "pen",
                       distractors: bool = False) -> tuple[dict, dict]:
    """The spotting options chosen on ``data``'s subjects (training subjects
    only): they are dealt into two halves, each half's streams spotted by
    models trained on the other. First the threshold bias of ``grid`` with the
    best F1 at ``spotting``'s end delay (ties go to the larger bias, the
    stricter threshold), then, at that bias, the end delay of ``delays`` with
    the best F1 (ties go to the shorter delay; ``delays`` None or empty keeps
    ``spotting``'s). Returns the chosen ``{"threshold_bias", "end_delay"}``
    and the F1 of each value tried (``{"threshold_bias": {...},
    "end_delay": {...}}``)."""
    subjects = np.unique(data.subject)
    if subjects.size < 2:
        raise ValueError("calibration needs at least two training subjects")
    halves = [subjects[0::2], subjects[1::2]]
    folds = []
    for k in range(2):
        train = np.flatnonzero(np.isin(data.subject, halves[1 - k]))
        test = np.flatnonzero(np.isin(data.subject, halves[k]))
        models = train_models([sequences[i] for i in train], data.label[train],
                              data.class_names, states, emission_floor=emission_floor)
        folds.append((models, subject_streams(data.subset(test), per_stream, seed, pause=pause,
                                              distractors=distractors)))

    def f1_of(options):
        true = det = correct = 0
        for models, streams in folds:
            t, d, c, *_ = _spot_counts(ContinuousRecogniser(models, **options), streams, step,
                                       front_end)
            true, det, correct = true + t, det + d, correct + c
        return 2 * correct / (true + det) if true + det else 0.0

    f1 = {b: f1_of(dict(spotting, threshold_bias=b)) for b in grid}
    bias = float(max(grid, key=lambda b: (f1[b], b)))
    chosen = {"threshold_bias": bias, "end_delay": spotting["end_delay"]}
    report = {"threshold_bias": {str(b): round(v, 4) for b, v in f1.items()}}
    if delays:
        f1_delay = {d: f1_of(dict(spotting, threshold_bias=bias, end_delay=d)) for d in delays}
        chosen["end_delay"] = int(max(delays, key=lambda d: (f1_delay[d], -d)))
        report["end_delay"] = {str(d): round(v, 4) for d, v in f1_delay.items()}
    return chosen, report


def _between_frames(stream: GestureStream) -> int:
    inside = int((stream.spans[:, 1] - stream.spans[:, 0] + 1).sum())
    return len(stream) - inside


def idle_stream(data: TrajectorySet, steps: int, seed: int, *, pause=(0, 15),
                subject: int = 0, kind: str | None = None) -> GestureStream:
    """``steps`` steps of distractors alone (:func:`recognition.streams.
    distractor_stream`; of one ``kind``, or of every kind) from the median
    start of ``data``'s gestures, in units of their median extent."""
    parts = data.trajectories()
    start = np.median([np.asarray(p, dtype=np.float64)[0] for p in parts], axis=0)
    kinds = DISTRACTOR_KINDS if kind is None else (kind,)
    return distractor_stream(start, gesture_extent(parts), steps,
                             np.random.default_rng([seed, subject, len(kinds)]), pause=pause,
                             subject=subject, kinds=kinds)


def leave_one_subject_out(data: TrajectorySet, *, states: int = 12, step: int = 6,
                          emission_floor: float = 1e-3, per_stream: int = 8,
                          pause=(0, 15), seed: int = 0, spotting: dict | None = None,
                          fps: float = 30.0, front_end: str = "pen",
                          distractors: bool = False, idle_steps: int = 0) -> dict:
    """Continuous recognition of every subject of ``data`` by models trained on
    the others (module docstring); JSON-ready figures, overall and per subject.
    ``distractors``: a distractor before every gesture (in the calibration's
    streams too); ``idle_steps``: per held-out subject, that many steps of
    distractors alone (every kind, in rounds of a random order), its commands
    counted as ``idle`` (all false); ``kind_alone`` counts the commands in a
    sixth as many steps of each kind alone (back to back: a diagnosis)."""
    if data.subject is None:
        raise ValueError("the dataset has no subject (or writer) key")
    names = data.class_names
    options = dict(SPOTTING_DEFAULTS, **(spotting or {}), step=step)
    calibrate = "threshold_bias" not in (spotting or {})
    delays = END_DELAY_GRID if "end_delay" not in (spotting or {}) else None
    sequences = distance_sequences(data, step, front_end)
    frames = _symbol_frames(data, step, front_end)
    per_subject = {}
    totals = np.zeros(5, np.int64)           # true, detections, correct, between, false
    all_latencies = []
    idle_false = 0
    idle_by_kind = dict.fromkeys(DISTRACTOR_KINDS, 0)
    for subject in np.unique(data.subject):
        train = np.flatnonzero(data.subject != subject)
        fold = dict(options, **_learned_gaps([frames[i] for i in train], spotting))
        calibration = None
        if calibrate:
            chosen, calibration = calibrate_spotting(
                data.subset(train), [sequences[i] for i in train], states=states, step=step,
                emission_floor=emission_floor, per_stream=per_stream, pause=pause, seed=seed,
                spotting=fold, delays=delays, front_end=front_end, distractors=distractors)
            fold.update(chosen)
        models = train_models([sequences[i] for i in train], data.label[train], names, states,
                              emission_floor=emission_floor)
        held = data.subset(np.flatnonzero(data.subject == subject))
        streams = subject_streams(held, per_stream, seed, pause=pause, distractors=distractors)
        recogniser = ContinuousRecogniser(models, **fold)
        true, det, correct, latencies, between, false = _spot_counts(
            recogniser, streams, step, front_end)
        per_subject[int(subject)] = dict(
            stream_summary(true, det, correct, latencies, between, false, fps),
            threshold_bias=fold["threshold_bias"], end_delay=fold["end_delay"],
            max_gap=fold["max_gap"],
            max_gap_share=fold["max_gap_share"],
            calibration_f1=calibration)
        if idle_steps:
            idle = idle_stream(held, idle_steps, seed, pause=pause, subject=int(subject))
            named = len(spot_stream(recogniser, idle.points, step, front_end, idle.present))
            per_subject[int(subject)]["idle_false_commands"] = named
            idle_false += named
            for kind in DISTRACTOR_KINDS:     # the diagnosis: each kind alone
                idle = idle_stream(held, idle_steps // len(DISTRACTOR_KINDS), seed, pause=pause,
                                   subject=int(subject), kind=kind)
                idle_by_kind[kind] += len(spot_stream(recogniser, idle.points, step, front_end,
                                                      idle.present))
        totals += (true, det, correct, between, false)
        all_latencies += latencies
    true, det, correct, between, false = (int(v) for v in totals)
    overall = stream_summary(true, det, correct, all_latencies, between, false, fps)
    return {"protocol": "leave one subject out", "front_end": front_end,
            "states": states, "step": step,
            "emission_floor": emission_floor, "per_stream": per_stream,
            "pause": list(pause), "seed": seed, "spotting": options,
            "distractors": distractors, "overall": overall,
            "idle": dict(_idle_summary(idle_false, idle_steps * len(per_subject), fps),
                         kind_alone=idle_by_kind) if idle_steps else None,
            "per_subject": per_subject}


def _idle_summary(false: int, frames: int, fps: float) -> dict:
    minutes = frames / fps / 60.0
    return {"frames": frames, "minutes": round(minutes, 2), "false_commands": false,
            "false_commands_per_10_min": 10.0 * false / minutes}


def train_continuous(data: TrajectorySet, *, states: int = 8,
                     step: int = SPOTTING_DEFAULTS["step"],
                     emission_floor: float = 1e-3, per_stream: int = 8, pause=(0, 15),
                     seed: int = 0, spotting: dict | None = None, front_end: str = "camera",
                     meta: dict | None = None):
    """Models for the board's continuous spotting: discrete class models
    trained on every trajectory's distance symbols, with a ``spotting`` entry
    (``step``; the threshold bias and the end delay :func:`calibrate_spotting`
    chooses on ``data``'s subjects, unless ``spotting`` gives the bias, or the
    delay; ``max_gap`` and ``max_gap_share`` learned from the gestures).
    Returns (:class:`sw_hps.hmm.GestureModels`, the calibration's F1 per value
    tried, or None)."""
    import dataclasses
    if data.subject is None:
        raise ValueError("the dataset has no subject (or writer) key: the threshold bias is "
                         "calibrated on held-out subjects")
    options = dict(SPOTTING_DEFAULTS, **(spotting or {}), step=step)
    options.update(_learned_gaps(_symbol_frames(data, step, front_end), spotting))
    sequences = distance_sequences(data, step, front_end)
    calibration = None
    if "threshold_bias" not in (spotting or {}):
        chosen, calibration = calibrate_spotting(
            data, sequences, states=states, step=step, emission_floor=emission_floor,
            per_stream=per_stream, pause=pause, seed=seed, spotting=options,
            delays=END_DELAY_GRID if "end_delay" not in (spotting or {}) else None,
            front_end=front_end)
        options.update(chosen)
    models = train_models(sequences, data.label, data.class_names, states,
                          emission_floor=emission_floor,
                          meta=dict(meta or {}, front_end=front_end, symbols="distance",
                                    spotting_calibration=calibration))
    return dataclasses.replace(models, spotting=options), calibration
