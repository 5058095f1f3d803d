"""The whole pipeline's routed timing as the project states it: one record of
every placement ``make timing`` makes (both configurations, placer seeds 1-3),
the commit and tools it was measured with, the netlist it describes, and the
table the figures page docs/figures/fpga.md shows.

``make timing`` writes the record (``hdl/timing_pipeline.json``) from the two
``stereogest timing --block pipeline`` reports and puts its table into the
figures page between :data:`TABLE_BEGIN` and :data:`TABLE_END`. ``make test`` checks
that the page's table is the record's and that the record's netlists are
the ones the hardware builds today (:func:`stale`): a change to the pipeline
that alters its netlist fails the tests until ``make timing`` has measured it.

Run as ``python -m hdl.timing_record THESIS.json CALIBRATED.json -o RECORD.json
[--page PAGE.md]``.
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
import tempfile
from pathlib import Path

__all__ = ["CONFIGURATIONS", "TABLE_BEGIN", "TABLE_END", "RECORD", "record", "render_table",
           "replace_table", "design_digest", "stale", "main"]

#: The record beside this module, and the figures page that shows it.
RECORD = Path(__file__).resolve().parent / "timing_pipeline.json"
PAGE = Path(__file__).resolve().parent.parent / "docs" / "figures" / "fpga.md"
#: Markers around the generated table in the page.
TABLE_BEGIN = "<!-- pipeline timing table: written by make timing from hdl/timing_pipeline.json -->"
TABLE_END = "<!-- end of the pipeline timing table -->"


@dataclasses.dataclass(frozen=True)
class Configuration:
    """A configuration of the pipeline whose routed timing is recorded."""
    name: str
    calibration: bool       #: rectified with the default rig's calibration
    hand_tracking: bool
    target_mhz: float       #: the pipeline clock's Fmax on every seed must reach it


#: The two configurations (issue 40's targets: 5 MHz above the earlier ones).
CONFIGURATIONS = (
    Configuration("thesis", calibration=False, hand_tracking=False, target_mhz=115.0),
    Configuration("calibration + hand tracking", calibration=True, hand_tracking=True,
                  target_mhz=110.0),
)
#: The frame size of the recorded runs.
SIZE = (640, 480)


def _configuration_of(report: dict) -> Configuration:
    tracking = bool(report["params"].get("track_gate"))
    calibrated = report.get("calibration") is not None
    for c in CONFIGURATIONS:
        if (c.calibration, c.hand_tracking) == (calibrated, tracking):
            return c
    raise ValueError(f"a report of calibration {calibrated}, hand tracking {tracking} is "
                     "neither recorded configuration")


def record(reports) -> dict:
    """One record from ``stereogest timing --block pipeline`` reports, one per
    configuration of :data:`CONFIGURATIONS`.

    Raises ``ValueError`` naming what is missing or inconsistent: a report of
    another block or size, two of one configuration, a missing configuration,
    runs of differing netlists or tools.
    """
    configurations = {}
    commits, tools = [], []
    for report in reports:
        if report.get("runs") is None or any(b["block"] != "pipeline" for run in report["runs"]
                                                  for b in run["blocks"]):
            raise ValueError("every report must be of stereogest timing --block pipeline")
        if (report["width"], report["height"]) != SIZE:
            raise ValueError(f"the reports must be of {SIZE[0]}x{SIZE[1]} frames, got "
                             f"{report['width']}x{report['height']}")
        config = _configuration_of(report)
        if config.name in configurations:
            raise ValueError(f"two reports of the configuration {config.name!r}")
        runs = [b for run in report["runs"] for b in run["blocks"]]
        digests = {b["rtlil_sha256"] for b in runs}
        if len(digests) != 1:
            raise ValueError(f"{config.name}: its runs placed different netlists")
        seeds = {}
        for b in runs:
            clocks = {}
            for clock, c in b["clocks"].items():
                path = c["critical_path"] or {}
                clocks[clock] = {
                    "fmax_mhz": c["fmax_mhz"], "constraint_mhz": c["constraint_mhz"],
                    "critical_path": {k: path.get(k) for k in
                                      ("start", "end", "logic_levels", "delay_ns",
                                       "routing_ns")} if path else None}
            seeds[str(b["seed"])] = {"clocks": clocks, "pnr_cpu_s": b["pnr_cpu_s"],
                                     "resources": b["resources"],
                                     "routed": b.get("routed", True)}
            if not seeds[str(b["seed"])]["routed"]:
                seeds[str(b["seed"])]["error"] = b.get("error", "")
        configurations[config.name] = {
            "calibration": report.get("calibration"), "hand_tracking": config.hand_tracking,
            "target_mhz": config.target_mhz, "rtlil_sha256": digests.pop(), "seeds": seeds,
            "synth_cpu_s": runs[0]["synth_cpu_s"]}
        commits.append(report.get("commit"))
        tools.append(report.get("tools") or runs[0].get("tools"))
    missing = [c.name for c in CONFIGURATIONS if c.name not in configurations]
    if missing:
        raise ValueError(f"no report of the configuration(s) {', '.join(missing)}")
    if any(t != tools[0] for t in tools):
        raise ValueError("the reports were measured with different tools")
    return {"device": reports[0]["device"], "width": SIZE[0], "height": SIZE[1],
            "commits": commits, "tools": tools[0],
            "configurations": {c.name: configurations[c.name] for c in CONFIGURATIONS}}


def _met(rec: dict, name: str) -> bool:
    conf = rec["configurations"][name]
    return all((s["clocks"]["clk"]["fmax_mhz"] or 0) >= conf["target_mhz"]
               for s in conf["seeds"].values())


def render_table(rec: dict) -> str:
    """The figures page's table of the record: per configuration and seed the
    pipeline clock's and the slower camera clock's Fmax, and the pipeline
    clock's critical path; then the commit and the tools."""
    lines = ["| configuration | target (pipeline clock) | seed | pipeline clock | cameras' PCLK "
             "(slower) | critical path of the pipeline clock |",
             "|---|---|---|---|---|---|"]
    for name, conf in rec["configurations"].items():
        for k, (seed, run) in enumerate(sorted(conf["seeds"].items(), key=lambda s: int(s[0]))):
            clk = run["clocks"]["clk"]
            cams = [c for port, c in run["clocks"].items() if port != "clk"
                    and c["fmax_mhz"] is not None]
            cam = min(cams, key=lambda c: c["fmax_mhz"]) if cams else None
            path = clk["critical_path"] or {}
            fmax = clk["fmax_mhz"]
            mark = "" if fmax is not None and fmax >= conf["target_mhz"] else " (below)"
            route = (f"`{path.get('start')}` to `{path.get('end')}`, {path.get('logic_levels')} "
                     f"levels, {path.get('delay_ns')} ns of which {path.get('routing_ns')} ns "
                     "routing") if path else "-"
            fmax_text = f"{fmax} MHz{mark}"
            if not run.get("routed", True):
                fmax_text = "not routed"
                route = f"nextpnr: {run.get('error', '')}".replace("|", "/")
            head = (f"{name} | >= {conf['target_mhz']:g} MHz"
                    + (": met" if _met(rec, name) else ": not met")) if k == 0 else " | "
            cam_text = f"{cam['fmax_mhz']} MHz (at {cam['constraint_mhz']:g})" if cam else "-"
            lines.append(f"| {head} | {seed} | {fmax_text} | {cam_text} | {route} |")
    commits = sorted({(c or {}).get("sha", "?")[:7] + ("+" if (c or {}).get("dirty") else "")
                      for c in rec["commits"]})
    tools = rec["tools"] or {}
    measured = (f"Measured with `make timing` at commit {', '.join(f'`{c}`' for c in commits)} "
                "('+': with changes to hdl/, soc/ or sim/ not yet committed), with "
                f"{tools.get('yosys', '?')} and {tools.get('nextpnr', '?')} ({rec['device']}, "
                f"{rec['width']}x{rec['height']}).")
    lines = [measured, ""] + lines
    return "\n".join(lines)


