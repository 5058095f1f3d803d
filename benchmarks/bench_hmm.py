"""Speed of gesture classification on the board's side (sw_hps.hmm,
sw_hps.gaussian_hmm), in CPU seconds (``time.process_time``) on this machine.

Discrete (thesis: 7 classes, 5 states, 8 orientation symbols, trained by
Baum-Welch on a synthetic corpus), one 60-symbol gesture:

* ``GestureModels.classify`` (builds a fresh ForwardStream per gesture);
* a reused ``ForwardStream`` (``reset`` + ``feed``);
* the board application's streaming: ``reset`` + one ``ForwardStream.update``
  per symbol (60 calls per gesture), and that per symbol;
* hmmlearn (``CategoricalHMM.score``, the C++ forward pass) on the same seven
  parameter sets: seven ``score`` calls per gesture; and, for reference, one
  ``score`` call per model on a concatenated batch of gestures (``lengths=``),
  divided by the batch size. The batch call only returns the *sum* of the
  log-likelihoods, so it cannot classify; it shows hmmlearn's throughput
  without per-call overhead.

The log-likelihoods of both implementations are compared (they must agree to
1e-9).

Gaussian (``GaussianGestureModels``, resample 64: 63 feature vectors of 6
features per gesture), with random parameters (the cost does not depend on
training), in three settings: the robot gestures (7 classes x 1 component x
16 states), the $1 unistrokes (16 x 1 x 16) and pendigits (10 x 5 x 16).
Per setting:

* ``scores_of_points`` on a 60-point gesture (the board buffers the gesture
  and scores it at its end: features + forward of every component), also
  split into ``stroke_features`` and ``scores_of_features``;
* the per-point equivalent: per gesture / 63 feature vectors;
* hmmlearn's ``GaussianHMM(covariance_type="diag").score`` on the same
  features with one component's parameters (start in state 0, two-diagonal
  transitions from ``stay``, ``means_``, ``covars_ = var``), times the number
  of components (classes x components per class). hmmlearn has no feature
  weights and no "must end in the last state", so this compares the cost of
  a model of the same size, not the same number (the log-emissions are checked
  equal with unit weights); and, for reference, one component's ``score`` on a
  concatenated batch (``lengths=``) per gesture, which leaves out hmmlearn's
  per-call overhead;
* the model file's size (bytes of ``sw_hps.hmm.save_models``' JSON).

Prints a table per part, a Markdown summary table and a final JSON line.
Run: ``python benchmarks/bench_hmm.py`` (``--quick``: few repetitions, for
the tests).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
import warnings

import numpy as np

from recognition.gaussian_train import DEFAULT_RESAMPLE, DEFAULT_WEIGHTS
from recognition.hmm_train import train_models
from sim.gesture_shapes import GESTURE_NAMES, gesture_path, random_time_warp
from sw_hps.gaussian_hmm import GaussianGestureModels, GaussianHMM, log_emissions
from sw_hps.hmm import GestureModels, save_models
from sw_hps.orientation import orientation_symbols

SYMBOLS = 60
STATES = 5
#: Points of the gesture the Gaussian models score (before resampling).
POINTS = 60
#: Gaussian settings: name -> (classes, components per class, states).
GAUSSIAN_SETTINGS = {
    "robot": (7, 1, 16),
    "$1": (16, 1, 16),
    "pendigits": (10, 5, 16),
}


def per_call_us(fn, calls: int, repeats: int) -> float:
    """Median over ``repeats`` of the mean CPU time (``process_time``) of
    ``calls`` calls, in us."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.process_time()
        for _ in range(calls):
            fn()
        times.append(1e6 * (time.process_time() - start) / calls)
    return statistics.median(times)


def cycling(items):
    """A function returning the items in turn, forever."""
    state = {"i": 0}

    def next_item():
        item = items[state["i"] % len(items)]
        state["i"] += 1
        return item
    return next_item


