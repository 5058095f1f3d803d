"""Train one left-right HMM per gesture class from a labelled trajectory
dataset and write the model file the board application loads.

--emission gaussian (the default, the best measured: docs/figures/recognition.md): whole-
gesture features (direction, position, arc fraction, turn) with Gaussian
emissions, several components per class (recognition.gaussian_train).
--emission discrete: the thesis' 8 orientation symbols and Baum-Welch (§7.4,
eq. 29-33); with --states 5 and no floor it is §9.4's recogniser. With
--cv-states (discrete only), first cross-validate every number of states in
the range (thesis Fig. 108: JSON and PNG report), then train the final
models on all the data with the best one.

Unless --no-reject, the model file carries per-class rejection thresholds
calibrated on held-out groups of subjects (recognition.recogniser): a
gesture scoring below its class' threshold is refused ("none").

Trajectories go through the camera front end (the FPGA's centroid smoothing
and gesture spotting), or, with --resample N, are pen strokes resampled to N
points equally spaced along the path."""
from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path

from stereogest.commands import DEFAULT_SEED, add_json_switch, check_output_file

NAME = "train"
HELP = "train the gesture HMMs (optionally choosing the number of states by cross-validation)"

_DEFAULT_STATES = 5
#: --continuous: states per class model (chosen on one synthetic corpus, its
#: figures measured on another; docs/figures/recognition.md, "Continuous recognition")
_CONTINUOUS_STATES = 8
_DEFAULT_FOLDS = 10