def replace_table(page_text: str, table: str) -> str:
    """``page_text`` with the text between the markers replaced by ``table``;
    ValueError if the markers are missing."""
    try:
        head, rest = page_text.split(TABLE_BEGIN, 1)
        _, tail = rest.split(TABLE_END, 1)
    except ValueError:
        raise ValueError(f"the page has no '{TABLE_BEGIN}' ... '{TABLE_END}' markers") \
            from None
    return f"{head}{TABLE_BEGIN}\n{table}\n{TABLE_END}{tail}"


def design_digest(config: Configuration) -> str:
    """The SHA-256 of the RTLIL ``stereogest timing --block pipeline`` places
    for ``config`` today (the default rig's calibration, as ``stereogest
    chessboards --truth`` writes it)."""
    from sim.calibration import (StereoRig, load_calibration, rig_calibration,
                                 save_calibration, stereo_rectification)
    from sim.model.pipeline import PipelineParams, hand_tracking_for
    from soc.clocks import PCLK_HZ, SYNC_HZ

    from .place_route import timing_design, timing_rtlil
    width, height = SIZE
    params = PipelineParams()
    if config.hand_tracking:
        params = dataclasses.replace(params, **hand_tracking_for(width))
    rectification = None
    if config.calibration:
        with tempfile.TemporaryDirectory() as tmp:
            path = save_calibration(rig_calibration(StereoRig()), Path(tmp) / "calib.json")
            rectification = stereo_rectification(load_calibration(path), width, height,
                                                 interpolation="bilinear")
    dut, clocks, shell = timing_design("pipeline", width, height, params, sync_hz=SYNC_HZ,
                                       pclk_hz=PCLK_HZ, rectification=rectification)
    text = timing_rtlil(dut, "pipeline", clocks=clocks, shell=shell)
    return hashlib.sha256(text.encode()).hexdigest()


