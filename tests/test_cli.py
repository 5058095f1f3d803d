"""The stereogest console script, called in-process: stereo, eval-stereo, pipeline,
demo, error reporting and --help."""
import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import stereogest.cli as cli
from sim.clip import save_clip
from sim.evaluate import score_disparity
from sim.images import read_array, read_grey
from sim.model.pipeline import PipelineParams, run_clip
from sim.model.stereo import stereo_match
from sim.pictures import LEGEND_HEIGHT
from sim.render import render_clip
from tests.cli_helpers import assert_one_line_error, run

TSUKUBA = Path(__file__).resolve().parent.parent / "data" / "middlebury" / "tsukuba"
VENUS = TSUKUBA.parent / "venus"
OPTIONS = ["--census-window", "7", "--hamming-window", "13", "--max-disparity", "32",
           "--lrcc-threshold", "8"]


def files_in(path):
    return sorted(p.name for p in Path(path).iterdir())


# ---------------------------------------------------------------- stereo


@pytest.fixture(scope="module")
def tsukuba_disparity():
    left, right = read_grey(TSUKUBA / "left.png"), read_grey(TSUKUBA / "right.png")
    return stereo_match(left, right, census_window=7, hamming_window=13, max_disparity=32,
                        lrcc_threshold=8).disparity


def test_stereo_writes_the_model_disparity(tmp_path, capsys, tsukuba_disparity):
    out = tmp_path / "disp.png"
    status, stdout, err = run(capsys, "stereo", TSUKUBA / "left.png", TSUKUBA / "right.png",
                              "-o", out, *OPTIONS)
    assert status == 0 and err == ""
    with Image.open(out) as img:
        assert img.mode.startswith("I")                 # 16-bit grey, not 8-bit "L"
        disp = np.asarray(img)
    assert disp.shape == (288, 384)
    assert np.array_equal(disp, tsukuba_disparity)
    lines = stdout.strip().splitlines()
    assert len(lines) == 1
    info = json.loads(lines[0])
    assert info["output"] == str(out) and (info["width"], info["height"]) == (384, 288)
    assert info["pct_invalid"] == pytest.approx(100 * (tsukuba_disparity == 0).mean(), abs=1e-3)
    # beside it, a preview a person can read: colour-mapped, with the colour bar
    assert info["preview"] == str(tmp_path / "disp_colour.png")
    assert files_in(tmp_path) == ["disp.png", "disp_colour.png"]  # no temporary file left
    preview = np.asarray(Image.open(tmp_path / "disp_colour.png"))
    assert preview.shape[0] == 288 and preview.shape[1] > 384 and preview.shape[2] == 3
    assert not preview[:, :384][tsukuba_disparity == 0].any()        # no match: black
    assert preview[:, :384][tsukuba_disparity > 0].any(axis=1).all()


def test_stereo_options_reach_the_matcher(tmp_path, capsys):
    out = tmp_path / "disp.png"
    status, _, _ = run(capsys, "stereo", TSUKUBA / "left.png", TSUKUBA / "right.png", "-o", out,
                       "--census-window", "5", "--hamming-window", "9", "--max-disparity", "20",
                       "--lrcc-threshold", "2", "--no-match-cost", "3", "--prefilter-median",
                       "--no-disparity-median", "--threads", "2")
    assert status == 0
    left, right = read_grey(TSUKUBA / "left.png"), read_grey(TSUKUBA / "right.png")
    expected = stereo_match(left, right, census_window=5, hamming_window=9, max_disparity=20,
                            lrcc_threshold=2, no_match_cost=3, prefilter_median=True,
                            disparity_median=False).disparity
    assert np.array_equal(read_array(out), expected)


@pytest.mark.parametrize("case", ["missing", "sizes", "census", "not-an-image", "hamming"])
def test_stereo_errors(tmp_path, capsys, case):
    left, right = TSUKUBA / "left.png", TSUKUBA / "right.png"
    extra, words = OPTIONS, []
    if case == "missing":
        left, words = tmp_path / "nope.png", ["nope.png"]
    elif case == "sizes":
        right, words = VENUS / "right.png", ["384x288", "434x383"]
    elif case == "census":
        extra, words = ["--census-window", "4"], ["--census-window must be odd"]
    elif case == "hamming":
        extra, words = ["--hamming-window", "14"], ["--hamming-window must be odd"]
    else:
        left = tmp_path / "text.png"
        left.write_text("not a picture")
        words = ["text.png"]
    out = tmp_path / "disp.png"
    status, stdout, err = run(capsys, "stereo", left, right, "-o", out, *extra)
    assert status == 2 and stdout == ""
    assert_one_line_error(err, "stereo", *words)
    assert not out.exists()
    assert [n for n in files_in(tmp_path) if n.startswith("disp")] == []


