"""Issue 28's targets for continuous recognition, judged in one table.

Each run of :data:`RUNS` is one of the two benchmarks that measure them
(``continuous_recognition.py``: joined trajectory streams, leave one subject
out; ``continuous_sessions.py``: rendered sessions through the golden model of
the whole pipeline and the board's spotter) with the issue's settings, and
writes its report to ``--dir`` (``build/continuous/<run>.json``). ``--run``
runs the named ones first (``all``: every one, 123 user CPU minutes here in
the runs of issue 28's third round, most of it the 640x480 sessions and the
$1 logs); then every target of
:data:`TARGETS` is printed beside the figure measured and whether it is met,
``not run`` where its report is missing.

Run: ``python benchmarks/continuous_accuracy.py [--run all|RUN,...] [--dir DIR]``.
"""
from __future__ import annotations

import argparse
import json
import operator
import resource
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent

#: run -> (benchmark script, its arguments); what each measures is in the
#: script's docstring.
RUNS = {
    "corpus": ("continuous_recognition.py", ["--data", "corpus"]),
    "corpus-distractors": ("continuous_recognition.py",
                           ["--data", "corpus", "--distractors", "--idle-steps", "18000"]),
    "sessions": ("continuous_sessions.py", ["--isolated", "5"]),
    "sessions-distractors": ("continuous_sessions.py",
                             ["--distractors", "--idle-frames", "18000"]),
    "hard": ("continuous_sessions.py", ["--sessions", "5", "--distractors", "--idle-frames",
                                        "5400", "--scene", "hard"]),
    "sessions-640": ("continuous_sessions.py",
                     ["--distractors", "--idle-frames", "18000", "--idle-clip", "600",
                      "--width", "640", "--height", "480", "--stops", "20"]),
    "dollar": ("continuous_recognition.py", ["--data", "dollar"]),
    "dollar-distractors": ("continuous_recognition.py",
                           ["--data", "dollar", "--distractors", "--idle-steps", "18000"]),
}

#: (target, run, figure, comparison, bound); figure names a key of
#: :func:`figures`; a bound of None is reported, not judged.
TARGETS = (
    ("F1 >= 98 % (rendered 640x480, distractors)", "sessions-640", "f1", ">=", 0.98),
    ("false commands <= 1 per 10 min of distractors alone (640x480)", "sessions-640",
     "idle_per_10_min", "<=", 1.0),
    ("median latency <= 10 frames (640x480)", "sessions-640", "latency_median", "<=", 10),
    ("95th percentile latency <= 10 frames (640x480)", "sessions-640", "latency_p95", "<=", 10),
    ("stop posture: median latency <= 10 frames from its first frame (640x480)",
     "sessions-640", "stop_latency_median", "<=", 10),
    ("stop posture: 95th percentile latency <= 10 frames (640x480)", "sessions-640",
     "stop_latency_p95", "<=", 10),
    ("stop posture: every hold stopped (640x480)", "sessions-640", "stops_missed", "<=", 0),
    ("no stop on distractors (640x480)", "sessions-640", "idle_stops", "<=", 0),
    ("F1 >= 98 % (rendered 320x240, distractors)", "sessions-distractors", "f1", ">=", 0.98),
    ("false commands <= 1 per 10 min (320x240)", "sessions-distractors", "idle_per_10_min",
     "<=", 1.0),
    ("F1 >= 98 % (--scene hard, hand tracking)", "hard", "f1", ">=", 0.98),
    ("false commands <= 1 per 10 min (--scene hard)", "hard", "idle_per_10_min", "<=", 1.0),
    ("median latency <= 10 frames (--scene hard)", "hard", "latency_median", "<=", 10),
    ("95th percentile latency <= 10 frames (--scene hard)", "hard", "latency_p95", "<=", 10),
    ("isolated gestures between rests: every one named once and right", "sessions",
     "isolated_wrong", "<=", 0),
    ("$1 joined streams, leave one subject out: F1", "dollar", "f1", None, None),
    ("$1 with distractors: F1", "dollar-distractors", "f1", None, None),
    ("$1: false commands per 10 min of distractors alone", "dollar-distractors",
     "idle_per_10_min", None, None),
    ("synthetic corpus (seed 23): F1", "corpus", "f1", ">=", 0.98),
    ("synthetic corpus with distractors: F1", "corpus-distractors", "f1", ">=", 0.98),
    ("synthetic corpus: false commands per 10 min of distractors alone",
     "corpus-distractors", "idle_per_10_min", "<=", 1.0),
)
_COMPARE = {">=": operator.ge, "<=": operator.le}