def add_arguments(p):
    from recognition.hmm_train import (DEFAULT_EXPECTED_LENGTH, DEFAULT_MAX_ITER,
                                       DEFAULT_TOL, MAX_STATES)
    p.add_argument("data", metavar="DATA.npz",
                   help="trajectory dataset (points, offsets, label: strings, or integers with "
                        "class_names; optional subject, or writer as the subject)")
    p.add_argument("-o", "--output", metavar="MODEL.json", required=True,
                   help="model file to write")
    from recognition.gaussian_train import DEFAULT_STATES as _GAUSSIAN_STATES
    from recognition.gaussian_train import MAX_AUTO_COMPONENTS as _MAX_AUTO
    from recognition.gaussian_train import SAMPLES_PER_COMPONENT as _PER_COMPONENT
    from recognition.recogniser import (DEFAULT_CALIBRATION_FOLDS, DEFAULT_EMISSION,
                                        DEFAULT_REJECT_BUDGET, DEFAULT_REJECT_MARGIN,
                                        DEFAULT_REJECT_QUANTILE,
                                        EMISSIONS)
    p.add_argument("--emission", choices=EMISSIONS, default=DEFAULT_EMISSION,
                   help=f"emission model (default {DEFAULT_EMISSION})")
    p.add_argument("--states", type=int, default=None, metavar="N",
                   help=f"states per model, 1..{MAX_STATES} (default {_DEFAULT_STATES} discrete, "
                        f"{_CONTINUOUS_STATES} --continuous, "
                        f"{_GAUSSIAN_STATES} gaussian; not with --cv-states)")
    p.add_argument("--components", type=int, default=None, metavar="K",
                   help="gaussian: most components per class, 1..16 (default: one per "
                        f"{_PER_COMPONENT} training samples, 1..{_MAX_AUTO})")
    p.add_argument("--no-reject", dest="reject", action="store_false",
                   help="no rejection thresholds (every gesture gets a class)")
    p.add_argument("--reject-quantile", type=float, default=DEFAULT_REJECT_QUANTILE,
                   metavar="Q", help="refuse below this quantile of held-out in-vocabulary "
                                     f"per-step scores, 0 <= Q < 0.5 (default "
                                     f"{DEFAULT_REJECT_QUANTILE})")
    p.add_argument("--reject-margin", default=str(DEFAULT_REJECT_MARGIN), metavar="M",
                   help="less this margin (per-step log-likelihood), >= 0, or auto: the "
                        "smallest that refuses at most --reject-budget of every held-out "
                        f"calibration group's gestures (default {DEFAULT_REJECT_MARGIN})")
    p.add_argument("--reject-budget", type=float, default=DEFAULT_REJECT_BUDGET, metavar="B",
                   help="with --reject-margin auto, the share of a held-out group's gestures "
                        f"the margin may refuse, 0 <= B < 0.5 (default {DEFAULT_REJECT_BUDGET})")
    p.add_argument("--calibration-folds", type=int, default=DEFAULT_CALIBRATION_FOLDS,
                   metavar="K", help="groups of subjects held out to calibrate the "
                                     f"rejection, >= 2 (default {DEFAULT_CALIBRATION_FOLDS})")
    p.add_argument("--cv-states", metavar="RANGE", default=None,
                   help="cross-validate these state counts, e.g. 2-20 or 3,5,8, then train "
                        "with the best")
    p.add_argument("--folds", type=int, default=None, metavar="K",
                   help=f"folds of the stratified cross-validation, 2..samples "
                        f"(default {_DEFAULT_FOLDS})")
    p.add_argument("--groups", metavar="KEY", default=None,
                   help="cross-validate leave-one-group-out over this per-trajectory key of "
                        "DATA.npz (e.g. subject, or writer) instead of k folds")
    p.add_argument("--resample", type=int, default=None, metavar="N",
                   help="pen front end: resample each path to N points, 2..4096 "
                        "(default: camera front end)")
    p.add_argument("--tol", type=float, default=DEFAULT_TOL,
                   help="stop Baum-Welch when the log-likelihood improves by less than this")
    p.add_argument("--max-iter", type=int, default=DEFAULT_MAX_ITER, metavar="I",
                   help="most Baum-Welch re-estimations, >= 1")
    p.add_argument("--emission-floor", type=float, default=0.0, metavar="F",
                   help="lowest emission probability after each re-estimation, 0 <= F < 1/8 "
                        "(0 = thesis; e.g. 1e-3 keeps one unseen symbol from being fatal)")
    p.add_argument("--expected-length", type=int, default=DEFAULT_EXPECTED_LENGTH, metavar="T",
                   help="expected symbols per gesture (T of the initial model, eq. 29-33), "
                        ">= states")
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="run the cross-validation on this Dask scheduler (tcp://host:8786)")
    p.add_argument("--jobs", type=int, default=None, metavar="J",
                   help="local worker processes for the cross-validation (default: CPUs)")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, metavar="S",
                   help="seed of the fold shuffle (>= 0)")
    p.add_argument("--report", metavar="PREFIX", default=None,
                   help="cross-validation report PREFIX.json and PREFIX.png "
                        "(default: MODEL without .json, plus -cv)")
    p.add_argument("--continuous", action="store_true",
                   help="models for the board's continuous spotting (python -m sw_hps "
                        "--spotting continuous): discrete, symbols at equal travel, the "
                        "threshold bias calibrated on the dataset's subjects (two halves); "
                        "no per-class rejection (the threshold model refuses)")
    from sw_hps.continuous import SPOTTING_DEFAULTS
    p.add_argument("--step", type=int, default=None, metavar="PX",
                   help="--continuous: pixels of travel per symbol at 640 wide, 1..640 "
                        f"(default {SPOTTING_DEFAULTS['step']})")
    p.add_argument("--verifier", metavar="MODEL.json", default=None,
                   help="--continuous: a gaussian model file of the same classes, with "
                        "rejection (as the default train writes), kept in the output: each "
                        "spotted gesture is named only if it names the gesture's path the "
                        "same class without refusing it")
    p.add_argument("--commands", metavar="CLASS=COMMAND,...", default=None,
                   help="the robot command each class sends (one of forward, back, right, "
                        "left, rotate-right, rotate-left, stop), for classes named otherwise; "
                        "a class that maps to none is warned about here and refused by the "
                        "board application")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_json_switch(p, always=True)


def parse_state_range(text: str) -> list[int]:
    """``"2-20"``, ``"5"`` or ``"3,5,8-10"`` to a sorted list of state counts."""
    from recognition.hmm_train import MAX_STATES
    allowed = f"A-B or a comma list, states in 1..{MAX_STATES}, A <= B"
    counts = set()
    try:
        for part in text.split(","):
            lo, sep, hi = part.strip().partition("-")
            lo = int(lo)
            hi = int(hi) if sep else lo
            if not 1 <= lo <= hi <= MAX_STATES:
                raise ValueError
            counts.update(range(lo, hi + 1))
    except ValueError:
        raise ValueError(f"--cv-states must be {allowed}, got {text!r}") from None
    return sorted(counts)