# ---------------------------------------------------------------- eval-stereo


def test_eval_stereo_matches_score_disparity(tmp_path, capsys, tsukuba_disparity):
    disp = tmp_path / "disp.png"
    assert run(capsys, "stereo", TSUKUBA / "left.png", TSUKUBA / "right.png", "-o", disp,
               *OPTIONS)[0] == 0
    truth = read_array(TSUKUBA / "disp_left.png")

    status, stdout, err = run(capsys, "eval-stereo", disp, TSUKUBA / "disp_left.png",
                              "--gt-scale", "16")
    assert status == 0 and err == ""
    got = json.loads(stdout.strip().splitlines()[-1])
    expected = score_disparity(tsukuba_disparity, truth, 16)
    assert got["pct_good"] == expected["pct_good"]
    assert got["pct_invalid"] == expected["pct_invalid"]
    assert "pct_good_excluding_left" not in got

    status, stdout, _ = run(capsys, "eval-stereo", disp, TSUKUBA / "disp_left.png",
                            "--gt-scale", "16", "--exclude-left", "32", "--max-error", "0.5")
    assert status == 0
    got = json.loads(stdout)
    expected = score_disparity(tsukuba_disparity, truth, 16, max_error=0.5, exclude_left=32)
    for key in ("pct_good", "pct_invalid", "pct_good_excluding_left"):
        assert got[key] == expected[key], key


@pytest.mark.parametrize("extra, words", [
    (["--gt-scale", "0"], ["--gt-scale must be"]),
    (["--gt-scale", "16", "--exclude-left", "999"], ["--exclude-left must be in"]),
    (["--gt-scale", "16", "--max-error", "-1"], ["--max-error"]),
])
def test_eval_stereo_bad_options(capsys, extra, words):
    status, stdout, err = run(capsys, "eval-stereo", TSUKUBA / "disp_left.png",
                              TSUKUBA / "disp_left.png", *extra)
    assert status == 2 and stdout == ""
    assert_one_line_error(err, "eval-stereo", *words)


def test_eval_stereo_size_mismatch_and_missing(tmp_path, capsys):
    status, _, err = run(capsys, "eval-stereo", TSUKUBA / "disp_left.png",
                         VENUS / "disp_left.png", "--gt-scale", "8")
    assert status == 2
    assert_one_line_error(err, "eval-stereo", "DISP.png", "GT.png")
    status, _, err = run(capsys, "eval-stereo", tmp_path / "gone.png",
                         TSUKUBA / "disp_left.png", "--gt-scale", "16")
    assert status == 2
    assert_one_line_error(err, "eval-stereo", "gone.png")


# ---------------------------------------------------------------- pipeline

STAGES = ("left", "right", "disparity", "skin", "band", "opening")


@pytest.fixture(scope="module")
def clip_dir(tmp_path_factory):
    # 320x240: at the default parameters the hand is found in every frame (see
    # test_model_pipeline), so the trajectory has motion, flags and symbols.
    clip = render_clip("rotate-right", 1, 320, 240, n_pre_rest=2, n_motion=10, n_post_rest=2)
    return clip, save_clip(clip, tmp_path_factory.mktemp("clips") / "clip")