def figures(report: dict) -> dict:
    """The figures :data:`TARGETS` names, from either benchmark's report (None
    where the report has no such figure)."""
    overall = report.get("overall", report)        # continuous_recognition nests them
    idle = report.get("idle") or {}
    isolated = report.get("isolated")
    stops = report.get("stops")
    return {"stop_latency_median": stops["latency_median_frames"] if stops else None,
            "stop_latency_p95": stops["latency_p95_frames"] if stops else None,
            "stops_missed": stops["holds"] - stops["stopped"] if stops else None,
            "idle_stops": sum(n for kind, n in idle.get("by_distractor", {}).items()
                              if kind.endswith("(stop posture)")) if idle else None,
            "f1": overall.get("f1") if overall.get("gestures", overall.get("true")) else None,
            "idle_per_10_min": idle.get("false_commands_per_10_min"),
            "latency_median": overall.get("latency_median_frames"),
            "latency_p95": overall.get("latency_p95_frames"),
            "isolated_wrong": isolated["clips"] - isolated["right"] if isolated else None}


def _shown(figure: str, value) -> str:
    if value is None:
        return "not measured"
    if figure == "f1":
        return f"{100 * value:.2f} %"
    if figure == "idle_per_10_min":
        return f"{value:.1f} per 10 min"
    if figure == "isolated_wrong":
        return f"{value:g} clips wrong"
    if figure == "stops_missed":
        return f"{value:g} holds missed"
    if figure == "idle_stops":
        return f"{value:g} stops"
    return f"{value:g} frames"


def judge(reports: dict) -> list[dict]:
    """Each target of :data:`TARGETS` with its run's figure (``reports``: run ->
    report, or missing) and ``met`` (True, False, or None: not judged)."""
    rows = []
    for target, run, figure, compare, bound in TARGETS:
        report = reports.get(run)
        value = figures(report)[figure] if report is not None else None
        met = None if compare is None or value is None else _COMPARE[compare](value, bound)
        rows.append({"target": target, "run": run, "figure": figure, "value": value,
                     "measured": _shown(figure, value) if report is not None else "not run",
                     "met": met})
    return rows


def run(name: str, directory: Path) -> float:
    """Run ``name`` of :data:`RUNS` (its report to ``directory``); its CPU
    seconds (user, children)."""
    script, args = RUNS[name]
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    print(f"running {name}: {script} {' '.join(args)}", flush=True)
    done = subprocess.run([sys.executable, str(HERE / script), *args,
                           "--json", str(directory / f"{name}.json")], cwd=ROOT)
    if done.returncode:
        raise SystemExit(f"{name}: {script} exited with {done.returncode}")
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", default="",
                    help=f"runs to measure first: all, or comma-separated of {', '.join(RUNS)}")
    ap.add_argument("--dir", default=str(ROOT / "build" / "continuous"),
                    help="where the runs' reports are (default build/continuous)")
    args = ap.parse_args(argv)
    names = list(RUNS) if args.run == "all" else [n for n in args.run.split(",") if n]
    unknown = [n for n in names if n not in RUNS]
    if unknown:
        ap.error(f"--run must be all or names of {', '.join(RUNS)}, got {', '.join(unknown)}")
    directory = Path(args.dir)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        ap.error(f"--dir: cannot use {directory} ({exc.strerror})")
    for name in names:
        print(f"{name}: {run(name, directory):.0f} CPU s", flush=True)
    reports = {}
    for name in RUNS:
        path = directory / f"{name}.json"
        if path.is_file():
            try:
                reports[name] = json.loads(path.read_text())
                figures(reports[name])
            except (OSError, ValueError, TypeError, KeyError, AttributeError) as exc:
                ap.error(f"--dir: {path} is not a readable report of {RUNS[name][0]} "
                         f"({type(exc).__name__}: {exc})")
    rows = judge(reports)
    print("| target | run | measured | met |\n|---|---|---|---|")
    for r in rows:
        met = {True: "yes", False: "**no**", None: ""}[r["met"]]
        print(f"| {r['target']} | {r['run']} | {r['measured']} | {met} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