def _check_options(args) -> list[int] | None:
    from recognition.features import RESAMPLE_RANGE
    from recognition.hmm_train import MAX_STATES
    from recognition.recogniser import DEFAULT_REJECT_BUDGET
    cv_states = None
    gaussian = args.emission == "gaussian"
    if args.step is not None and not args.continuous:
        raise ValueError("--step applies to --continuous")
    if args.verifier is not None and not args.continuous:
        raise ValueError("--verifier applies to --continuous")
    if args.continuous:
        if args.emission != "discrete":
            raise ValueError("--continuous needs --emission discrete (the threshold model is "
                             "built from discrete states)")
        for option, value in (("--cv-states", args.cv_states), ("--resample", args.resample),
                              ("--groups", args.groups), ("--folds", args.folds)):
            if value is not None:
                raise ValueError(f"{option} does not apply with --continuous")
        if args.step is not None and not 1 <= args.step <= 640:
            raise ValueError(f"--step must be in 1..640 pixels, got {args.step}")
        if args.states is None:
            args.states = _CONTINUOUS_STATES
    if gaussian:
        from recognition.gaussian_train import DEFAULT_RESAMPLE
        if args.cv_states is not None:
            raise ValueError("--cv-states applies to --emission discrete (the gaussian "
                             "defaults were chosen by leave-one-subject-out; "
                             "docs/design/recognition.md)")
        top = (args.resample or DEFAULT_RESAMPLE) - 1
        if args.states is not None and not 1 <= args.states <= min(MAX_STATES, top):
            raise ValueError(f"--states must be in 1..{min(MAX_STATES, top)} for gaussian "
                             f"models of {top + 1} resampled points, got {args.states}")
        if args.resample is not None and args.resample < 3:
            raise ValueError(f"--resample must be >= 3 for gaussian models, got {args.resample}")
        from recognition.hmm_train import DEFAULT_EXPECTED_LENGTH, DEFAULT_MAX_ITER, DEFAULT_TOL
        for option, value, default in (("--tol", args.tol, DEFAULT_TOL),
                                       ("--max-iter", args.max_iter, DEFAULT_MAX_ITER),
                                       ("--emission-floor", args.emission_floor, 0.0),
                                       ("--expected-length", args.expected_length,
                                        DEFAULT_EXPECTED_LENGTH)):
            if value != default:
                raise ValueError(f"{option} applies to --emission discrete")
    elif args.components is not None:
        raise ValueError("--components applies to --emission gaussian")
    if args.components is not None and not 1 <= args.components <= 16:
        raise ValueError(f"--components must be in 1..16, got {args.components}")
    if not 0.0 <= args.reject_quantile < 0.5:
        raise ValueError(f"--reject-quantile must be in [0, 0.5), got {args.reject_quantile}")
    if args.reject_margin == "auto":
        args.reject_margin = None
    else:
        try:
            margin = float(args.reject_margin)
        except ValueError:
            margin = math.nan
        if not (math.isfinite(margin) and margin >= 0):
            raise ValueError(f"--reject-margin must be auto or a finite number >= 0, got "
                             f"{args.reject_margin}")
        args.reject_margin = margin
    if not 0.0 <= args.reject_budget < 0.5:
        raise ValueError(f"--reject-budget must be in [0, 0.5), got {args.reject_budget}")
    if args.reject_budget != DEFAULT_REJECT_BUDGET and args.reject_margin is not None:
        raise ValueError("--reject-budget applies to --reject-margin auto")
    if args.calibration_folds < 2:
        raise ValueError(f"--calibration-folds must be >= 2, got {args.calibration_folds}")
    if gaussian:
        for option, value in (("--folds", args.folds), ("--groups", args.groups),
                              ("--scheduler", args.scheduler), ("--jobs", args.jobs),
                              ("--report", args.report)):
            if value is not None:
                raise ValueError(f"{option} applies to --cv-states (--emission discrete)")
    elif args.cv_states is not None:
        if args.states is not None:
            raise ValueError("--states and --cv-states exclude each other (--cv-states "
                             "chooses the number of states)")
        cv_states = parse_state_range(args.cv_states)
    else:
        for option, value in (("--folds", args.folds), ("--groups", args.groups),
                              ("--scheduler", args.scheduler), ("--jobs", args.jobs),
                              ("--report", args.report)):
            if value is not None:
                raise ValueError(f"{option} applies to cross-validation: give --cv-states too")
        if args.states is None:
            args.states = _DEFAULT_STATES
        if not 1 <= args.states <= MAX_STATES:
            raise ValueError(f"--states must be in 1..{MAX_STATES}, got {args.states}")
    if args.folds is not None and not args.folds >= 2:
        raise ValueError(f"--folds must be >= 2, got {args.folds}")
    if args.folds is not None and args.groups is not None:
        raise ValueError("--folds does not apply with --groups (one fold per group)")
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
    lo, hi = RESAMPLE_RANGE
    if args.resample is not None and not lo <= args.resample <= hi:
        raise ValueError(f"--resample must be in {lo}..{hi}, got {args.resample}")
    if not (math.isfinite(args.tol) and args.tol >= 0):
        raise ValueError(f"--tol must be a finite number >= 0, got {args.tol}")
    if args.max_iter < 1:
        raise ValueError(f"--max-iter must be >= 1, got {args.max_iter}")
    if not 0.0 <= args.emission_floor < 1.0 / 8:
        raise ValueError(f"--emission-floor must be in [0, 0.125) (below 1/8 symbols), "
                         f"got {args.emission_floor}")
    if args.expected_length < 1:
        raise ValueError(f"--expected-length must be >= 1, got {args.expected_length}")
    most = max(cv_states) if cv_states else args.states
    if not gaussian and most > args.expected_length:
        option = "--cv-states" if cv_states else "--states"
        raise ValueError(f"{option} must be <= --expected-length ({args.expected_length}): "
                         f"the initial model needs T/N >= 1, got {most} states")
    if args.seed < 0:
        raise ValueError(f"--seed must be >= 0, got {args.seed}")
    check_output_file(args.output)
    if args.report is not None:
        check_output_file(args.report, "--report")
    return cv_states