def test_pipeline_outputs(tmp_path, capsys, clip_dir):
    clip, path = clip_dir
    out = tmp_path / "out"
    status, stdout, err = run(capsys, "pipeline", path, "-o", out, "--frames", "0,5")
    assert status == 0
    assert "frame 14/14" in err                         # progress (not --quiet)
    assert str(out) in stdout

    # the spotting scaled to the frame as in `demo` (PipelineParams.for_frame)
    params = PipelineParams.for_frame(320)
    assert "spotting: Tm = 15 px" in err
    trajectory, kept = run_clip(clip.left, clip.right, params, keep=lambda n: n in (0, 5))
    assert trajectory.flag.any() and (trajectory.symbol >= 0).any()     # not a trivial clip

    with open(out / "trajectory.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["frame", "x", "y", "flag", "symbol"]
    assert len(rows) == 1 + clip.frames
    for n, row in enumerate(rows[1:]):
        x, y = trajectory.smoothed[n] / 256
        assert row == [str(n), f"{x:.4f}", f"{y:.4f}", str(int(trajectory.flag[n])),
                       str(int(trajectory.symbol[n]))], n

    pictures = sorted(p.name for p in out.glob("frame_*.png"))
    assert pictures == sorted(f"frame_{n:04d}_{s}.png" for n in (0, 5)
                              for s in STAGES + ("sheet",))
    sheet = np.asarray(Image.open(out / "frame_0005_sheet.png"))
    assert sheet.ndim == 3 and sheet.shape[0] > 2 * 240 and sheet.shape[1] > 3 * 320
    for n in (0, 5):
        st = kept[n]
        assert np.array_equal(read_array(out / f"frame_{n:04d}_left.png"), st.left)
        assert np.array_equal(read_array(out / f"frame_{n:04d}_right.png"), st.right)
        for stage, mask in (("skin", st.skin), ("band", st.band), ("opening", st.opened)):
            assert np.array_equal(read_array(out / f"frame_{n:04d}_{stage}.png"),
                                  mask.astype(np.int64) * 255), stage
        rgb = np.asarray(Image.open(out / f"frame_{n:04d}_disparity.png").convert("RGB"))
        assert rgb.shape == (240, 320, 3)
        assert not rgb[st.disparity == 0].any() and rgb[st.disparity > 0].any(axis=1).all()
    traj_png = np.asarray(Image.open(out / "trajectory.png"))
    assert traj_png.shape == (240 + LEGEND_HEIGHT, 320, 3)           # the legend below

    summary = json.loads((out / "summary.json").read_text())
    assert summary["gesture"] == "rotate-right" and summary["frames"] == clip.frames
    assert summary["gesture_frames"] == int(trajectory.flag.sum())
    assert summary["symbols"] == "".join(str(s) for s in trajectory.symbol if s >= 0)
    assert summary["params"] == json.loads(json.dumps(params.as_dict()))
    assert "recognised" in summary and "telegram" in summary
    assert f"recognised: {summary['recognised'] or 'none'}" in stdout
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith("frame_")) == [
        "summary.json", "trajectory.csv", "trajectory.png"]

    # the folder used again: the pictures of the last run go (none may pass for
    # this run's), a file of the user's stays
    (out / "notes.txt").write_text("mine")
    status, _, _ = run(capsys, "pipeline", path, "-o", out, "--frames", "3", "--quiet")
    assert status == 0
    assert sorted(p.name for p in out.glob("frame_*.png")) == sorted(
        f"frame_0003_{s}.png" for s in STAGES + ("sheet",))
    assert (out / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("frames, words", [("0,99", ["--frames", "99"]),
                                           ("0,x", ["--frames", "'0,x'"]),
                                           ("-1", ["--frames"])])
def test_pipeline_bad_frames(tmp_path, capsys, clip_dir, frames, words):
    _, path = clip_dir
    out = tmp_path / "out"
    status, stdout, err = run(capsys, "pipeline", path, "-o", out, f"--frames={frames}",
                              "--quiet")
    assert status == 2 and stdout == ""
    assert_one_line_error(err, "pipeline", *words)
    assert not out.exists()


def test_pipeline_not_a_clip(tmp_path, capsys):
    status, _, err = run(capsys, "pipeline", tmp_path / "nothing", "-o", tmp_path / "out")
    assert status == 2
    assert_one_line_error(err, "pipeline")
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------- demo


def test_demo_small(tmp_path, capsys):
    out = tmp_path / "demo"
    status, stdout, err = run(capsys, "demo", "--width", "160", "--height", "120", "-o", out,
                              "--backend", "model", "--quiet")
    # 160x120 is too small a view to recognise the gesture: a failed demo (exit 1,
    # one line) that still leaves every output
    assert status == 1, err
    assert err == "stereogest demo: error: the clip shows rotate-right but the board " \
                  "application recognised nothing\n"
    summary = json.loads(stdout.strip().splitlines()[-1])
    assert summary["recognised"] is None
    assert {"gesture", "frames", "flagged", "symbols"} <= set(summary)
    assert summary["gesture"] == "rotate-right"               # the default
    clip_meta = json.loads((out / "clip" / "clip.json").read_text())
    assert (clip_meta["width"], clip_meta["height"]) == (160, 120)
    assert summary["frames"] == clip_meta["frames"]
    with open(out / "pipeline" / "trajectory.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == summary["frames"]
    assert summary["flagged"] == sum(int(r["flag"]) for r in rows)
    assert summary["symbols"] == "".join(r["symbol"] for r in rows if int(r["symbol"]) >= 0)
    pictures = out / "pipeline"
    assert (pictures / "trajectory.png").is_file() and (pictures / "summary.json").is_file()
    stage_pngs = list(pictures.glob("frame_*_*.png"))
    assert stage_pngs and len(stage_pngs) % (len(STAGES) + 1) == 0      # + the sheet


def test_demo_hard_scene_needs_the_hand_tracking(tmp_path, capsys):
    """`demo --scene hard` (a forearm, an intruder at the hand's depth, ...): the
    thesis' centroid misses this person's gesture, the hand tracking's finds it;
    the pipeline summary records the parameters used."""
    found = {}
    for option in ([], ["--hand-tracking"]):
        out = tmp_path / f"demo{len(option)}"
        status, stdout, err = run(capsys, "demo", "--backend", "model", "--scene", "hard",
                                  "--gesture", "left", "--seed", "2001", "--width", "320",
                                  "--height", "240", "-o", out, "--quiet", *option)
        # missing its own gesture fails the demo
        assert (status, err) == ((0, "") if option else
                                 (1, "stereogest demo: error: the clip shows left but the "
                                     "board application recognised nothing\n")), err
        found[bool(option)] = json.loads(stdout.strip().splitlines()[-1])["recognised"]
        params = json.loads((out / "pipeline" / "summary.json").read_text())["params"]
        assert (params["track_gate"], params["hand_rows"]) == ((32, 18) if option else (0, 0))
    assert found == {False: None, True: "left"}


@pytest.mark.parametrize("gesture, recognised, names, failure", [
    ("stop", "stop", ("stop", "left"), None),
    (None, None, ("stop",), None),                           # unlabelled footage
    (None, "left", ("stop", "left"), None),
    ("stop", None, ("stop", "left"),
     "the clip shows stop but the board application recognised nothing"),
    ("stop", "left", ("stop", "left"),
     "the clip shows stop but the board application recognised left"),
    ("stop", None, ("up", "down"), "the clip shows stop but the board application "
                                   "recognised nothing (the model has no class stop: up, down)"),
])
def test_demo_fails_when_its_gesture_is_not_recognised(gesture, recognised, names, failure):
    """The demo's verdict (exit 1 and this line unless None): the recognised
    gesture must be the rendered (or labelled) one."""
    from stereogest.commands.demo import gesture_failure
    assert gesture_failure(gesture, recognised, names) == failure


def test_demo_sequence_continuous(tmp_path, capsys):
    """`demo --sequence ... --spotting continuous` (model backend): every
    rendered gesture named once, scored against the truth; the thesis'
    spotting on the same back-to-back clip fails the demo."""
    for spotting, expected in (("continuous", 0), ("thesis", 1)):
        # the open hand: the continuous figures at 320x240 are for it (docs/figures/recognition.md)
        status, stdout, err = run(capsys, "demo", "--backend", "model", "--sequence",
                                  "right,stop", "--pause", "0-5", "--spotting", spotting,
                                  "--width", "320", "--height", "240", "--posture", "open",
                                  "-o", tmp_path / spotting, "--quiet")
        summary = json.loads(stdout.strip().splitlines()[-1])
        assert status == expected, err
        if expected == 0:
            assert [g["name"] for g in summary["gestures"]] == ["right", "stop"]
            assert (summary["truth"]["correct"], summary["truth"]["false"]) == (2, 0)
        else:
            assert err.startswith("stereogest demo: error: the board application named ")


@pytest.mark.parametrize("argv, message", [
    (["--sequence", "right,wave"], "--sequence: names must be among"),
    (["--sequence", "right", "--clip", "x"], "--sequence renders a clip"),
    (["--sequence", "right", "--pause", "4-1"], "--pause must satisfy"),
    (["--spotting", "continuous", "--model", "sw_hps/models/gestures7.json"],
     "continuous spotting needs a discrete model file"),
])
def test_demo_sequence_bad_input(tmp_path, capsys, argv, message):
    status, stdout, err = run(capsys, "demo", "--backend", "model", "-o", tmp_path / "d",
                              *argv)
    assert status == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("value", ["-2", "10001"])
def test_demo_pre_rest_out_of_range_is_one_line_and_writes_nothing(tmp_path, capsys, value):
    out = tmp_path / "demo"
    status, stdout, err = run(capsys, "demo", "--pre-rest", value, "-o", out,
                              "--backend", "model", "--quiet")
    assert status == 2 and stdout == ""
    assert err.count("\n") == 1 and "--pre-rest must be in -1..10000" in err
    assert not out.exists()


# ---------------------------------------------------------------- help

HELP_OPTIONS = {
    None: ["render", "clip", "stereo", "eval-stereo", "pipeline", "demo", "generate",
           "resources", "timing", "--version"],
    "clip": ["--left", "--right", "--output", "--width", "--height", "--fps", "--frames",
             "--gesture", "--json"],
    "render": ["--gesture", "--seed", "--output", "--width", "--height", "--fps"],
    "stereo": ["LEFT", "RIGHT", "--output", "--census-window", "--hamming-window",
               "--max-disparity", "--lrcc-threshold", "--no-match-cost",
               "--prefilter-median", "--no-disparity-median", "--threads"],
    "eval-stereo": ["DISP.png", "GT.png", "--gt-scale", "--max-error", "--exclude-left"],
    "pipeline": ["CLIP", "--output", "--frames", "--threads", "--spot-threshold", "--spot-hold",
                 "--model", "--json", "--quiet"],
    "demo": ["--gesture", "--seed", "--pre-rest", "--width", "--height", "--output",
             "--backend", "--stage", "--threads", "--clip", "--quiet"],
    "generate": ["--output", "--out", "--width", "--height"],
    "resources": ["--width", "--height", "--quiet"],
    "timing": ["--block", "--width", "--height", "--census-window", "--hamming-window",
               "--max-disparity", "--opening-size", "--seed", "--router", "--json", "--keep"],
}


@pytest.mark.parametrize("command", list(HELP_OPTIONS), ids=str)
def test_help(capsys, command):
    argv = ["--help"] if command is None else [command, "--help"]
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 0
    out, err = capsys.readouterr()
    assert err == ""
    for word in HELP_OPTIONS[command]:
        assert word in out, word
    if command is not None:                     # and whatever else the parser defines
        sub = next(a for a in cli.build_parser()._subparsers._group_actions
                   if a.choices).choices[command]
        for action in sub._actions:
            for option in action.option_strings:
                assert option in out, option


def test_no_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([])
    assert exc.value.code == 2
    err = capsys.readouterr().err          # one line; --help has the usage
    assert err == "stereogest: error: the following arguments are required: COMMAND\n"


def test_version_and_one_seed_default(capsys):
    from importlib.metadata import version

    from stereogest.commands import DEFAULT_SEED
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"stereogest {version('stereogest')}"
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    seeds = {name: next(a.default for a in p._actions if a.dest == "seed")
             for name, p in sub.choices.items() if any(a.dest == "seed" for a in p._actions)}
    assert set(seeds) == {"render", "chessboards", "demo", "gestures", "train", "timing",
                          "train-posture", "postures"}
    # timing's --seed may be repeated (no default list to append to): none given is DEFAULT_SEED
    from stereogest.commands.timing import parse_seeds
    assert seeds.pop("timing") is None and parse_seeds(None, None) == [DEFAULT_SEED]
    assert set(seeds.values()) == {DEFAULT_SEED}


def test_every_output_option_is_dash_o(capsys):
    """-o/--output names the output of every command that writes one."""
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    writers = {"render", "clip", "stereo", "pipeline", "demo", "gestures", "train", "generate",
               "postures", "train-posture"}
    for name in writers:
        options = {s for a in sub.choices[name]._actions for s in a.option_strings}
        assert {"-o", "--output"} <= options, name
