"""sw_hps/posture_commands.py: the command posture gates the gestures, the
stop posture stops at once and latches, the command posture's power goes in
the telegram; in the streaming spotter, the board's streaming loop and the
thesis loop; the board refuses a model file whose postures its posture model
does not know."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from recognition.continuous import train_continuous
from recognition.corpus import synthetic_corpus
from recognition.streams import subject_streams
from sw_hps.posture_commands import PostureCommands, check_posture_classes
from sw_hps.streaming import StreamSpotter
from sw_hps.telegram import telegram

OPTIONS = {"command": ["asl2", "asl3"], "share": 0.5, "stop": "fist", "stop_frames": 3,
           "power": {"asl2": 40, "asl3": 70}}


def test_the_stop_fires_once_after_its_frames_and_latches_until_another_posture():
    c = PostureCommands(OPTIONS)
    fired = [c.take(f, p) for f, p in enumerate(
        ["asl2", "fist", "fist", None, "fist", "fist", "fist", "fist", None, "asl5", "fist"])]
    # a frame without a posture breaks the run; the third in a row fires
    assert [f for f, x in enumerate(fired) if x] == [6] and c.stops == 1
    # 'asl5' at frame 9 released it; the fist after it starts a new run
    assert not c.latched and c.stop_started == 10
    c2 = PostureCommands(OPTIONS)
    for f, p in enumerate(["fist"] * 3 + [None] * 2):
        c2.take(f, p)
    assert c2.latched                          # ... a frame without a posture does not
    assert not c2.judge(0, 4).commands
    c2.take(5, "asl5")
    assert not c2.latched and c2.stop_started is None


def test_a_gesture_commands_with_enough_of_its_frames_in_a_command_posture():
    c = PostureCommands(OPTIONS)
    v = c.judge_names(["asl2"] * 4 + ["asl3"] * 3 + ["asl5"] * 3)
    assert v.commands and v.posture == "asl2" and v.share == 0.7 and v.power == 40
    v = c.judge_names(["asl3"] * 3 + [None] * 4 + ["asl5"])
    assert not v.commands and v.share == 0.375 and v.posture == "asl3"
    # a tie of power levels goes to the lower power
    assert c.judge_names(["asl2", "asl3"]).power == 40
    assert not c.judge_names([]).commands and not c.judge_names(["asl5"] * 5).commands
    # without command postures every gesture commands (but not while stopped)
    free = PostureCommands({"stop": "fist", "stop_frames": 1})
    assert free.judge_names(["asl5"]).commands
    free.take(0, "fist")
    assert not free.judge_names(["asl5"]).commands
    # the frames judged are the gesture's own
    for f, p in enumerate(["asl5"] * 10 + ["asl2"] * 10):
        c.take(f, p)
    assert c.judge(10, 19).commands and not c.judge(0, 9).commands


def test_frames_whose_posture_was_not_read_count_neither_way():
    """The application may pop several records between two reads of the
    posture slave: those frames have no posture to judge, unlike a frame
    read as no hand (None), and they neither extend nor break a stop's run."""
    c = PostureCommands(OPTIONS)
    for f in (0, 1, 2, 9):
        c.take(f, "asl2")
    v = c.judge(0, 9)
    assert v.commands and v.share == 1.0
    for f in range(3, 9):
        c.take(f, None)                           # read: no hand
    assert not c.judge(0, 9).commands and c.judge(0, 9).share == 0.4
    assert not c.judge(20, 30).commands and c.judge(20, 30).share == 0.0   # none read
    spotter_options = dict(OPTIONS, stop_frames=2)
    c = PostureCommands(spotter_options)
    assert not c.take(40, "fist") and c.take(45, "fist") and c.stop_started == 40


def test_unknown_postures_are_refused_naming_them():
    check_posture_classes(OPTIONS, ["asl2", "asl3", "asl5", "fist"])
    with pytest.raises(ValueError, match=r"model.json: postures: asl3, fist not a class"):
        check_posture_classes(OPTIONS, ["asl2", "asl5"], where="model.json: postures")