def _groups(path: Path, key: str, data):
    """The per-trajectory values of ``key`` in the dataset (``subject``: as loaded,
    i.e. the ``writer`` key of a file without ``subject``)."""
    import numpy as np
    if key == "subject":
        if data.subject is None:
            raise ValueError(f"--groups subject: {path} has no 'subject' or 'writer' array")
        return data.subject
    with np.load(path, allow_pickle=False) as arrays:
        if key not in arrays.files:
            raise ValueError(f"--groups {key}: {path} has no such key (keys: "
                             f"{', '.join(sorted(arrays.files))})")
        values = arrays[key]
    if values.shape != (len(data),) or values.dtype.kind not in "iuUS":
        raise ValueError(f"--groups {key}: must hold one integer or string per trajectory "
                         f"({len(data)}), got shape {values.shape} dtype {values.dtype}")
    return values


def run(args) -> int:
    from recognition.crossval import cross_validate, write_cv_report
    from recognition.datasets import load_trajectories
    from recognition.features import sequences
    from recognition.hmm_train import train_models

    cv_states = _check_options(args)
    say = (lambda text: None) if args.quiet else \
        (lambda text: print(text, file=sys.stderr, flush=True))
    start = time.perf_counter()
    data_path = Path(args.data)
    data = load_trajectories(data_path)
    if len(data) == 0:
        raise ValueError(f"{data_path}: holds no trajectories")
    if len(data.class_names) < 2:
        raise ValueError(f"{data_path}: holds one class ({', '.join(data.class_names)}); a "
                         f"recogniser needs at least 2")
    if args.commands is not None:
        from sw_hps.class_commands import check_commands, parse_commands
        try:
            args.commands = check_commands(parse_commands(args.commands), data.class_names)
        except ValueError as exc:
            raise ValueError(f"--commands: {str(exc).removeprefix('--commands: ')}") from None
    if args.emission == "gaussian":
        return _run_gaussian(args, data, data_path, say, start)
    if args.continuous:
        return _run_continuous(args, data, data_path, say, start)
    groups = _groups(data_path, args.groups, data) if args.groups is not None else None
    front_end = "camera" if args.resample is None else f"pen, resampled to {args.resample}"
    say(f"{len(data)} trajectories, classes {', '.join(data.class_names)}; "
        f"front end: {front_end}")
    seqs = sequences(data, resample=args.resample)
    empty = sum(1 for s in seqs if len(s) == 0)
    if empty:
        say(f"{empty} trajectories give no symbol (ignored in training)")
    options = {"tol": args.tol, "max_iter": args.max_iter,
               "emission_floor": args.emission_floor,
               "expected_length": args.expected_length}
    meta = {"dataset": str(data_path), "resample": args.resample,
            "front_end": "camera" if args.resample is None else "pen"}
    summary = {"output": str(args.output), "classes": list(data.class_names),
               "sequences": len(seqs)}

    states = args.states
    if cv_states is not None:
        folds = _DEFAULT_FOLDS if args.folds is None else args.folds

        def progress(done, total, num_states, fold, accuracy):
            say(f"cv: {done}/{total} jobs ({num_states} states, fold {fold}: "
                f"{100 * accuracy:.1f} %, {time.perf_counter() - start:.0f} s)")

        where = f"Dask scheduler {args.scheduler}" if args.scheduler else \
            f"{args.jobs or os.cpu_count()} local process(es)"
        say(f"cross-validating {cv_states[0]}-{cv_states[-1]} states on {where}")
        result = cross_validate(seqs, data.label, cv_states, folds=folds, seed=args.seed,
                                groups=groups, progress=progress, scheduler=args.scheduler,
                                jobs=args.jobs, class_names=data.class_names, **options)
        prefix = Path(args.report) if args.report is not None else \
            Path(args.output).with_suffix("").with_name(Path(args.output).stem + "-cv")
        json_path = prefix.with_name(prefix.name + ".json")
        png_path = prefix.with_name(prefix.name + ".png")
        write_cv_report(result, json_path, png_path)
        scheme = (f"{result.folds}-fold" if result.scheme == "stratified"
                  else f"leave-one-{args.groups}-out ({result.folds} groups)")
        print(f"{scheme} cross-validation, {len(seqs)} gestures")
        print("states  accuracy")
        for count, accuracy in zip(result.state_counts, result.accuracy):
            mark = "  <- best" if count == result.best_states else ""
            print(f"{count:6d}  {100 * accuracy:7.2f} %{mark}")
        states = result.best_states
        meta["cv_accuracy"] = result.best_accuracy
        meta["cv"] = {"scheme": result.scheme, "folds": result.folds, "seed": args.seed,
                      "groups": args.groups, "state_counts": list(result.state_counts),
                      "accuracy": list(result.accuracy), "best_states": result.best_states,
                      "report": str(json_path)}
        summary.update(cv_best_states=states, cv_accuracy=result.best_accuracy,
                       report=[str(json_path), str(png_path)])

    say(f"training {len(data.class_names)} models of {states} states on all {len(seqs)} "
        "trajectories")
    models = train_models(seqs, data.label, data.class_names, states, meta=meta, **options)
    if args.reject:
        from recognition.recogniser import Recogniser
        recogniser = Recogniser(emission="discrete", resample=args.resample, states=states,
                                emission_floor=args.emission_floor, tol=args.tol,
                                max_iter=args.max_iter, expected_length=args.expected_length,
                                reject_quantile=args.reject_quantile,
                                reject_margin=args.reject_margin,
                                reject_budget=args.reject_budget,
                                calibration_folds=args.calibration_folds)
        thresholds, calibration = recogniser.calibrate(
            seqs, data.label, data.class_names, groups if groups is not None else data.subject,
            progress=say)
        models.meta["rejection"] = calibration
        models = models.with_thresholds(thresholds)
        summary["rejection"] = calibration
    models = _save(models, args)
    training = models.meta["training"]
    summary.update(states=states,
                   iterations={k: v["iterations"] for k, v in training.items()},
                   converged=all(v["converged"] for v in training.values()),
                   seconds=round(time.perf_counter() - start, 2))
    say(f"wrote {args.output}")
    print(json.dumps(summary))
    return 0