def gesture_symbols(name: str, rng: np.random.Generator, length: int) -> np.ndarray:
    """``length`` symbols of a jittered gesture path (more points than needed, cut)."""
    n = length + 40
    path = gesture_path(name, n, aspect=float(rng.uniform(0.8, 1.25)),
                        time_warp=random_time_warp(n, rng))
    pts = np.rint((path * 200 + rng.normal(0, 3, path.shape)) * 16).astype(np.int64)
    symbols = orientation_symbols(pts)
    symbols = symbols[symbols >= 0]
    return np.resize(symbols, length).astype(np.int8)


def gesture_points(name: str, rng: np.random.Generator, length: int) -> np.ndarray:
    """``length`` jittered points (pixels, y down) of a gesture path."""
    path = gesture_path(name, length, aspect=float(rng.uniform(0.8, 1.25)),
                        time_warp=random_time_warp(length, rng))
    return path * 200 + 320 + rng.normal(0, 2, path.shape)


def trained_models(rng: np.random.Generator, per_class: int = 20) -> GestureModels:
    seqs, labels = [], []
    for name in GESTURE_NAMES:
        for _ in range(per_class):
            seqs.append(gesture_symbols(name, rng, SYMBOLS))
            labels.append(name)
    return train_models(seqs, labels, GESTURE_NAMES, STATES, emission_floor=1e-3)


def hmmlearn_models(models: GestureModels):
    from hmmlearn.hmm import CategoricalHMM
    result = []
    for m in models.models:
        h = CategoricalHMM(n_components=m.num_states, n_features=m.num_symbols,
                           init_params="", params="")
        h.startprob_, h.transmat_, h.emissionprob_ = m.pi, m.A, m.B
        result.append(h)
    return result


def random_gaussian_models(classes: int, components: int, states: int,
                           rng: np.random.Generator) -> GaussianGestureModels:
    """Gaussian models of the given size with random (valid) parameters."""
    features = len(DEFAULT_WEIGHTS)

    def component():
        stay = rng.uniform(0.5, 0.95, states)
        stay[-1] = 1.0
        return GaussianHMM(stay, rng.normal(0.0, 0.5, (states, features)),
                           rng.uniform(0.02, 0.5, (states, features)))
    groups = tuple(tuple(component() for _ in range(components)) for _ in range(classes))
    return GaussianGestureModels(tuple(f"class{i}" for i in range(classes)), groups,
                                 DEFAULT_RESAMPLE, DEFAULT_WEIGHTS)


def hmmlearn_gaussian(component: GaussianHMM):
    """hmmlearn's diagonal GaussianHMM with one component's parameters."""
    from hmmlearn.hmm import GaussianHMM as LearnGaussianHMM
    n, f = component.mean.shape
    h = LearnGaussianHMM(n_components=n, covariance_type="diag", init_params="", params="")
    h.n_features = f
    start = np.zeros(n)
    start[0] = 1.0
    trans = np.diag(component.stay)
    trans[np.arange(n - 1), np.arange(1, n)] = 1.0 - component.stay[:-1]
    h.startprob_, h.transmat_ = start, trans
    h.means_, h.covars_ = component.mean, component.var
    return h


