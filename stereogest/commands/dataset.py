"""Build a trajectory dataset (``.npz``, the layout of recognition.datasets that
``stereogest train`` reads) from one's own recordings.

Each INPUT is one recorded gesture:

* a clip folder (``stereogest clip`` of one's own cameras, or ``render``): the
  golden model of the whole pipeline runs over it and the hand's per-frame
  centroid is kept (frames where the opening found no hand are left out);
* a CSV file with ``x`` and ``y`` columns (a header row, one row per frame of
  hand centroids in pixels, or per pen sample);
* a manifest, a CSV file with a ``path`` column (clip folders or CSV files,
  relative to the manifest) and optional ``label`` and ``subject`` columns: one
  row per gesture.

The label of a gesture is its manifest row's, else ``--label``, else the clip's
own (``clip.json``'s gesture); the subject (who made it: ``train``
calibrates rejection on subjects held out) its row's, else ``--subject``. Train on the result
with ``stereogest train DATA.npz -o MODEL.json --commands CLASS=COMMAND,...``
to give each class a robot command.
"""
from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

from stereogest.commands import add_json_switch, check_output_file

NAME = "dataset"
HELP = "build a trajectory dataset (.npz) from clips or CSV files of one's own gestures"

#: Fewest points a gesture may have.
MIN_POINTS = 2


def add_arguments(p):
    p.add_argument("inputs", metavar="INPUT", nargs="+",
                   help="clip folder, CSV file with x,y columns, or manifest CSV with a path "
                        "column (and label, subject)")
    p.add_argument("-o", "--output", metavar="DATA.npz", required=True,
                   help="dataset to write")
    p.add_argument("--label", default=None,
                   help="class name of the inputs that carry none (default: a clip's gesture)")
    p.add_argument("--subject", type=int, default=0, metavar="N",
                   help="who made the inputs that carry no subject, 0..65535 (default 0)")
    p.add_argument("--hand-tracking", action="store_true",
                   help="clips: the pipeline's hand tracking (as pipeline --hand-tracking)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_json_switch(p)


def _read_csv(path: Path) -> list[dict]:
    try:
        with open(path, newline="") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ValueError(f"{path}: cannot read it as CSV ({exc})") from None
    return rows


def _points_of_csv(path: Path, rows: list[dict]):
    import numpy as np
    if not rows or not {"x", "y"} <= set(rows[0]):
        raise ValueError(f"{path}: a trajectory CSV needs x and y columns (a header row), "
                         f"got {sorted(rows[0]) if rows else 'no rows'}")
    points = []
    for number, row in enumerate(rows, 2):
        try:
            point = float(row["x"]), float(row["y"])
        except (TypeError, ValueError):
            raise ValueError(f"{path}:{number}: x and y must be numbers, got "
                             f"{row.get('x')!r}, {row.get('y')!r}") from None
        if not all(np.isfinite(point)):
            raise ValueError(f"{path}:{number}: x and y must be finite, got {point}")
        points.append(point)
    return np.array(points)


def _points_of_clip(path: Path, hand_tracking: bool, say):
    """The hand's per-frame centroid of a clip through the golden model; the
    clip's own label."""
    import numpy as np

    from sim.clip import load_clip
    from sim.model.pipeline import PipelineParams, run_clip
    clip = load_clip(path)
    params = PipelineParams.for_frame(clip.width, hand_tracking=hand_tracking)
    say(f"  {path}: {clip.frames} frames of {clip.width}x{clip.height} through the pipeline")
    trajectory, _ = run_clip(clip.left, clip.right, params)
    seen = np.asarray(trajectory.area) > 0
    return np.asarray(trajectory.centroid, dtype=np.float64)[seen], clip.gesture


def _gestures(inputs, label, subject):
    """``(path, label or None, subject)`` per gesture, manifests expanded."""
    out = []
    for text in inputs:
        path = Path(text)
        if path.is_dir():
            out.append((path, label, subject))
            continue
        if not path.is_file():
            raise ValueError(f"INPUT: {path} is neither a clip folder nor a CSV file")
        rows = _read_csv(path)
        if rows and "path" in rows[0]:
            for number, row in enumerate(rows, 2):
                where = f"{path}:{number}"
                if not row.get("path"):
                    raise ValueError(f"{where}: path is empty")
                row_subject = subject
                if row.get("subject"):
                    try:
                        row_subject = int(row["subject"])
                    except ValueError:
                        raise ValueError(f"{where}: subject must be an integer, got "
                                         f"{row['subject']!r}") from None
                    _check_subject(row_subject, where)
                target = path.parent / row["path"]
                if not target.exists():
                    raise ValueError(f"{where}: {target} does not exist")
                out.append((target, row.get("label") or label, row_subject))
        else:
            out.append((path, label, subject))
    return out


def _check_subject(value: int, where: str) -> None:
    if not 0 <= value <= 65535:
        raise ValueError(f"{where}: subject must be in 0..65535, got {value}")


def run(args) -> int:
    import numpy as np

    from recognition.datasets import TrajectorySet, save_trajectories
    say = (lambda text: None) if args.quiet else \
        (lambda text: print(text, file=sys.stderr, flush=True))
    _check_subject(args.subject, "--subject")
    if args.label is not None and not args.label.strip():
        raise ValueError("--label must not be empty")
    output = check_output_file(args.output)
    gestures = _gestures(args.inputs, args.label, args.subject)
    trajectories, labels, subjects = [], [], []
    for path, label, subject in gestures:
        if path.is_dir():
            points, own = _points_of_clip(path, args.hand_tracking, say)
            label = label or own
        else:
            points = _points_of_csv(path, _read_csv(path))
        if not label:
            raise ValueError(f"{path}: no label (give --label, a manifest's label column, or "
                             f"a clip labelled with --gesture)")
        if len(points) < MIN_POINTS:
            raise ValueError(f"{path}: {len(points)} points with a hand, at least "
                             f"{MIN_POINTS} needed")
        trajectories.append(points)
        labels.append(label)
        subjects.append(subject)
    data = TrajectorySet.from_list(trajectories, labels, subjects)   # validates
    save_trajectories(data, output)
    classes = {name: labels.count(name) for name in sorted(set(labels))}
    print(f"wrote {len(data)} gestures of {len(classes)} classes "
          f"({', '.join(f'{k} {v}' for k, v in classes.items())}), "
          f"{len(set(subjects))} subjects -> {output}")
    if args.json:
        print(json.dumps({"output": str(output), "gestures": len(data), "classes": classes,
                          "subjects": sorted(set(subjects)),
                          "points": int(np.diff(data.offsets).sum())}))
    return 0
