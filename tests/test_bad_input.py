"""The bad-input corpus (issue 15): every subcommand and the board application
given bad options, bad values, missing, wrong and broken files and unwritable
outputs. Each case asserts one line on stderr naming the option (or file)
with no traceback, the exit status, and that nothing is left behind."""
from __future__ import annotations

import itertools
import json
import os
from pathlib import Path

import numpy as np
import pytest

from stereogest import cli

DATA = Path(__file__).resolve().parent.parent / "data"
TSUKUBA = DATA / "middlebury" / "tsukuba"
DOLLAR = DATA / "gestures" / "dollar1_unistroke" / "dollar1_unistroke.npz"
MODEL = Path(__file__).resolve().parent.parent / "sw_hps" / "models" / "gestures7.json"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Files the cases name: a small clip, a dataset, and broken look-alikes."""
    from recognition.datasets import load_trajectories, save_trajectories
    from sim.clip import save_clip
    from sim.render import render_clip
    root = tmp_path_factory.mktemp("inputs")
    save_clip(render_clip("stop", 1, 96, 64, n_pre_rest=1, n_motion=2, n_post_rest=0),
              root / "clip")
    assert cli.main(["gestures", "-o", str(root / "data.npz"), "--per-class", "3",
                     "--people", "1", "--width", "320", "--height", "240"]) == 0
    data = load_trajectories(root / "data.npz")
    save_trajectories(data, root / "data2.npz")
    np.save(root / "array.npy", np.zeros(3))
    os.replace(root / "array.npy", root / "renamed.npz")                # .npy named .npz
    (root / "truncated.npz").write_bytes((root / "data2.npz").read_bytes()[:200])
    (root / "text.png").write_text("not a picture")
    from recognition.datasets import TrajectorySet
    one = TrajectorySet(data.points[:data.offsets[2]], data.offsets[:3],
                        np.array(["stop", "stop"]))
    save_trajectories(one, root / "one_class.npz")
    save_trajectories(TrajectorySet(one.points, one.offsets, np.array(["wave", "circle"])),
                      root / "foreign_labels.npz")               # no gesture of the model
    empty = TrajectorySet(np.zeros((0, 2)), np.zeros(1, np.int64), np.array([], str))
    save_trajectories(empty, root / "empty.npz")
    arrays = dict(np.load(root / "data2.npz"))
    arrays["label"] = np.array([""] * len(arrays["label"]))
    np.savez(root / "blank_labels.npz", **arrays)
    (root / "model.json").write_bytes(MODEL.read_bytes())
    (root / "text.json").write_text("not json")
    (root / "empty.json").write_text("{}")
    (root / "afile").write_text("a file where a directory is expected")
    (root / "adir").mkdir()
    from PIL import Image
    Image.fromarray(np.random.default_rng(0).integers(0, 256, (288, 384, 3), np.uint8)).save(
        root / "rgb.png")                                               # a colour photo
    models = json.loads(MODEL.read_text())
    models["class_names"] = models["class_names"][:-1]                 # 6 names, 7 models
    (root / "short_names.json").write_text(json.dumps(models))
    thesis = json.loads((MODEL.parent / "thesis7.json").read_text())
    thesis["num_symbols"] = 9                 # a valid HMM file, but not for 8 orientations
    for m in thesis["models"]:
        m["B"] = [[p * 0.9 for p in row] + [0.1] for row in m["B"]]
    (root / "nine_symbols.json").write_text(json.dumps(thesis))
    from sim.calibration import StereoRig, rig_calibration, save_calibration
    save_calibration(rig_calibration(StereoRig()), root / "calib640.json")
    doc = json.loads((root / "calib640.json").read_text())
    doc["R"] = [[2, 0, 0], [0, 1, 0], [0, 0, 1]]
    (root / "calib_bad_r.json").write_text(json.dumps(doc))
    del doc["T"]
    (root / "calib_no_t.json").write_text(json.dumps(doc))
    (root / "unpaired").mkdir()
    Image.fromarray(np.zeros((48, 64), np.uint8)).save(root / "unpaired" / "left_a.png")
    _posture_inputs(root)
    return root


def _posture_inputs(root):
    """Pictures for train-posture and classify-posture: two students' photos,
    look-alikes of them, and a posture model trained on them."""
    from recognition import posture as rp
    photos = np.load(DATA / "hand_postures" / "sign_language_digits_dev.npz")
    keep = photos["subject"] < 2
    image, label, subject = photos["image"][keep], photos["label"][keep], \
        photos["subject"][keep]
    np.savez(root / "postures.npz", image=image, label=label, subject=subject)
    np.savez(root / "postures_no_subject.npz", image=image, label=label)
    np.savez(root / "postures_label_12.npz", image=image, label=np.where(label == 3, 12, label))
    np.savez(root / "postures_two_names.npz", image=image[:4], label=np.array([0, 1, 2, 1]),
             class_names=np.array(["fist", "open"]))
    np.savez(root / "postures_unknown_names.npz", image=image[:2], label=np.array([0, 1]),
             class_names=np.array(["fist", "open"]))
    np.savez(root / "postures_grey.npz", image=image[..., 0], label=label)
    np.savez(root / "postures_64.npz", image=np.ascontiguousarray(image[:, :64, :64]),
             label=label)
    white = image.copy()
    white[5] = 255                                         # a picture without skin
    np.savez(root / "postures_no_skin.npz", image=white, label=label)
    features = np.zeros((len(label), 176))   # FEATURES
    features[3, 7] = np.nan                                # a record that is not one
    np.savez(root / "postures_nan_features.npz", image=image, label=label, features=features)
    np.savez(root / "postures_short_features.npz", image=image, label=label,
             features=np.zeros((len(label), 5)))
    data = rp.load_postures(root / "postures.npz")
    model = rp.train_posture(rp.still_features(rp.picture_masks(data)), data.label,
                             data.class_names, c=10.0)
    model.meta = {"picture_sizes": [[100, 100]]}
    (root / "posture.json").write_text(json.dumps(model.to_dict()))
    bad = model.to_dict()
    bad["version"] = 9
    (root / "posture_v9.json").write_text(json.dumps(bad))


def case(*argv, match, code=2):
    return pytest.param(list(argv), match, code, id=" ".join(argv)[:80] or "no-args")


IN = "{in}"          # the inputs folder
OUT = "{out}"        # a fresh output folder (must stay empty)
RO = "{ro}"          # a read-only file system (a tmpfs mounted read-only)
DENIED = "{denied}"  # a folder that refuses new files even to root (/sys)


def int_option_cases(command, base, options):
    """argparse-level bad values of every integer option: one line too."""
    for option in options:
        for bad in ("abc", "1.5", ""):
            yield case(command, *base, option, bad, match=f"argument {option}")


CASES = [
    # ------------------------------------------------------------ top level
    case(match="required: COMMAND"),
    case("nonsense", match="invalid choice: 'nonsense'"),
    case("render", "--gesture", "stop", "-o", f"{OUT}/c", "--no-such-option",
         match="unrecognized arguments: --no-such-option"),
    # ------------------------------------------------------------ render
    *int_option_cases("render", ["--gesture", "stop", "-o", f"{OUT}/c"],
                      ["--seed", "--width", "--height", "--fps"]),
    case("render", "-o", f"{OUT}/c", match="--gesture"),
    case("render", "--gesture", "stop", match="-o/--output"),
    case("render", "--gesture", "wave", "-o", f"{OUT}/c", match="invalid choice: 'wave'"),
    *[case("render", "--gesture", "stop", "-o", f"{OUT}/c", option, value, match=option)
      for option, value in [("--seed", "-1"), ("--width", "95"), ("--width", "97"),
                            ("--width", "4098"), ("--height", "63"), ("--height", "65"),
                            ("--height", "5000"), ("--fps", "4"), ("--fps", "241")]],
    *[case("render", "--gesture", "stop", "-o", f"{OUT}/c", option, value, match=match)
      for option, value, match in [("--motion-blur", "1.5", "--motion-blur must be a number"),
                                   ("--skin-tone", "-2", "--skin-tone must be a number"),
                                   ("--exposure-drift", "nan", "--exposure-drift must be"),
                                   ("--flicker", "0.3", "--flicker must be a number"),
                                   ("--flicker", "abc", "argument --flicker")]],
    case("render", "--gesture", "stop", "-o", f"{OUT}/c", "--scene", "medium",
         match="invalid choice: 'medium'"),
    case("render", "--gesture", "stop", "-o", f"{OUT}/c", "--posture", "asl10",
         match="--posture: posture must be one of"),
    case("render", "--sequence", "stop@fist,left@wave", "-o", f"{OUT}/c",
         match="--sequence: left@wave: posture must be one of"),
    case("demo", "--sequence", "stop,left@flat", "-o", f"{OUT}/d", "--backend", "model",
         match="--sequence: left@flat: posture must be one of"),
    case("demo", "--gesture", "stop", "-o", f"{OUT}/d", "--backend", "model", "--posture",
         "wave", match="--posture: posture must be one of"),
    case("posture-commands", f"{IN}/model.json", "--command", "asl2,flat",
         match="--command/--stop/--neutral/--power: postures: flat not a class of the "
               "posture model"),
    case("posture-commands", f"{IN}/model.json", "--release-frames", "-1",
         match="--release-frames: postures release_frames must be an integer in [0, 30]"),
    case("posture-commands", f"{IN}/model.json", "--command", "asl2", "--neutral", "asl2",
         match="--neutral: postures neutral asl2 must be neither a command nor the stop"),
    case("posture-commands", f"{IN}/model.json", "--power", "asl2=120", "--command", "asl2",
         match="--power: postures power 'asl2' must be an integer in [0, 100]"),
    case("render", "--gesture", "stop", "-o", f"{OUT}/c", "--hand-scale", "0.5",
         match="--hand-scale must be a number in [0.8, 1.2]"),
    case("demo", "--clip", f"{IN}/clip", "--backend", "model", "-o", f"{OUT}/d",
         "--scene", "hard", match="--scene and the difficulty options apply to a rendered clip"),
    case("render", "--gesture", "stop", "-o", f"{IN}/afile", match="not a stereogest clip"),
    case("render", "--gesture", "stop", "-o", f"{OUT}/no/such/dir", match="does not exist"),
    case("render", "--gesture", "stop", "-o", "/proc/stereogest-clip", "--width", "96",
         "--height", "64", match="/proc"),
    # ------------------------------------------------------------ clip
    case("clip", "--right", f"{IN}/adir", "-o", f"{OUT}/c", match="--left"),
    case("clip", "--left", f"{IN}/nope.avi", "--right", f"{IN}/adir", "-o", f"{OUT}/c",
         match="--left: '"),
    case("clip", "--left", f"{IN}/adir", "--right", f"{IN}/adir", "-o", f"{OUT}/c",
         match="--left: folder"),
    case("clip", "--left", f"{IN}/text.png", "--right", f"{IN}/text.png", "-o", f"{OUT}/c",
         match="--left"),
    case("clip", "--left", f"{IN}/afile", "--right", f"{IN}/afile", "-o", f"{OUT}/c",
         match="--left"),
    case("clip", "--left", f"{IN}/*.nothing", "--right", f"{IN}/afile", "-o", f"{OUT}/c",
         match="--left: no file matches"),
    *int_option_cases("clip", ["--left", "x", "--right", "y", "-o", f"{OUT}/c"],
                      ["--width", "--height", "--fps", "--frames"]),
    *[case("clip", "--left", f"{TSUKUBA}/left.png", "--right", f"{TSUKUBA}/right.png", "-o",
           f"{OUT}/c", option, value, match=option)
      for option, value in [("--width", "95"), ("--width", "97"), ("--height", "5000"),
                            ("--fps", "0"), ("--fps", "1001"), ("--frames", "0"),
                            ("--frames", "1801")]],
    case("clip", "--left", f"{TSUKUBA}/left.png", "--right", f"{TSUKUBA}/right.png", "-o",
         f"{OUT}/c", "--gesture", "wave", match="invalid choice"),
    # ------------------------------------------------------------ stereo
    case("stereo", match="required"),
    case("stereo", f"{TSUKUBA}/left.png", match="required"),
    case("stereo", f"{IN}/nope.png", f"{TSUKUBA}/right.png", "-o", f"{OUT}/d.png",
         match="nope.png"),
    case("stereo", f"{IN}/text.png", f"{TSUKUBA}/right.png", "-o", f"{OUT}/d.png",
         match="text.png"),
    case("stereo", f"{TSUKUBA}/left.png", f"{DATA}/middlebury/venus/right.png", "-o",
         f"{OUT}/d.png", match="one size"),
    case("stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o", f"{IN}/adir",
         match="adir"),
    case("stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o", f"{OUT}/no/d.png",
         match="no"),
    *int_option_cases("stereo", [f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o",
                                 f"{OUT}/d.png"],
                      ["--census-window", "--hamming-window", "--max-disparity",
                       "--lrcc-threshold", "--no-match-cost", "--threads"]),
    *[case("stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o", f"{OUT}/d.png",
           option, value, match=option)
      for option, value in [("--census-window", "2"), ("--census-window", "4"),
                            ("--census-window", "13"), ("--hamming-window", "0"),
                            ("--hamming-window", "2"), ("--hamming-window", "65"),
                            ("--max-disparity", "0"), ("--max-disparity", "257"),
                            ("--lrcc-threshold", "0"), ("--lrcc-threshold", "49"),
                            ("--no-match-cost", "-1"), ("--no-match-cost", "25"),
                            ("--threads", "0"), ("--threads", "65")]],
    case("stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o", f"{OUT}/d.png",
         "--backend", "gpu", match="invalid choice"),
    # ------------------------------------------------------------ eval-stereo
    case("eval-stereo", f"{IN}/nope.png", f"{TSUKUBA}/disp_left.png", "--gt-scale", "16",
         match="nope.png"),
    case("eval-stereo", f"{TSUKUBA}/disp_left.png", f"{IN}/text.png", "--gt-scale", "16",
         match="text.png"),
    case("eval-stereo", f"{IN}/rgb.png", f"{TSUKUBA}/disp_left.png", "--gt-scale", "16",
         match="rgb.png"),
    *[case("eval-stereo", f"{TSUKUBA}/disp_left.png", f"{TSUKUBA}/disp_left.png",
           "--gt-scale", "16", option, value, match=option)
      for option, value in [("--max-error", "-1"), ("--max-error", "nan"),
                            ("--max-error", "inf"), ("--max-error", "abc"),
                            ("--exclude-left", "-1"), ("--exclude-left", "999"),
                            ("--exclude-left", "abc")]],
    *[case("eval-stereo", f"{TSUKUBA}/disp_left.png", f"{TSUKUBA}/disp_left.png",
           "--gt-scale", value, match="--gt-scale")
      for value in ("0", "-1", "nan", "inf", "abc")],
    # ------------------------------------------------------------ pipeline
    case("pipeline", "-o", f"{OUT}/p", match="CLIP"),
    case("pipeline", f"{IN}/nope", "-o", f"{OUT}/p", match="not a clip directory"),
    case("pipeline", f"{IN}/adir", "-o", f"{OUT}/p", match="clip.json"),
    case("pipeline", f"{IN}/afile", "-o", f"{OUT}/p", match="not a clip directory"),
    *[case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", "--frames", value, match="--frames")
      for value in ("abc", "", ",", "-1", "999", "1;2")],
    *int_option_cases("pipeline", [f"{IN}/clip", "-o", f"{OUT}/p"],
                      ["--threads", "--spot-threshold", "--spot-hold"]),
    *[case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", option, value, match=option)
      for option, value in [("--threads", "0"), ("--threads", "65"),
                            ("--spot-threshold", "-1"), ("--spot-threshold", "1024"),
                            ("--spot-hold", "0"), ("--spot-hold", "256")]],
    case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", "--model", f"{IN}/nope.json",
         match="nope.json"),
    # a model the board application refuses is refused before any work
    *[case(*args, "--model", f"{IN}/nine_symbols.json",
           match="nine_symbols.json: models must use the 8 orientation symbols")
      for args in (("pipeline", f"{IN}/clip", "-o", f"{OUT}/p"),
                   ("demo", "--clip", f"{IN}/clip", "--backend", "model", "-o", f"{OUT}/d"),
                   ("live", "--clip", f"{IN}/clip", "--port", "0"))],
    case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", "--model", f"{IN}/text.json",
         match="text.json"),
    case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", "--model", f"{IN}/empty.json",
         match="empty.json"),
    case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", "--model", f"{IN}/short_names.json",
         match="class"),
    case("pipeline", f"{IN}/clip", "-o", f"{OUT}/p", "--backend", "fpga",
         match="invalid choice"),
    case("pipeline", f"{IN}/clip", "-o", f"{IN}/afile", match="afile"),
    case("pipeline", f"{IN}/clip", "-o", "/proc/stereogest-out", match="/proc"),
    # ------------------------------------------------------------ demo
    *int_option_cases("demo", ["-o", f"{OUT}/d", "--backend", "model"],
                      ["--seed", "--pre-rest", "--width", "--height", "--threads"]),
    *[case("demo", "-o", f"{OUT}/d", "--backend", "model", option, value, match=option)
      for option, value in [("--seed", "-1"), ("--pre-rest", "-2"), ("--pre-rest", "10001"),
                            ("--width", "97"), ("--width", "94"), ("--width", "5000"),
                            ("--height", "63"), ("--height", "241"), ("--threads", "0"),
                            ("--threads", "65")]],
    case("demo", "-o", f"{OUT}/d", "--gesture", "wave", match="invalid choice"),
    case("demo", "-o", f"{OUT}/d", "--stage", "edges", match="invalid choice"),
    case("demo", "-o", f"{OUT}/d", "--backend", "fpga", match="invalid choice"),
    case("demo", "-o", f"{OUT}/d", "--model", f"{IN}/nope.json", match="nope.json"),
    case("demo", "-o", f"{OUT}/d", "--model", f"{IN}/text.json", match="text.json"),
    case("demo", "-o", f"{OUT}/d", "--clip", f"{IN}/nope", match="not a clip directory"),
    *int_option_cases("demo", ["-o", f"{OUT}/d", "--backend", "model"], ["--vga-scale"]),
    *[case("demo", "-o", f"{OUT}/d", "--backend", backend, "--vga-scale", value,
           match=f"--vga-scale must be in [1, 2], got {value}")
      for backend, value in [("model", "0"), ("verilator", "3")]],
    case("demo", "-o", f"{IN}/afile", "--backend", "model", "--width", "96", "--height", "64",
         match="afile"),
    # ------------------------------------------------------------ live
    case("live", match="--clip CLIP or both --left and --right"),
    case("live", "--right", "1", match="--clip CLIP or both"),
    *int_option_cases("live", ["--clip", f"{IN}/clip"],
                      ["--width", "--height", "--port", "--fps", "--frames", "--threads"]),
    *[case("live", "--clip", f"{IN}/clip", option, value, match=option)
      for option, value in [("--port", "-1"), ("--port", "65536"), ("--fps", "0"),
                            ("--frames", "0"), ("--frames", "1801"), ("--threads", "0"),
                            ("--threads", "65")]],
    case("live", "--clip", f"{IN}/nope", match="not a clip directory"),
    case("live", "--left", f"{IN}/nope.avi", "--right", f"{IN}/nope.avi", match="--left"),
    case("live", "--left", f"{IN}/adir", "--right", f"{IN}/adir", "--width", "97",
         match="--width"),
    case("live", "--clip", f"{IN}/clip", "--model", f"{IN}/text.json", match="text.json"),
    case("live", "--clip", f"{IN}/clip", "--width", "320", match="--width applies to --left"),
    case("live", "--left", f"{IN}/adir", "--right", f"{IN}/adir", "--loop",
         match="--loop replays a clip: only with --clip"),
    case("live", "--clip", f"{IN}/clip", "--height", "240", match="--height applies to"),
    # ------------------------------------------------------------ gestures
    *int_option_cases("gestures", ["-o", f"{OUT}/g.npz"],
                      ["--per-class", "--people", "--seed", "--width", "--height", "--fps"]),
    *[case("gestures", "-o", f"{OUT}/g.npz", option, value, match=option)
      for option, value in [("--per-class", "0"), ("--per-class", "100001"),
                            ("--people", "0"), ("--people", "1001"), ("--seed", "-1"),
                            ("--width", "95"), ("--height", "63"), ("--fps", "0")]],
    case("gestures", "-o", f"{OUT}/no/g.npz", match="--output"),
    case("gestures", "-o", f"{IN}/adir", match="--output"),
    case("gestures", "-o", "/proc/stereogest.npz", "--per-class", "1", match="/proc"),
    *[case("gestures", "-o", f"{OUT}/s.npz", "--join", str(DOLLAR), option, value, match=option)
      for option, value in [("--pause", "5-2"), ("--pause", "x"), ("--pause", "0-10001"),
                            ("--per-stream", "0")]],
    case("gestures", "-o", f"{OUT}/s.npz", "--join", f"{IN}/nope.npz", match="nope.npz"),
    # ------------------------------------------------------------ train
    case("train", f"{IN}/nope.npz", "-o", f"{OUT}/m.json", match="nope.npz"),
    case("train", f"{IN}/renamed.npz", "-o", f"{OUT}/m.json", match="renamed.npz"),
    case("train", f"{IN}/truncated.npz", "-o", f"{OUT}/m.json", match="truncated.npz"),
    case("train", f"{IN}/text.json", "-o", f"{OUT}/m.json", match="text.json"),
    case("train", f"{IN}/one_class.npz", "-o", f"{OUT}/m.json", match="one class"),
    case("train", f"{IN}/empty.npz", "-o", f"{OUT}/m.json", match="no trajectories"),
    case("train", f"{IN}/blank_labels.npz", "-o", f"{OUT}/m.json", match="label must not be"),
    # ------------------------------------------------------------ train-posture
    *int_option_cases("train-posture", [f"{IN}/postures.npz", "-o", f"{OUT}/p.json"],
                      ["--copies", "--seed"]),
    case("train-posture", f"{IN}/postures.npz", match="-o/--output"),
    case("train-posture", f"{IN}/postures.npz", "-o", f"{OUT}/p.json", "--copies", "33",
         match="--copies must be an integer in 0..32, got 33"),
    case("train-posture", f"{IN}/postures.npz", "-o", f"{IN}/adir", match="--output"),
    case("train-posture", f"{IN}/postures.npz", "-o", f"{OUT}/p.json", "--seed", "-1",
         match="--seed"),
    case("train-posture", f"{IN}/postures.npz", "-o", f"{OUT}/p.json", "--groups", "writer",
         match="argument --groups"),
    case("train-posture", f"{IN}/nope.npz", "-o", f"{OUT}/p.json", match="nope.npz: no such"),
    case("train-posture", f"{IN}/renamed.npz", "-o", f"{OUT}/p.json", match="renamed.npz"),
    case("train-posture", f"{IN}/truncated.npz", "-o", f"{OUT}/p.json", match="truncated.npz"),
    case("train-posture", f"{IN}/data2.npz", "-o", f"{OUT}/p.json",
         match="data2.npz: has no 'image' array"),
    case("train-posture", f"{IN}/postures_grey.npz", "-o", f"{OUT}/p.json",
         match="postures_grey.npz: image must be N x H x W x 3 uint8 RGB"),
    case("train-posture", f"{IN}/postures_label_12.npz", "-o", f"{OUT}/p.json",
         match="postures_label_12.npz: label must be in 0..9"),
    case("train-posture", f"{IN}/postures_two_names.npz", "-o", f"{OUT}/p.json",
         match="postures_two_names.npz: label must be in 0..1"),
    case("train-posture", f"{IN}/postures_no_skin.npz", "-o", f"{OUT}/p.json",
         match="postures_no_skin.npz: image 5 has no skin-coloured pixel"),
    case("train-posture", f"{IN}/postures_nan_features.npz", "-o", f"{OUT}/p.json",
         match="postures_nan_features.npz: features must be 20 x 176 finite floats"),
    case("classify-posture", f"{IN}/posture.json", f"{IN}/postures_short_features.npz",
         match="postures_short_features.npz: features must be 20 x 176"),
    case("train-posture", f"{IN}/postures_no_subject.npz", "-o", f"{OUT}/p.json", "--groups",
         "subject", match="--groups subject needs a subject array"),
    # ------------------------------------------------------------ postures
    case("postures", "-o", f"{OUT}/r.npz", "--people", "0", match="--people must be"),
    case("postures", "-o", f"{OUT}/r.npz", "--seed", "-1", match="--seed must be"),
    case("postures", "-o", f"{OUT}/r.npz", "--postures", "fist,wave",
         match="--postures: hand must be one of"),
    case("postures", "-o", f"{OUT}/r.npz", "--postures", "fist,fist",
         match="--postures: each posture once"),
    case("postures", "-o", f"{OUT}/r.npz", "--width", "97", match="width must be even"),
    case("postures", "-o", f"{IN}/adir", match="--output"),
    case("postures", match="-o/--output"),
    # ------------------------------------------------------------ classify-posture
    case("classify-posture", f"{IN}/nope.json", f"{IN}/postures.npz", match="nope.json"),
    case("classify-posture", f"{IN}/text.json", f"{IN}/postures.npz",
         match="text.json: not valid JSON"),
    case("classify-posture", str(MODEL), f"{IN}/postures.npz",
         match="gestures7.json: format must be 'stereogest-posture'"),
    case("classify-posture", f"{IN}/posture_v9.json", f"{IN}/postures.npz",
         match="posture_v9.json: version must be 1, got 9"),
    case("classify-posture", f"{IN}/posture.json", f"{IN}/nope.npz", match="nope.npz"),
    case("classify-posture", f"{IN}/posture.json", f"{IN}/postures_64.npz",
         match="pictures are 64 x 64, the model was trained on 100 x 100"),
    case("classify-posture", f"{IN}/posture.json", f"{IN}/postures_label_12.npz",
         match="label must be in 0..9"),
    case("classify-posture", f"{IN}/posture.json", f"{IN}/postures_unknown_names.npz",
         match="class_names fist, open are not postures of"),
    case("classify-posture", f"{IN}/posture.json", f"{IN}/postures_no_skin.npz",
         match="image 5 has no skin-coloured pixel"),
    case("classify", str(MODEL), f"{IN}/empty.npz", match="no trajectories"),
    case("classify", str(MODEL), f"{IN}/blank_labels.npz", match="label must not be empty"),
    case("train", f"{IN}/data.npz", "-o", f"{OUT}/no/m.json", match="no"),
    case("train", f"{IN}/data.npz", "-o", f"{IN}/adir", match="adir"),
    *int_option_cases("train", [f"{IN}/data.npz", "-o", f"{OUT}/m.json"],
                      ["--states", "--components", "--calibration-folds", "--folds",
                       "--resample", "--max-iter", "--expected-length", "--jobs", "--seed"]),
    *[case("train", f"{IN}/data.npz", "-o", f"{OUT}/m.json", option, value, match=option)
      for option, value in [("--states", "0"), ("--components", "0"), ("--folds", "1"),
                            ("--resample", "0"), ("--max-iter", "0"), ("--tol", "-1"),
                            ("--tol", "nan"), ("--reject-quantile", "-0.5"),
                            ("--reject-quantile", "2"), ("--reject-margin", "-1"),
                            ("--reject-margin", "some"),
                            ("--reject-margin", "inf"), ("--reject-budget", "0.5"),
                            ("--reject-budget", "0.01"),
                            ("--emission-floor", "-1"), ("--seed", "-1"), ("--jobs", "0"),
                            ("--cv-states", "x"), ("--cv-states", "5-2"),
                            ("--expected-length", "0")]],
    case("train", f"{IN}/data.npz", "-o", f"{OUT}/m.json", "--emission", "poisson",
         match="invalid choice"),
    # ------------------------------------------------------------ classify
    case("classify", f"{IN}/nope.json", f"{IN}/data.npz", match="nope.json"),
    case("classify", f"{IN}/text.json", f"{IN}/data.npz", match="text.json"),
    case("classify", f"{IN}/empty.json", f"{IN}/data.npz", match="empty.json"),
    case("classify", f"{IN}/short_names.json", f"{IN}/data.npz", match="class"),
    case("classify", str(MODEL), f"{IN}/nope.npz", match="nope.npz"),
    case("classify", str(MODEL), f"{IN}/renamed.npz", match="renamed.npz"),
    case("classify", str(MODEL), f"{IN}/truncated.npz", match="truncated.npz"),
    case("classify", str(MODEL), f"{IN}/data.npz", "--resample", "0", match="--resample"),
    case("classify", str(MODEL), f"{IN}/data.npz", "--resample", "abc", match="--resample"),
    case("classify", str(MODEL), f"{IN}/data.npz", "--plot", f"{OUT}/c.txt", match="--plot"),
    case("classify", f"{IN}/nine_symbols.json", f"{IN}/data.npz", "--plot", f"{OUT}/c.png",
         match="nine_symbols.json: models must use the 8 orientation symbols"),
    case("classify", str(MODEL), f"{IN}/foreign_labels.npz", "--plot", f"{OUT}/c.png",
         match="foreign_labels.npz: none of its labels (circle, wave) is a class of"),
    # ------------------------------------------------------------ resources, timing, generate
    *int_option_cases("resources", [], ["--width", "--height", "--vga-scale"]),
    *[case("resources", "--vga-scale", value, match=f"--vga-scale must be in [1, 2], got {value}")
      for value in ("0", "3", "-1")],
    case("resources", "--hand-tracking", "--width", "8", match="--width must be in [48, 4096]"),
    *int_option_cases("timing", [], ["--width", "--height", "--census-window",
                                     "--hamming-window", "--max-disparity", "--opening-size",
                                     "--seed"]),
    case("timing", "--block", "cpu", match="--block"),
    case("timing", "--seed", "0", match="--seed"),
    case("timing", "--router", "router9", match="invalid choice"),
    case("timing", "--timeout", "-1", match="--timeout"),
    case("timing", "--hand-tracking", "--width", "8", match="--width must be in [48, 4096]"),
    *int_option_cases("generate", ["-o", f"{OUT}/b"], ["--width", "--height"]),
    case("generate", "-o", f"{OUT}/b", "--width", "641", match="--width"),
    case("generate", "-o", f"{OUT}/b", "--height", "0", match="--height"),
    case("generate", "-o", f"{OUT}/b", "--hand-tracking", "--width", "8",
         match="--width must be in [48, 4096]"),
    *int_option_cases("generate", ["-o", f"{OUT}/b"], ["--vga-scale"]),
    case("generate", "-o", f"{OUT}/b", "--vga-scale", "4",
         match="--vga-scale must be in [1, 2], got 4"),
    *[case("generate", "-o", f"{OUT}/b", "--scl-khz", value,
           match=f"--scl-khz must be in (0, 400] kHz, got {shown}")
      for value, shown in (("0", "0"), ("401", "401"), ("-5", "-5"), ("nan", "nan"))],
    case("generate", "-o", f"{OUT}/b", "--scl-khz", "fast", match="--scl-khz"),
    case("generate", "-o", f"{IN}/afile", match="afile"),
    case("generate", match="-o/--output"),
    # ------------------------------------------------------------ chessboards, calibrate
    *int_option_cases("chessboards", ["-o", f"{OUT}/cb"], ["--count", "--seed"]),
    case("chessboards", match="-o/--output"),
    *[case("chessboards", "-o", f"{OUT}/cb", option, value, match=option)
      for option, value in [("--count", "0"), ("--count", "101"), ("--seed", "-1")]],
    case("calibrate", match="required"),
    case("calibrate", f"{IN}/adir", match="-o/--output"),
    case("calibrate", f"{IN}/nope", "-o", f"{OUT}/c.json", match=f"PAIRS: {IN}/nope is not a folder"),
    case("calibrate", f"{IN}/adir", "-o", f"{OUT}/c.json", match=f"PAIRS: {IN}/adir holds no left_*.png"),
    case("calibrate", f"{IN}/unpaired", "-o", f"{OUT}/c.json", match="PAIRS: 1 pictures have no partner (e.g. left_a.png)"),
    case("calibrate", f"{IN}/clip", "-o", f"{OUT}/c.json",
         match="chessboard was found in both images of 0 of 3 pairs"),
    *[case("calibrate", f"{IN}/adir", "-o", f"{OUT}/c.json", option, value, match=match)
      for option, value, match in [("--pattern", "9", "--pattern must be COLSxROWS"),
                                   ("--pattern", "2x6", "--pattern columns"),
                                   ("--pattern", "9x99", "--pattern rows"),
                                   ("--square", "0", "--square"), ("--square", "nan", "--square"),
                                   ("--square", "abc", "argument --square")]],
    case("calibrate", f"{IN}/adir", "-o", f"{OUT}/no/dir/c.json", match="does not exist"),
    # ------------------------------------------------------------ --calibration
    *[case(*command, "--calibration", calib, match=f"--calibration: {match}")
      for command in (["stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o",
                       f"{OUT}/d.png"],
                      ["pipeline", f"{IN}/clip", "-o", f"{OUT}/p"],
                      ["generate", "-o", f"{OUT}/b", "--width", "64", "--height", "16"])
      for calib, match in [(f"{IN}/nope.json", f"{IN}/nope.json does not exist"),
                           (f"{IN}/adir", f"{IN}/adir is a directory"),
                           (f"{IN}/text.json", f"{IN}/text.json: not a calibration file"),
                           (f"{IN}/empty.json", f"{IN}/empty.json: not a calibration file"),
                           (f"{IN}/calib_bad_r.json",
                            f"{IN}/calib_bad_r.json: R must be a rotation matrix"),
                           (f"{IN}/calib_no_t.json", f"{IN}/calib_no_t.json: T is missing"),
                           (f"{IN}/calib640.json", "the calibration is for 640x480 frames")]],
    case("stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png", "-o", f"{OUT}/d.png",
         "--interpolation", "cubic", match="invalid choice: 'cubic'"),
    *[case(*command, "--calibration", f"{IN}/calib640.json",
           match="--calibration: the calibration is for 640x480 frames")
      for command in (["demo", "--backend", "model", "--width", "320", "--height", "240",
                       "-o", f"{OUT}/d"],
                      ["resources", "--width", "320", "--height", "240"],
                      ["timing", "--block", "rectify", "--width", "320", "--height", "240"])],
    *[case(*command, "--calibration", f"{IN}/text.json",
           match=f"--calibration: {IN}/text.json: not a calibration file")
      for command in (["demo", "--backend", "model", "-o", f"{OUT}/d"], ["resources"],
                      ["timing", "--block", "rectify"])],
]


def _output_cases():
    """Every command's every output on a read-only file system, in a folder
    without permission, under /proc, and as an existing file or directory where
    the other is expected: refused before any work, naming the option."""
    stereo = ["stereo", f"{TSUKUBA}/left.png", f"{TSUKUBA}/right.png"]
    clip = ["clip", "--left", f"{TSUKUBA}/left.png", "--right", f"{TSUKUBA}/right.png"]
    small = ["--width", "96", "--height", "64"]
    train = ["train", f"{IN}/data.npz"]
    report = [*train, "--emission", "discrete", "--cv-states", "2-3", "-o", f"{OUT}/m.json"]
    outputs = [  # (argv before the path, option, argv after the path)
        ([*stereo, "-o"], "--output", []),
        (["pipeline", f"{IN}/clip", "-o"], "--output", []),
        (["render", "--gesture", "stop", *small, "-o"], "--output", []),
        ([*clip, *small, "-o"], "--output", []),
        (["demo", "--backend", "model", *small, "-o"], "--output", []),
        (["gestures", "--per-class", "1", "-o"], "--output", []),
        ([*train, "-o"], "--output", []),
        ([*report, "--report"], "--report", []),
        (["classify", str(MODEL), f"{IN}/data.npz", "--plot"], "--plot", [".png"]),
        (["generate", "--width", "64", "--height", "16", "-o"], "--output", []),
        (["timing", "--block", "median3x3", "-o"], "--output", []),
        (["timing", "--block", "median3x3", "--keep"], "--keep", []),
        (["calibrate", f"{IN}/adir", "-o"], "--output", []),
        (["chessboards", "--count", "1", "-o"], "--output", []),
        (["chessboards", "--count", "1", "-o", f"{OUT}/cb", "--truth"], "--truth", []),
    ]
    for before, option, suffix in outputs:
        for where, why in ((f"{RO}/x", "Read-only file system"), (f"{DENIED}/x", "Permission"),
                           ("/proc/stereogest-x", "/proc")):
            yield case(*before, where + "".join(suffix), match=f"{option}: cannot write")
    yield case(*report, "--report", f"{IN}/adir", match="--report: ")
    yield case(*clip, "-o", f"{IN}/afile", match="--output: ")
    yield case("timing", "--block", "median3x3", "--json", f"{IN}/adir", match="--json: ")             # the older spelling
    yield case("timing", "--block", "median3x3", "-o", f"{OUT}/t.json", "--json", f"{OUT}/u.json",
               match="older spelling")
    yield case("timing", "--block", "median3x3", "--keep", f"{IN}/afile", match="--keep: ")
    yield case("chessboards", "--count", "1", "-o", f"{OUT}/cb", "--truth", f"{OUT}/cb",
               match="is the --output folder; name a file")
    yield case("chessboards", "--count", "1", "-o", f"{OUT}/cb", "--truth", f"{IN}/adir",
               match="--truth: ")
    yield case("generate", "-o", f"{IN}", match="--output")      # not empty, not a bundle


CASES += list(_output_cases())


@pytest.fixture(scope="module")
def unwritable(tmp_path_factory):
    """The folders RO and DENIED stand for, or None where this machine has none
    (mounting needs root; /sys may be an ordinary folder in a container)."""
    import subprocess
    import tempfile
    ro = tmp_path_factory.mktemp("ro")
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(ro)],
                             capture_output=True).returncode == 0 if os.geteuid() == 0 else False
    try:
        tempfile.mkstemp(dir="/sys")
        denied = None
    except OSError:
        denied = "/sys"
    yield {"ro": str(ro) if mounted else None, "denied": denied}
    if mounted:
        subprocess.run(["umount", str(ro)], check=False)


def _format(argv, inputs, out, unwritable=None):
    for token, name in ((RO, "ro"), (DENIED, "denied")):
        if any(token in a for a in argv):
            if unwritable[name] is None:
                pytest.skip(f"no {name} folder on this machine (needs root and sysfs)")
            argv = [a.replace(token, unwritable[name]) for a in argv]
    return [a.replace(IN, str(inputs)).replace(OUT, str(out)) for a in argv]


def _tree(path: Path) -> list:
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


@pytest.mark.parametrize("argv, match, code", CASES)
def test_stereogest_bad_input(inputs, unwritable, tmp_path, capsys, monkeypatch, argv, match,
                              code):
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.chdir(tmp_path)
    argv = _format(argv, inputs, out, unwritable)
    match = _format([match], inputs, out)[0]
    before = _tree(inputs)
    try:
        status = cli.main(argv)
    except SystemExit as exc:          # argparse's own refusals
        status = exc.code
    captured = capsys.readouterr()
    err = captured.err
    assert status == code, (status, err)
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert err.startswith("stereogest"), err
    assert match in err, (match, err)
    assert _tree(out) == [], "an output was left behind"
    assert _tree(inputs) == before, "an input folder changed"
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


BOARD_CASES = [
    *[(["--model", "{model}", "--bus", "sim", "--robot", "none", option, value], option)
      for option, value in itertools.chain(
          [("--poll-ms", v) for v in ("0", "-5", "abc", "1e9")],
          [("--min-symbols", v) for v in ("0", "-1", "abc")],
          [("--max-points", v) for v in ("0", "-1", "abc")],
          [("--gesture-timeout", v) for v in ("0", "-1", "abc", "nan")],
          [("--heartbeat", v) for v in ("-1", "abc", "nan")],
          [("--bridge-offset", v) for v in ("0x3", "zz", "-4")],
          [("--uart-offset", v) for v in ("0x8", "zz")],
          [("--log-level", v) for v in ("loud", "")],
      )],
    (["--model", "{model}", "--bus", "sim", "--robot", "none", "--sim-trajectory",
      "{tmp}/none.csv"], "none.csv: cannot read trajectory"),
    (["--model", "{model}", "--bus", "sim", "--robot", "none", "--sim-trajectory",
      "{model}"], "gestures7.json: header must name frame,x,y,flag"),
    (["--model", "{tmp}/none.json", "--bus", "sim", "--robot", "none"], "none.json"),
    (["--model", "{text}", "--bus", "sim", "--robot", "none"], "text.json"),
    (["--model", "{short}", "--bus", "sim", "--robot", "none"], "class"),
    (["--model", "{nine}", "--bus", "sim", "--robot", "none"], "8 orientation symbols"),
    (["--model", "{model}", "--bus", "pci", "--robot", "none"], "--bus"),
    (["--model", "{model}", "--bus", "sim", "--robot", "wifi"], "--robot"),
    (["--model", "{model}", "--bus", "sim"], "--robot"),
    (["--bus", "sim", "--robot", "none"], "--model"),
    (["--model", "{model}", "--bus", "sim", "--robot", "none", "--posture-model", "{text}"],
     "text.json"),
    (["--model", "{continuous}", "--bus", "sim", "--robot", "none", "--spotting",
      "continuous", "--posture-model", "{text}"], "text.json"),
    (["--model", "{continuous}", "--bus", "sim", "--robot", "none", "--spotting",
      "continuous", "--posture-model", "{model}"], "gestures7.json"),
    (["--model", "{model}", "--bus", "sim", "--robot", "none", "--user", "no-such-user"],
     "argument --user: no user 'no-such-user'"),
    (["--check", "--bus", "sim", "--user", "root"], "argument --user: not with --check"),
]


@pytest.mark.parametrize("argv, match", BOARD_CASES, ids=lambda v: " ".join(v)[:60]
                         if isinstance(v, list) else v)
def test_board_application_bad_input(inputs, tmp_path, capsys, argv, match):
    from sw_hps.__main__ import main
    names = {"model": str(MODEL), "tmp": str(tmp_path), "text": str(inputs / "text.json"),
             "continuous": str(MODEL.parent / "continuous7.json"),
             "short": str(inputs / "short_names.json"), "nine": str(inputs / "nine_symbols.json")}
    status = main([a.format(**names) for a in argv])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and err.startswith("python -m sw_hps: error:"), err
    assert match.format(**names) in err and "Traceback" not in err


def test_the_corpus_is_large():
    assert len(CASES) + len(BOARD_CASES) >= 300


@pytest.mark.parametrize("argv, buffered", [
    (["classify", str(MODEL), "{in}/data.npz"], False),
    (["classify", str(MODEL), "{in}/data.npz"], True),
    (["eval-stereo", f"{TSUKUBA}/disp_left.png", f"{TSUKUBA}/disp_left.png", "--gt-scale",
      "16"], True),
    (["eval-stereo", "--help"], True),
    (["--version"], True),
], ids=lambda v: " ".join(v)[:40] if isinstance(v, list) else ("buffered" if v else "unbuffered"))
def test_a_closed_pipe_is_no_error(inputs, argv, buffered):
    """`stereogest ... | head -c 100`: the reader leaves before the report is
    written; the command ends quietly (exit 1, nothing on stderr), whether the
    write fails at once (unbuffered) or at the flush (a pipe's usual buffering)."""
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if not buffered:
        env["PYTHONUNBUFFERED"] = "1"
    proc = subprocess.Popen([sys.executable, "-m", "stereogest",
                             *(a.replace("{in}", str(inputs)) for a in argv)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    proc.stdout.close()                      # the reader is gone before anything is written
    _, err = proc.communicate(timeout=120)
    assert b"Traceback" not in err and b"BrokenPipeError" not in err, err.decode()
    assert proc.returncode == 1 and err == b"", err.decode()


@pytest.mark.parametrize("model, match", [("nine_symbols.json", "8 orientation symbols"),
                                          ("short_names.json", "class"),
                                          ("text.json", "text.json")])
def test_bundle_refuses_what_the_application_refuses(inputs, tmp_path, capsys, model, match):
    """`python -m sw_hps.bundle` ships only a model the board application runs
    (exit 2, one line, no tarball), as `python -m sw_hps` would refuse it."""
    from sw_hps.bundle import main
    out = tmp_path / "bundle.tar.gz"
    assert main(["--model", str(inputs / model), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sw_hps.bundle: error:") and match in err
    assert list(tmp_path.iterdir()) == []