def model_file_bytes(models) -> int:
    """Size of the model file ``save_models`` writes."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "model.json")
        save_models(models, path)
        return os.path.getsize(path)


def bench_discrete(args, rng):
    models = trained_models(rng, args.per_class)
    gesture = gesture_symbols("rotate-right", rng, SYMBOLS)
    column = gesture.astype(np.int64).reshape(-1, 1)
    hmms = hmmlearn_models(models)

    ours = models.scores(gesture)
    theirs = np.array([h.score(column) for h in hmms])
    max_diff = float(np.max(np.abs(ours - theirs)))
    assert max_diff < 1e-9, f"log-likelihoods differ by {max_diff}"
    decision = models.classify(gesture)

    stream = models.stream()
    symbols = [int(s) for s in gesture]

    def reused_stream():
        stream.reset()
        return stream.feed(gesture)

    def streamed():                       # the board: one update per symbol
        stream.reset()
        for s in symbols:
            stream.update(s)
        return stream.log_likelihoods()

    streamed_scores = streamed()
    stream_diff = float(np.max(np.abs(streamed_scores - ours)))
    assert stream_diff < 1e-9, f"update and feed differ by {stream_diff}"

    batch = np.concatenate([gesture_symbols(GESTURE_NAMES[i % 7], rng, SYMBOLS)
                            for i in range(args.batch)]).astype(np.int64).reshape(-1, 1)
    lengths = [SYMBOLS] * args.batch

    timings = {
        "GestureModels.classify": per_call_us(lambda: models.classify(gesture),
                                              args.calls, args.repeats),
        "ForwardStream reset+feed": per_call_us(reused_stream, args.calls, args.repeats),
        "ForwardStream reset+60 update": per_call_us(streamed, args.calls, args.repeats),
        "hmmlearn 7 x score": per_call_us(lambda: [h.score(column) for h in hmms],
                                          args.calls, args.repeats),
        "hmmlearn batch score / gesture": per_call_us(
            lambda: [h.score(batch, lengths) for h in hmms],
            max(1, args.calls // 20), args.repeats) / args.batch,
    }
    update_us = timings["ForwardStream reset+60 update"] / SYMBOLS
    reference = timings["hmmlearn 7 x score"]
    print(f"DISCRETE: one {SYMBOLS}-symbol gesture against {len(models.models)} models "
          f"of {STATES} states, {args.calls} gestures x {args.repeats} repeats "
          f"(decision: {models.class_names[decision]}; max |ours - hmmlearn| = {max_diff:.1e})")
    print(f"{'method':34s} {'us/gesture':>11s} {'vs hmmlearn':>12s}")
    for name, us in timings.items():
        print(f"{name:34s} {us:11.1f} {us / reference:11.2f}x")
    print(f"{'ForwardStream.update (per symbol)':34s} {update_us:11.2f}")
    print(f"{'hmmlearn 7 x score (per symbol)':34s} {reference / SYMBOLS:11.2f}")
    result = {"symbols": SYMBOLS, "models": len(models.models), "states": STATES,
              "us": {k: round(v, 1) for k, v in timings.items()},
              "update_us_per_symbol": round(update_us, 2),
              "classify_vs_hmmlearn": round(timings["GestureModels.classify"] / reference, 3),
              "max_abs_difference": max_diff}
    row = {"setting": "discrete (thesis)", "classes": len(models.models), "components": 1,
           "states": STATES, "per_gesture_ms": timings["ForwardStream reset+60 update"] / 1e3,
           "per_point_us": update_us, "hmmlearn_per_gesture_ms": reference / 1e3,
           "model_bytes": model_file_bytes(models)}
    return result, row


def bench_gaussian(name, classes, components, states, args, rng):
    models = random_gaussian_models(classes, components, states, rng)
    gestures = [gesture_points(GESTURE_NAMES[i % 7], rng, POINTS) for i in range(16)]
    feats = [models.features(p) for p in gestures]
    steps = models.steps
    assert all(f is not None and f.shape == (steps, len(DEFAULT_WEIGHTS)) for f in feats)
    component = models.components[0][0]
    h = hmmlearn_gaussian(component)
    # Same parameters: hmmlearn's log-emissions equal ours with unit weights.
    ours = log_emissions(feats[0], component.mean[None], component.var[None],
                         np.ones(len(DEFAULT_WEIGHTS)))[0]
    emission_diff = float(np.max(np.abs(ours - h._compute_log_likelihood(feats[0]))))
    assert emission_diff < 1e-9, f"log-emissions differ by {emission_diff}"
    h.score(feats[0])

    total = classes * components
    batch = np.concatenate([feats[i % len(feats)] for i in range(args.batch)])
    lengths = [steps] * args.batch
    points_fn, features_fn, feats_fn = cycling(gestures), cycling(gestures), cycling(feats)
    learn_fn = cycling(feats)
    timings = {
        "scores_of_points": per_call_us(lambda: models.scores_of_points(points_fn()),
                                        args.calls, args.repeats),
        "stroke_features": per_call_us(lambda: models.features(features_fn()),
                                       args.calls, args.repeats),
        "scores_of_features": per_call_us(lambda: models.scores_of_features(feats_fn()),
                                          args.calls, args.repeats),
        "hmmlearn 1 x score": per_call_us(lambda: h.score(learn_fn()),
                                          args.calls, args.repeats),
        "hmmlearn 1 x batch score / gesture": per_call_us(
            lambda: h.score(batch, lengths), max(1, args.calls // 20),
            args.repeats) / args.batch,
    }
    per_gesture = timings["scores_of_points"]
    learn = timings["hmmlearn 1 x score"] * total
    print(f"GAUSSIAN {name}: {classes} classes x {components} components x {states} states, "
          f"{POINTS}-point gesture -> {steps} feature vectors, {args.calls} gestures x "
          f"{args.repeats} repeats")
    print(f"{'method':34s} {'us/gesture':>11s}")
    for key, us in timings.items():
        print(f"{key:34s} {us:11.1f}")
    print(f"{'hmmlearn score x ' + str(total) + ' components':34s} {learn:11.1f}")
    print(f"{'hmmlearn batch x ' + str(total) + ' components':34s} "
          f"{timings['hmmlearn 1 x batch score / gesture'] * total:11.1f}")
    row = {"setting": f"gaussian {name}", "classes": classes, "components": components,
           "states": states, "per_gesture_ms": per_gesture / 1e3,
           "per_point_us": per_gesture / steps, "hmmlearn_per_gesture_ms": learn / 1e3,
           "model_bytes": model_file_bytes(models)}
    result = {"classes": classes, "components": components, "states": states,
              "resample": models.resample, "points": POINTS, "feature_vectors": steps,
              "us": {k: round(v, 1) for k, v in timings.items()},
              "hmmlearn_us_per_gesture": round(learn, 1),
              "per_point_us": round(per_gesture / steps, 2),
              "vs_hmmlearn": round(per_gesture / learn, 3),
              "forward_vs_hmmlearn": round(timings["scores_of_features"] / learn, 3),
              "model_bytes": row["model_bytes"], "max_abs_emission_difference": emission_diff}
    return result, row


def markdown_table(rows) -> str:
    lines = ["| setting | classes x components x states | per gesture ms | per point us "
             "| hmmlearn per gesture ms | ratio | model file KB |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['setting']} | {r['classes']} x {r['components']} x {r['states']} "
                     f"| {r['per_gesture_ms']:.3f} | {r['per_point_us']:.1f} "
                     f"| {r['hmmlearn_per_gesture_ms']:.3f} "
                     f"| {r['per_gesture_ms'] / r['hmmlearn_per_gesture_ms']:.2f} "
                     f"| {r['model_bytes'] / 1024:.1f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=7, help="timing repeats (median)")
    parser.add_argument("--calls", type=int, default=200,
                        help="gestures per timing repeat")
    parser.add_argument("--batch", type=int, default=100,
                        help="gestures in hmmlearn's concatenated batch")
    parser.add_argument("--per-class", type=int, default=20,
                        help="training gestures per class of the discrete models")
    parser.add_argument("--quick", action="store_true",
                        help="few repetitions (a smoke test; the numbers are noisy)")
    args = parser.parse_args(argv)
    if args.quick:
        args.repeats, args.calls, args.batch, args.per_class = 2, 5, 10, 5
    warnings.filterwarnings("ignore", category=RuntimeWarning)   # log(0) of zero transitions

    rng = np.random.default_rng(0)
    start = time.process_time()
    result, row = bench_discrete(args, rng)
    rows = [row]
    gaussian = {}
    for name, (classes, components, states) in GAUSSIAN_SETTINGS.items():
        print()
        gaussian[name], row = bench_gaussian(name, classes, components, states, args, rng)
        rows.append(row)
    print()
    print(f"CPU time (process_time), {args.calls} gestures x {args.repeats} repeats (median); "
          "per point: discrete per symbol, gaussian per gesture / 63 feature vectors; "
          "hmmlearn gaussian: one component's score x components (same-sized model, not "
          "the same number); ratio = ours / hmmlearn")
    print(markdown_table(rows))
    result.update({
        "timer": "process_time",
        "calls": args.calls, "repeats": args.repeats,
        "gaussian": gaussian,
        "table": [{k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()}
                  for r in rows],
        "cpu_seconds_total": round(time.process_time() - start, 2),
    })
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
