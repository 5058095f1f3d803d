# amaranth: UnusedElaboratable=no
"""hdl/timing_record.py: the whole pipeline's routed timing as docs/figures/fpga.md
states it. The page's table is the record's; the record describes the
netlists the hardware builds today (a change to the pipeline fails here until
``make timing`` has measured it); the record is made only from complete,
consistent reports."""
from __future__ import annotations

import copy
import json

import pytest

from hdl import timing_record as tr

ROOT = tr.RECORD.parent.parent


def _report(calibrated: bool, tracking: bool, digest="ab" * 32, fmax=(120.0, 118.5, 121.0)):
    """A stereogest timing --block pipeline report with three seeds."""
    runs = []
    for seed, mhz in zip((1, 2, 3), fmax):
        path = {"start": "a", "end": "b", "logic_levels": 1, "delay_ns": 8.1,
                "routing_ns": 6.0, "nets": ["a", "b"]}
        clocks = {"clk": {"constraint_mhz": 100.0, "fmax_mhz": mhz, "passed": True,
                          "critical_path": path},
                  "cam_left_clk": {"constraint_mhz": 50.0, "fmax_mhz": 150.0 + seed,
                                   "passed": True, "critical_path": path}}
        runs.append({"seed": seed, "passed": True, "blocks": [{
            "block": "pipeline", "seed": seed, "clocks": clocks, "rtlil_sha256": digest,
            "tools": {"yosys": "Yosys X", "nextpnr": "nextpnr Y"}, "pnr_cpu_s": 500.0,
            "synth_cpu_s": 90.0, "resources": {"lut4": 1, "ccu2c": 1, "ff": 1, "ebr": 1}}]})
    return {"device": "LFE5U-85F-8CABGA381", "width": 640, "height": 480,
            "params": {"track_gate": 80 if tracking else 0},
            "calibration": "CALIB.json" if calibrated else None,
            "commit": {"sha": "0123456789abcdef", "dirty": False},
            "tools": {"yosys": "Yosys X", "nextpnr": "nextpnr Y"}, "runs": runs}


def test_record_and_table_from_two_reports():
    rec = tr.record([_report(True, True, fmax=(108.0, 111.0, 112.5)), _report(False, False)])
    assert list(rec["configurations"]) == ["thesis", "calibration + hand tracking"]
    thesis = rec["configurations"]["thesis"]
    assert thesis["target_mhz"] == 115.0 and set(thesis["seeds"]) == {"1", "2", "3"}
    table = tr.render_table(rec)
    assert "| thesis | >= 115 MHz: met | 1 | 120.0 MHz |" in table
    assert "calibration + hand tracking | >= 110 MHz: not met | 1 | 108.0 MHz (below)" in table
    assert "Measured with `make timing` at commit `0123456`" in table and "Yosys X" in table
    readme = f"intro\n{tr.TABLE_BEGIN}\nold\n{tr.TABLE_END}\nrest\n"
    assert tr.replace_table(readme, table) == \
        f"intro\n{tr.TABLE_BEGIN}\n{table}\n{tr.TABLE_END}\nrest\n"
    with pytest.raises(ValueError, match="markers"):
        tr.replace_table("no markers", table)


def test_a_seed_not_routed_is_shown_and_not_met():
    report = _report(True, True, fmax=(121.0, 122.0, 123.0))
    block = report["runs"][2]["blocks"][0]
    block.update(routed=False, error="Failed to route arc 0 of net rst")
    block["clocks"]["clk"].update(fmax_mhz=None, passed=False, critical_path=None)
    rec = tr.record([report, _report(False, False)])
    assert rec["configurations"]["calibration + hand tracking"]["seeds"]["3"]["error"] \
        == "Failed to route arc 0 of net rst"
    table = tr.render_table(rec)
    assert "calibration + hand tracking | >= 110 MHz: not met | 1 | 121.0 MHz |" in table
    assert "| 3 | not routed | 153.0 MHz (at 50) | nextpnr: Failed to route arc 0 of net rst |" \
        in table


@pytest.mark.parametrize("mutate, match", [
    (lambda rs: rs.pop(), r"no report of the configuration\(s\) calibration \+ hand tracking"),
    (lambda rs: rs.append(copy.deepcopy(rs[0])), "two reports of the configuration 'thesis'"),
    (lambda rs: rs[0]["runs"][1]["blocks"][0].update(rtlil_sha256="cd" * 32),
     "thesis: its runs placed different netlists"),
    (lambda rs: rs[0].update(width=320), "must be of 640x480 frames, got 320x480"),
    (lambda rs: rs[0]["runs"][0]["blocks"][0].update(block="census"),
     "stereogest timing --block pipeline"),
    (lambda rs: rs[1].update(tools={"yosys": "other"}), "different tools"),
])
def test_record_refuses_incomplete_or_mixed_reports(mutate, match):
    reports = [_report(False, False), _report(True, True)]
    mutate(reports)
    with pytest.raises(ValueError, match=match):
        tr.record(reports)


def test_main_writes_the_record_and_the_page_or_one_error_line(tmp_path, capsys):
    paths = []
    for k, flags in enumerate(((False, False), (True, True))):
        paths.append(tmp_path / f"r{k}.json")
        paths[-1].write_text(json.dumps(_report(*flags)))
    readme = tmp_path / "fpga.md"
    readme.write_text(f"x\n{tr.TABLE_BEGIN}\n{tr.TABLE_END}\n")
    out = tmp_path / "rec.json"
    assert tr.main([*map(str, paths), "-o", str(out), "--page", str(readme)]) == 0
    rec = json.loads(out.read_text())
    assert tr.render_table(rec) in readme.read_text()
    (tmp_path / "bad.json").write_text("{")
    assert tr.main([str(paths[0]), str(tmp_path / "bad.json"), "-o", str(tmp_path / "n.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.json: not a readable timing report" in err[0]
    assert not (tmp_path / "n.json").exists()
    # a page without the markers, or one that is missing: one line, nothing written
    for bad, word in ((tmp_path / "rec.json", "markers"), (tmp_path / "none.md", "--page")):
        assert tr.main([*map(str, paths), "-o", str(tmp_path / "m.json"),
                        "--page", str(bad)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and word in err[0]
        assert not (tmp_path / "m.json").exists()


def test_figures_page_shows_the_records_table():
    rec = json.loads(tr.RECORD.read_text())
    readme = tr.PAGE.read_text()
    assert tr.replace_table(readme, tr.render_table(rec)) == readme, \
        ("docs/figures/fpga.md's pipeline timing table is not "
         "hdl/timing_pipeline.json's: run make timing")


def test_record_describes_todays_hardware():
    """The recorded netlists are today's: a change to the pipeline's hardware
    makes the figures stale until ``make timing`` measures it again."""
    rec = json.loads(tr.RECORD.read_text())
    assert tr.stale(rec) == [], "the pipeline changed since its routed timing was measured: " \
        "run make timing"