def _save(models, args):
    """Write the model file with ``--commands``; warn (stderr) about classes that
    send no robot command, which the board application refuses."""
    from dataclasses import replace

    from sw_hps.class_commands import unmapped
    from sw_hps.hmm import save_models
    from sw_hps.telegram import GESTURE_NAMES
    if args.commands:
        models = replace(models, commands=args.commands, meta=dict(models.meta))
    missing = unmapped(models.commands, models.class_names)
    if missing:
        print(f"warning: {', '.join(map(repr, missing))} map{'s' if len(missing) == 1 else ''} "
              f"to no robot command ({', '.join(GESTURE_NAMES)}): the board application "
              f"refuses this model until --commands maps them", file=sys.stderr)
    save_models(models, args.output)
    return models


def _run_gaussian(args, data, data_path, say, start) -> int:
    from recognition.recogniser import Recogniser

    recogniser = Recogniser(emission="gaussian", resample=args.resample, states=args.states,
                            components=args.components, reject=args.reject,
                            reject_quantile=args.reject_quantile,
                            reject_margin=args.reject_margin,
                            reject_budget=args.reject_budget,
                            calibration_folds=args.calibration_folds)
    front_end = "camera" if args.resample is None else f"pen, resampled to {args.resample}"
    say(f"{len(data)} trajectories, classes {', '.join(data.class_names)}; "
        f"front end: {front_end}; gaussian emissions")
    samples = recogniser.samples(data)
    still = sum(1 for x in samples if x is None)
    if still:
        say(f"{still} trajectories have no motion (ignored in training)")
    meta = {"dataset": str(data_path), "resample": args.resample,
            "front_end": "camera" if args.resample is None else "pen"}
    say(f"training {len(data.class_names)} models of {recogniser.num_states} states on all "
        f"{len(samples)} trajectories")
    models = recogniser.fit(samples, data.label, data.class_names, groups=data.subject,
                            meta=meta, progress=say)
    models = _save(models, args)
    summary = {"output": str(args.output), "classes": list(data.class_names),
               "sequences": len(samples), "emission": "gaussian",
               "states": recogniser.num_states,
               "components": {n: len(c) for n, c in zip(models.class_names, models.components)},
               "rejection": models.meta.get("rejection"),
               "seconds": round(time.perf_counter() - start, 2)}
    say(f"wrote {args.output}")
    print(json.dumps(summary))
    return 0