def test_a_power_goes_in_the_telegram_as_three_digits():
    assert telegram("right", power=75).hex(" ") == "09 00 80 09 00 05 33 30 37 35 00"
    assert telegram("stop", power=0)[-5:] == b"7000\x00"
    for bad in (101, -1, 7.5, True):
        with pytest.raises(ValueError, match=r"power must be an integer in \[0, 100\]"):
            telegram("right", power=bad)


# ---- the streaming spotter --------------------------------------------------------
STEP = 12


@pytest.fixture(scope="module")
def models():
    corpus = synthetic_corpus(per_class=8, people=3, seed=5)
    train = corpus.subset(np.flatnonzero(corpus.subject != 2))
    plain, _ = train_continuous(train, states=6, step=STEP, spotting={"threshold_bias": -0.5})
    held = corpus.subset(np.flatnonzero(corpus.subject == 2))
    stream = subject_streams(held, per_stream=8, seed=3)[0]
    from sim.model.pipeline import PipelineParams, track
    pts = np.floor(np.maximum(stream.points, 0)).astype(np.int64)
    fixed = track(pts, np.ones(len(pts), np.int64), PipelineParams()).smoothed
    return plain, dataclasses.replace(plain, postures=dict(OPTIONS)), fixed


def _spot(models, fixed, postures):
    spotter = StreamSpotter(models)
    out = []
    for (x, y), p in zip(fixed, postures):
        out += spotter.take(int(x), int(y), True, p)
    return out + spotter.flush(), spotter


def test_in_the_command_posture_the_spotter_names_what_it_named_without(models):
    plain, gated, fixed = models
    before, _ = _spot(plain, fixed, [None] * len(fixed))
    assert len(before) >= 4
    after, spotter = _spot(gated, fixed, ["asl3"] * len(fixed))
    assert [(c.name, c.first, c.last) for c in after] == \
        [(c.name, c.first, c.last) for c in before]
    assert {(c.posture, c.power, c.posture_share) for c in after} == {("asl3", 70, 1.0)}
    assert spotter.refused == 0
    # out of the command posture nothing commands: each is refused and counted
    refused, spotter = _spot(gated, fixed, ["asl5"] * len(fixed))
    assert refused == [] and spotter.refused == len(before)


def test_the_clutch_releases_after_its_records_out_of_a_command_posture():
    c = PostureCommands(dict(OPTIONS, release_frames=3))
    engaged = []
    for f, p in enumerate(["asl2", "asl5", None, "asl3", "asl5", "asl5", "asl5", "asl5",
                           "asl2", "fist", "fist", "fist"]):
        c.take(f, p)
        engaged.append(c.engaged)
    # two records out (asl5, no posture) do not release; the third in a row
    # does, a command posture engages again, and a stop posture releases too
    assert engaged == [True] * 6 + [False, False, True, True, True, False]
    off = PostureCommands(OPTIONS)
    for f in range(10):
        off.take(f, "asl5")
    assert off.engaged                     # release_frames 0: no clutch
    # a neutral posture neither extends nor breaks a run out of the command postures
    c = PostureCommands(dict(OPTIONS, release_frames=3, neutral=["asl0"]))
    engaged = []
    for f, p in enumerate(["asl2", "asl0", "asl0", "asl0", "asl0", "asl5", "asl0", "asl5",
                           "asl0", "asl5"]):
        c.take(f, p)
        engaged.append(c.engaged)
    assert engaged == [True] * 9 + [False]