def stale(rec: dict) -> list[str]:
    """The configurations whose recorded netlist is not the one built today."""
    by_name = {c.name: c for c in CONFIGURATIONS}
    return [name for name, conf in rec["configurations"].items()
            if design_digest(by_name[name]) != conf["rtlil_sha256"]]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hdl.timing_record",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("reports", nargs="+", metavar="REPORT.json",
                        help="stereogest timing --block pipeline reports, one per configuration")
    parser.add_argument("-o", "--output", default=str(RECORD), metavar="RECORD.json")
    parser.add_argument("--page", default=None, metavar="PAGE.md",
                        help="also write the table into this page between the markers")
    args = parser.parse_args(argv)
    try:
        reports = []
        for path in args.reports:
            try:
                reports.append(json.loads(Path(path).read_text()))
            except (OSError, ValueError) as exc:
                raise ValueError(f"{path}: not a readable timing report ({exc})") from None
        rec = record(reports)
        page = None
        if args.page:
            try:
                page = replace_table(Path(args.page).read_text(), render_table(rec))
            except OSError as exc:
                raise ValueError(f"--page: {args.page}: {exc.strerror}") from None
        # both outputs tried before either is written: nothing half-written
        from stereogest.commands import check_output_file
        check_output_file(args.output, "--output")
        if page is not None:
            check_output_file(args.page, "--page")
        from sim.atomic import write_text_atomic
        write_text_atomic(args.output, json.dumps(rec, indent=1) + "\n")
        if page is not None:
            write_text_atomic(args.page, page)
    except ValueError as exc:
        print(f"python -m hdl.timing_record: error: {exc}", file=sys.stderr)
        return 2
    print(render_table(rec))
    return 0


if __name__ == "__main__":
    sys.exit(main())
