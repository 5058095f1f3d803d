"""The shipped posture classifier on rendered people it was not trained on,
through the golden model of the whole pipeline.

Each person (seeds ``--seed`` ... ``--seed + --people - 1``; the shipped model
is trained on :data:`TRAINING_PEOPLE`, ``make model``) holds each
posture (``sim.hand_postures``) still in front of the chest at 640x480; the
frame goes through the golden model of the pipeline three times, as a hand
held still in a stream and as the training people's frames
(:func:`recognition.posture_renders.present_still`: the hand tracking's window
then stands about the hand's own centroid, and the posture's reference comes
from a windowed frame), and the last frame's posture record through the
board's reader path (:func:`sw_hps.posture.decode_posture_words`,
``record_features``) to the classifier. The easy scene with the thesis'
pipeline, and the hard scene (every difficulty, each person's skin tone and
hand size) with hand tracking (``--hand-tracking``: the posture's window).

``--compare`` also trains, on the same training people, a model on the
photos alone and on the photos with the rendered postures, and scores them on
these people and (the joint one) on the photos of students it did not see
(one split: every fifth student held out).

Prints per scene the accuracy, per class, the extended-finger count and the
refusals, the CPU microseconds of one decision (one frame, as the board
decides), and the CPU seconds; JSON last line.

Run: ``python benchmarks/rendered_posture_accuracy.py [--people 20] [--compare]``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from sim.hand_postures import POSTURE_NAMES, extended_fingers  # noqa: E402
from stereogest.pipeline_outputs import load_posture_model  # noqa: E402

PHOTOS = ROOT / "data" / "hand_postures" / "sign_language_digits_dev.npz"
#: The people (seeds) per scene the shipped model learns, as ``make model`` renders them.
TRAINING_PEOPLE = {"easy": range(1000, 1100), "hard": range(2000, 2200)}


def still_records(scene: str, seeds, width=640, height=480):
    """(features, labels): each person's still of each posture through the
    pipeline's golden model, its record decoded as the board decodes it."""
    from recognition.posture_renders import posture_still, present_still
    from sw_hps.posture import decode_posture_words, record_features
    features, labels = [], []
    for seed in seeds:
        for label, name in enumerate(POSTURE_NAMES):
            person, params = posture_still(name, seed, width=width, height=height, scene=scene)
            still = present_still(*person.stereo_frame(0), params)
            features.append(record_features(decode_posture_words(still.posture_words())))
            labels.append(label)
    return np.array(features), np.array(labels)


def score(model, features, labels) -> dict:
    names = list(POSTURE_NAMES)
    decided = model.decide(features)
    named = [model.class_names[k] if k >= 0 else None for k in decided]
    truth = [names[k] for k in labels]
    right = np.array([a == b for a, b in zip(named, truth)])
    fingers = np.array([b is not None and extended_fingers(a) == extended_fingers(b)
                        for a, b in zip(truth, named)])
    return {"accuracy": round(float(right.mean()), 4),
            "fingers": round(float(fingers.mean()), 4),
            "refused": int(sum(n is None for n in named)),
            "per_class": {name: round(float(right[labels == k].mean()), 3)
                          for k, name in enumerate(names) if (labels == k).any()},
            "errors": sorted({f"{a}->{b}": int(sum(1 for t, n in zip(truth, named)
                                                  if (t, n) == (a, b)))
                              for a, b in zip(truth, named) if a != b}.items(),
                             key=lambda kv: -kv[1])[:8]}


def compare(people, report):
    """Photos alone and photos with the rendered postures, on the same people."""
    from recognition import posture as rp
    from recognition.posture_renders import render_postures
    names = list(POSTURE_NAMES)
    train = [render_postures(names, seeds, scene=scene)
             for scene, seeds in TRAINING_PEOPLE.items()]
    r_features = np.vstack([t["features"] for t in train])
    r_labels = np.concatenate([t["label"] for t in train])
    photos = rp.load_postures(PHOTOS)
    p_masks = rp.picture_masks(photos)
    p_features = rp.still_features(p_masks)
    held = np.isin(photos.subject, np.unique(photos.subject)[::5])
    aug = rp.augment_masks(p_masks[~held], 8, seed=1)
    aug_features = rp.still_features(aug)
    aug_labels = np.tile(photos.label[~held], 8)
    alone = rp.train_posture(p_features[~held], photos.label[~held], names[:10], c=10.0,
                             augmented=aug_features, augmented_labels=aug_labels)
    joint = rp.train_posture(np.vstack([p_features[~held], r_features]),
                             np.concatenate([photos.label[~held], r_labels]), names, c=10.0,
                             augmented=aug_features, augmented_labels=aug_labels)
    out = {}
    for name, model in (("photos", alone), ("photos_and_rendered", joint)):
        out[name] = {scene: score(model, *people[scene])["accuracy"] for scene in people}
        out[name]["held_out_students"] = round(float(np.mean(
            model.decide(p_features[held]) == photos.label[held])), 4)
        out[name]["support_vectors"] = int(len(model.support_vectors))
    report["compare"] = out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", default=None, help="posture model (default: the shipped one)")
    p.add_argument("--people", type=int, default=20)
    p.add_argument("--seed", type=int, default=9000, help="the first test person's seed")
    p.add_argument("--compare", action="store_true")
    args = p.parse_args(argv)
    start = time.process_time()
    model = load_posture_model(args.model)
    seeds = range(args.seed, args.seed + args.people)
    report = {"model": args.model or "sw_hps/models/posture.json", "people": args.people,
              "first_seed": args.seed, "postures": list(POSTURE_NAMES)}
    people = {}
    for scene in ("easy", "hard"):
        people[scene] = still_records(scene, seeds)
        result = score(model, *people[scene])
        report[scene] = result
        print(f"{scene} scene ({'hand tracking' if scene == 'hard' else 'thesis pipeline'}): "
              f"{result['accuracy']:.2%} of {len(people[scene][1])} stills, finger count "
              f"{result['fingers']:.2%}, {result['refused']} refused; errors "
              f"{result['errors'] or 'none'}")
    # the board decides one frame at a time
    rows = people["hard"][0]
    tick = time.process_time()
    for row in rows:
        model.decide(row[None])
    report["decision_cpu_us"] = round(1e6 * (time.process_time() - tick) / len(rows))
    report["support_vectors"] = int(len(model.support_vectors))
    print(f"one decision: {report['decision_cpu_us']} CPU us ({report['support_vectors']} "
          f"support vectors)")
    if args.compare:
        compare(people, report)
        for name, row in report["compare"].items():
            print(f"trained on {name}: easy {row['easy']:.2%}, hard {row['hard']:.2%}, "
                  f"held-out students {row['held_out_students']:.2%}, "
                  f"{row['support_vectors']} support vectors")
    report["cpu_seconds"] = round(time.process_time() - start, 1)
    print(f"{report['cpu_seconds']} CPU s")
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