def test_no_gesture_spans_motion_made_out_of_the_command_posture(models):
    """A gesture's first half made in another posture: with the share alone the
    whole is named when most of it is in the command posture; with the clutch
    only motion after the posture changed can make a gesture."""
    plain, gated, fixed = models
    before, _ = _spot(plain, fixed, [None] * len(fixed))
    clutch = dataclasses.replace(gated, postures=dict(OPTIONS, share=0.3, release_frames=3))
    for g in before[:4]:
        postures = ["asl2"] * len(fixed)
        cut = g.first + (g.last - g.first) // 3
        postures[g.first - 5:cut] = ["asl5"] * (cut - g.first + 5)
        shared, _ = _spot(dataclasses.replace(gated, postures=dict(OPTIONS, share=0.3)),
                          fixed, postures)
        assert (g.name, g.first) in [(c.name, c.first) for c in shared]
        held, _ = _spot(clutch, fixed, postures)
        assert not [c for c in held if c.first < cut <= c.last]
        assert all(c.first >= cut for c in held if g.first <= c.last and c.first <= g.last)
    # in the command posture throughout, a record or two named otherwise
    # change nothing
    postures = ["asl2"] * len(fixed)
    postures[::9] = ["asl5"] * len(postures[::9])
    postures[1::9] = [None] * len(postures[1::9])
    held, _ = _spot(clutch, fixed, postures)
    assert [(c.name, c.first, c.last) for c in held] == \
        [(c.name, c.first, c.last) for c in before]


def test_the_stop_posture_stops_at_once_and_nothing_follows_until_it_is_left(models):
    plain, gated, fixed = models
    before, _ = _spot(plain, fixed, [None] * len(fixed))
    second = before[1]
    start = (second.first + second.last) // 2           # a fist in the middle of it
    postures = ["asl2"] * len(fixed)
    postures[start:start + 20] = ["fist"] * 20
    after, _ = _spot(gated, fixed, postures)
    stops = [c for c in after if c.by_posture]
    assert [(c.name, c.first, c.named_at) for c in stops] == [("stop", start, start + 2)]
    # the gesture in progress is dropped; nothing is named in the stop posture
    assert second.name not in [c.name for c in after if c.first <= start <= c.last
                               and not c.by_posture]
    assert not [c for c in after if not c.by_posture and start <= c.named_at < start + 20]
    # the gestures before and well after it are still named
    assert [c.first for c in after if c.last < start] == \
        [c.first for c in before if c.named_at < start]


def test_the_board_streaming_loop_sends_the_stop_and_the_power(models):
    from sw_hps.posture import PostureTracker
    from sw_hps.simulated import run_stream, simulate_stream
    plain, gated, fixed = models

    class Reader:
        frame = None

        def read(self):
            return None

    class Tracker(PostureTracker):
        def poll(self, frame):
            self.names[frame] = "fist" if 100 <= frame < 110 else "asl3"
            return frame

    class Link:
        def __init__(self):
            self.sent = []

        def send(self, data):
            self.sent.append(bytes(data))
            return True

        def close(self):
            pass

    link = Link()
    app = run_stream(simulate_stream(gated, fixed[:, 0], fixed[:, 1], link=link,
                                     posture=Tracker(Reader(), model=None)))
    stops = [r for r in app.results if r.by_posture]
    assert [(r.class_name, r.first, r.named_at) for r in stops] == [("stop", 100, 102)]
    assert stops[0].telegram == telegram("stop") and stops[0].to_dict()["by_posture"]
    gestures = [r for r in app.results if not r.by_posture]
    assert gestures and all(r.power == 70 and r.telegram == telegram(r.class_name, power=70)
                            for r in gestures)
    assert link.sent == [r.telegram for r in app.results]
    with pytest.raises(ValueError, match="postures entry needs a posture tracker"):
        simulate_stream(gated, fixed[:, 0], fixed[:, 1])


