"""Speed of gesture classification on the board's side (sw_hps.hmm).

Times, in one run on this machine, classifying one 60-symbol gesture against
the seven class models (5 states each, left-right, trained by Baum-Welch on a
synthetic corpus):

* ``GestureModels.classify`` (builds a fresh ForwardStream per gesture);
* a reused ``ForwardStream`` (``reset`` + ``feed``), as the board application
  keeps one;
* the streaming cost per symbol (``ForwardStream.update``: one call per frame
  with a symbol);
* hmmlearn (``CategoricalHMM.score``, the C++ forward pass) on the same seven
  parameter sets: seven ``score`` calls per gesture; and, for reference, one
  ``score`` call per model on a concatenated batch of gestures (``lengths=``),
  divided by the batch size. The batch call only returns the *sum* of the
  log-likelihoods, so it cannot classify; it shows hmmlearn's throughput
  without per-call overhead.

The log-likelihoods of both implementations are compared (they must agree to
1e-9). Prints a table and a final JSON line; target: ours no slower than
hmmlearn's seven score calls. Run: ``python benchmarks/bench_hmm.py``.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
import warnings

import numpy as np

from recognition.hmm_train import train_models
from sim.gesture_shapes import GESTURE_NAMES, gesture_path, random_time_warp
from sw_hps.hmm import GestureModels
from sw_hps.orientation import orientation_symbols

SYMBOLS = 60
STATES = 5


def per_call_us(fn, calls: int, repeats: int) -> float:
    """Median over ``repeats`` of the mean wall time of ``calls`` calls, in us."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            fn()
        times.append(1e6 * (time.perf_counter() - start) / calls)
    return statistics.median(times)


def gesture_symbols(name: str, rng: np.random.Generator, length: int) -> np.ndarray:
    """``length`` symbols of a jittered gesture path (more points than needed, cut)."""
    n = length + 40
    path = gesture_path(name, n, aspect=float(rng.uniform(0.8, 1.25)),
                        time_warp=random_time_warp(n, rng))
    pts = np.rint((path * 200 + rng.normal(0, 3, path.shape)) * 16).astype(np.int64)
    symbols = orientation_symbols(pts)
    symbols = symbols[symbols >= 0]
    return np.resize(symbols, length).astype(np.int8)


def trained_models(rng: np.random.Generator) -> GestureModels:
    seqs, labels = [], []
    for name in GESTURE_NAMES:
        for _ in range(20):
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=7, help="timing repeats (median)")
    parser.add_argument("--calls", type=int, default=200, help="calls per timing repeat")
    parser.add_argument("--batch", type=int, default=100,
                        help="gestures in hmmlearn's concatenated batch")
    args = parser.parse_args(argv)

    rng = np.random.default_rng(0)
    models = trained_models(rng)
    gesture = gesture_symbols("rotate-right", rng, SYMBOLS)
    column = gesture.astype(np.int64).reshape(-1, 1)
    hmms = hmmlearn_models(models)
    warnings.filterwarnings("ignore", category=RuntimeWarning)   # log(0) of zero transitions

    ours = models.scores(gesture)
    theirs = np.array([h.score(column) for h in hmms])
    max_diff = float(np.max(np.abs(ours - theirs)))
    assert max_diff < 1e-9, f"log-likelihoods differ by {max_diff}"
    decision = models.classify(gesture)

    stream = models.stream()

    def reused_stream():
        stream.reset()
        return stream.feed(gesture)

    batch = np.concatenate([gesture_symbols(GESTURE_NAMES[i % 7], rng, SYMBOLS)
                            for i in range(args.batch)]).astype(np.int64).reshape(-1, 1)
    lengths = [SYMBOLS] * args.batch

    timings = {
        "GestureModels.classify": per_call_us(lambda: models.classify(gesture),
                                              args.calls, args.repeats),
        "ForwardStream reset+feed": per_call_us(reused_stream, args.calls, args.repeats),
        "hmmlearn 7 x score": per_call_us(lambda: [h.score(column) for h in hmms],
                                          args.calls, args.repeats),
        "hmmlearn batch score / gesture": per_call_us(
            lambda: [h.score(batch, lengths) for h in hmms],
            max(1, args.calls // 20), args.repeats) / args.batch,
    }
    stream.reset()
    update_us = per_call_us(lambda: stream.update(int(gesture[0])), args.calls * 10,
                            args.repeats)
    reference = timings["hmmlearn 7 x score"]
    print(f"classifying one {SYMBOLS}-symbol gesture against {len(models.models)} models "
          f"of {STATES} states (decision: {models.class_names[decision]}; "
          f"max |ours - hmmlearn| = {max_diff:.1e})")
    print(f"{'method':34s} {'us/gesture':>11s} {'vs hmmlearn':>12s}")
    for name, us in timings.items():
        print(f"{name:34s} {us:11.1f} {us / reference:11.2f}x")
    print(f"{'ForwardStream.update (per symbol)':34s} {update_us:11.2f}")
    print(json.dumps({"symbols": SYMBOLS, "models": len(models.models), "states": STATES,
                      "us": {k: round(v, 1) for k, v in timings.items()},
                      "update_us_per_symbol": round(update_us, 2),
                      "classify_vs_hmmlearn": round(timings["GestureModels.classify"]
                                                    / reference, 3),
                      "max_abs_difference": max_diff}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