def _verifier(path, class_names):
    """The ``--verifier`` model file, checked against the data's classes
    (``ValueError`` naming the option)."""
    from sw_hps.hmm import check_verifier, load_models
    try:
        verifier = load_models(path)
        check_verifier(verifier, class_names)
    except (ValueError, OSError) as exc:
        raise ValueError(f"--verifier: {exc}") from None
    return verifier


def _run_continuous(args, data, data_path, say, start) -> int:
    from dataclasses import replace

    from recognition.continuous import train_continuous
    from sw_hps.continuous import SPOTTING_DEFAULTS
    if data.subject is None or len(set(data.subject.tolist())) < 2:
        raise ValueError(f"{data_path}: --continuous calibrates on held-out subjects: the "
                         f"dataset needs a subject (or writer) key with at least 2 subjects")
    step = SPOTTING_DEFAULTS["step"] if args.step is None else args.step
    verifier = _verifier(args.verifier, data.class_names) if args.verifier else None
    say(f"{len(data)} trajectories of {len(set(data.subject.tolist()))} subjects; training "
        f"{args.states}-state models on symbols every {step} px of travel, calibrating the "
        "threshold bias and the end delay")
    models, calibration = train_continuous(
        data, states=args.states, step=step,
        emission_floor=args.emission_floor or 1e-3, seed=args.seed,
        meta={"dataset": str(data_path), "states": args.states})
    if verifier is not None:
        models = replace(models, verifier=verifier, meta=dict(models.meta, verifier=str(
            args.verifier)))
    models = _save(models, args)
    say(f"wrote {args.output}")
    print(json.dumps({"output": str(args.output), "classes": list(data.class_names),
                      "states": args.states, "spotting": models.spotting,
                      "calibration_f1": calibration,
                      "seconds": round(time.perf_counter() - start, 2)}))
    return 0