# ---- the thesis loop ----------------------------------------------------------------
def test_the_thesis_loop_refuses_gestures_out_of_the_command_posture_and_stops():
    from soc.hps_interface import POSTURE_WORD_COUNT, posture_word_offsets
    from sw_hps.app import GestureApp
    from sw_hps.bus import SimBus
    from sw_hps.fifo import FifoPeripheral
    from sw_hps.posture import POSTURE_OFFSET, PostureReader, PostureTracker
    from sw_hps.robot import NullLink
    from sw_hps.simulated import (SimulatedClock, SimulatedFifoPeripheral,
                                  SimulatedPostureSlave, SimulationRun)
    from tests.test_hps_app import MODELS, gesture_frames

    at = posture_word_offsets()
    slave = SimulatedPostureSlave()
    code = {1: "asl2", 2: "asl5", 3: "fist"}

    class Model:
        def classify(self, features):
            return code.get(int(round(features[0] * 100)))

    plan = []        # per video frame, the posture code

    class Fifo(SimulatedFifoPeripheral):
        def push_frame(self, x_fixed, y_fixed, flag, present=True):
            super().push_frame(x_fixed, y_fixed, flag, present)
            words = [0] * POSTURE_WORD_COUNT
            words[at["reference_width"]] = 10
            words[at["polar"]] = plan[self.frames - 1]
            slave.push_record(words)

    parts = [gesture_frames(name) for name in ("back", "left", "right")]
    # back in asl2 (commands), left in asl5 (refused), right with a fist halfway
    for k, (x, _, flag) in enumerate(parts):
        codes = [(1, 2, 1)[k]] * len(x)
        if k == 2:
            moving = np.flatnonzero(flag)
            codes[moving[30]:moving[30] + 8] = [3] * 8
        plan += codes
    x, y, flag = (np.concatenate([p[i] for p in parts]) for i in range(3))
    peripheral = Fifo(reads_per_frame=1)
    peripheral.queue_trajectory(x, y, flag, pixels=True)
    bus = SimBus(peripheral)
    bus.attach(POSTURE_OFFSET, slave)
    models = dataclasses.replace(MODELS, postures=dict(OPTIONS, command=["asl2"],
                                                       power={"asl2": 40}))
    clock, link = SimulatedClock(), NullLink()
    app = GestureApp(models, FifoPeripheral(bus), link, sleep=clock.sleep, clock=clock,
                     posture=PostureTracker(PostureReader(bus), Model()))
    results = SimulationRun(app, peripheral, link, 20_000).run().results
    got = [(r.outcome, r.class_name, r.by_posture) for r in results]
    assert got == [("recognised", "back", False), ("rejected", None, False),
                   ("recognised", "stop", True), ("dropped", None, False)], got
    assert results[0].power == 40 and results[0].telegram == telegram("back", power=40)
    assert "not made in a command posture" in results[1].reason
    assert results[2].telegram == telegram("stop") and results[2].posture == "fist"
    assert results[3].reason == "the stop posture was held"
    with pytest.raises(ValueError, match="postures entry needs a posture tracker"):
        GestureApp(models, FifoPeripheral(bus), link)


def test_the_board_refuses_postures_its_posture_model_does_not_know(tmp_path, capsys):
    from sw_hps.__main__ import main
    from sw_hps.hmm import save_models
    from tests.test_hps_app import MODELS
    path = tmp_path / "model.json"
    save_models(dataclasses.replace(MODELS, postures=dict(OPTIONS, stop="flat")), path)
    assert main(["--bus", "sim", "--robot", "none", "--model", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--posture-model" in err[0] and "postures entry" in err[0]
    posture = tmp_path / "posture.json"
    from stereogest.pipeline_outputs import shipped_posture_model_path
    posture.write_text(shipped_posture_model_path().read_text())
    assert main(["--bus", "sim", "--robot", "none", "--model", str(path),
                 "--posture-model", str(posture)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "postures: flat not a class of the posture model" in err[0]
    data = json.loads(path.read_text())
    assert data["version"] == 6 and data["postures"]["stop"] == "flat"


def test_posture_commands_command_sets_checks_and_clears_the_entry(tmp_path, capsys):
    from stereogest.cli import main
    from stereogest.pipeline_outputs import shipped_model_path
    from sw_hps.hmm import load_models
    path = tmp_path / "continuous.json"
    path.write_bytes(shipped_model_path("continuous").read_bytes())
    assert main(["posture-commands", str(path), "--command", "asl2,asl3", "--stop", "fist",
                 "--power", "fingers", "--share", "0.4"]) == 0
    shipped = load_models(shipped_model_path("continuous")).postures
    assert load_models(path).postures == {"command": ["asl2", "asl3"], "share": 0.4,
                                          "stop": "fist", "stop_frames": shipped["stop_frames"],
                                          "release_frames": shipped["release_frames"],
                                          "neutral": shipped["neutral"],
                                          "power": {"asl2": 40, "asl3": 60}}
    capsys.readouterr()
    before = path.read_bytes()
    for args, words in ((["--share", "2"], "--share: postures share must be a number in [0, 1]"),
                        (["--stop", "flat"], "flat not a class of the posture model"),
                        (["--power", "asl2=300,asl3=10"], "--power: postures power 'asl2'"),
                        (["--power", "asl2"], "--power: expected POSTURE=P pairs"),
                        (["--stop-frames", "0"], "--stop-frames: postures stop_frames"),
                        (["--neutral", "asl2"], "--neutral: postures neutral asl2 must be "
                                                "neither a command nor the stop posture"),
                        (["--neutral", "flat"], "flat not a class of the posture model"),
                        (["--release-frames", "31"],
                         "--release-frames: postures release_frames must be an integer in "
                         "[0, 30]"),
                        (["--clear", "--stop", "fist"], "--clear takes no other")):
        assert main(["posture-commands", str(path), *args]) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (args, err)
        assert path.read_bytes() == before          # nothing half-written
    assert main(["posture-commands", str(path), "--table"]) == 0
    assert path.read_bytes() == before              # printing the table changes nothing
    table = capsys.readouterr().out.splitlines()
    # every class in each command posture, then the stop posture
    assert len([row for row in table if row.startswith("| ")]) == 1 + 7 * 2 + 1
    assert "| right | asl3 | turn right (pivot), then forward | 60 | `09 00 80 09 00 05 33 " \
        "30 36 30 00` |" in table
    assert table[-1] == f"| (held {shipped['stop_frames']} frames) | fist | stop both motors | - | " \
        "`06 00 80 09 00 02 37 00` |"
    assert main(["posture-commands", str(path), "--clear"]) == 0
    assert load_models(path).postures is None


def test_the_renderer_makes_gestures_in_the_shipped_command_posture():
    """`render` and `demo` make gestures in COMMAND_POSTURE: the shipped
    continuous model's first command posture, and make model sets the same."""
    from pathlib import Path

    from sim.hand_postures import COMMAND_POSTURE, extended_fingers
    from stereogest.pipeline_outputs import shipped_model_path
    from sw_hps.hmm import load_models
    options = load_models(shipped_model_path("continuous")).postures
    assert options is not None and options["command"][0] == COMMAND_POSTURE
    make = (Path(__file__).resolve().parents[1] / "Makefile").read_text()
    assert f"COMMAND_POSTURES := {','.join(options['command'])}" in make
    assert f"STOP_POSTURE     := {options['stop']}" in make
    # the power is the extended fingers' (posture-commands --power fingers)
    assert options["power"] == {p: 20 * extended_fingers(p) for p in options["command"]}


def test_narrow_frames_set_the_posture_commands_aside(models, caplog):
    from sw_hps.posture_commands import MIN_FRAME_WIDTH, postures_for_frame
    plain, gated, fixed = models
    assert postures_for_frame(OPTIONS, MIN_FRAME_WIDTH) is OPTIONS
    assert postures_for_frame(OPTIONS, MIN_FRAME_WIDTH - 2) is None
    narrow = StreamSpotter(gated, frame_width=320)
    assert narrow.commands is None and "too narrow for the posture commands" in caplog.text
    # every gesture commands there, whatever the postures say (the path scaled to 320)
    half = [(x // 2, y // 2) for x, y in fixed]
    names = []
    for (x, y) in half:
        names += [c.name for c in narrow.take(int(x), int(y), True, "fist")]
    plain_spotter = StreamSpotter(plain, frame_width=320)
    expected = []
    for (x, y) in half:
        expected += [c.name for c in plain_spotter.take(int(x), int(y), True)]
    assert names == expected and names
