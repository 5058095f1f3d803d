"""sw_hps/streaming.py: the board's continuous spotting on the FIFO's streaming
mode names the gestures recognition.continuous.spot_stream names (the same
code path the figures come from), flushes when the hand leaves, survives
FIFO-FULL and a cleared GO, sends each command once; models trained by
recognition.continuous.train_continuous and `stereogest train --continuous`;
`python -m sw_hps --spotting continuous`."""
from __future__ import annotations

import json

import numpy as np
import pytest

from recognition.continuous import spot_stream, stream_pixels, train_continuous
from recognition.corpus import synthetic_corpus
from recognition.streams import GestureStream, subject_streams
from sw_hps.continuous import ContinuousRecogniser
from sw_hps.hmm import load_models, save_models
from sw_hps.simulated import run_stream, simulate_stream
from sw_hps.streaming import StreamingApp, check_streaming_models
from sw_hps.telegram import telegram

STEP = 12


@pytest.fixture(scope="module")
def corpus():
    return synthetic_corpus(per_class=8, people=3, seed=5)


@pytest.fixture(scope="module")
def models(corpus):
    """Continuous models of two people (a fixed bias: no calibration here)."""
    train = corpus.subset(np.flatnonzero(corpus.subject != 2))
    m, calibration = train_continuous(train, states=6, step=STEP,
                                      spotting={"threshold_bias": -0.5})
    assert calibration is None and m.spotting["step"] == STEP
    return m


@pytest.fixture(scope="module")
def stream(corpus):
    """The third person's gestures joined into one stream."""
    held = corpus.subset(np.flatnonzero(corpus.subject == 2))
    return subject_streams(held, per_stream=8, seed=3)[0]


def _smoothed_fixed(points, present=None):
    """What the FIFO holds: the camera front end's 10.8 positions (``present``:
    the frames with a hand, default all)."""
    from sim.model.pipeline import PipelineParams, track
    pts = np.floor(np.maximum(np.asarray(points, np.float64), 0)).astype(np.int64)
    areas = np.ones(len(pts), np.int64) if present is None else np.asarray(present, np.int64)
    return track(pts, areas, PipelineParams()).smoothed


def test_board_loop_names_what_the_measured_spotter_names(models, stream):
    golden = spot_stream(ContinuousRecogniser(models, **models.spotting), stream.points, STEP,
                         "camera")
    assert len(golden) >= 4, golden
    fixed = _smoothed_fixed(stream.points)
    assert np.array_equal(fixed >> 8, stream_pixels(stream.points, "camera"))
    app = run_stream(simulate_stream(models, fixed[:, 0], fixed[:, 1]))
    got = [(r.class_name, r.first, r.last) for r in app.results]
    assert got == [(d.name, d.first, d.last) for d in golden]
    # named at the same frames but the last, which the stream's end flushed
    # there and the board names once the still hand's frames show it ended
    # (within the recogniser's longest wait, 4 end delays)
    assert [r.named_at for r in list(app.results)[:-1]] == [d.named_at for d in golden[:-1]]
    assert app.results[-1].named_at - app.results[-1].last <= 4 * models.spotting["end_delay"]
    # each command sent once, in order
    sent = list(app.link.sent)
    assert sent == [telegram(r.class_name) for r in app.results]
    assert all(r.sent for r in app.results)
    assert app.results[0].to_dict()["telegram"] == telegram(app.results[0].class_name).hex(" ")
    assert {r.to_dict()["delivery"] for r in app.results} == {"unconfirmed"}   # no --robot-ack


def test_board_loop_acknowledged_deliveries(models, stream):
    """--robot uart --robot-ack: each named gesture's telegram goes out with the
    reply flag and the (simulated) brick's answer makes it acknowledged."""
    from sw_hps.bus import SimBus
    from sw_hps.robot import RobotChannel, UartLink
    from sw_hps.simulated import SimulatedRn42, SimulatedUart
    from sw_hps.telegram import GESTURE_NAMES

    fixed = _smoothed_fixed(stream.points)
    rn42 = SimulatedRn42()
    bus = SimBus()
    bus.attach(0x100, SimulatedUart(responder=rn42))
    channel = RobotChannel(UartLink(bus, 0x100), ack_timeout=0.3)
    app = run_stream(simulate_stream(models, fixed[:, 0], fixed[:, 1], link=channel, bus=bus))
    assert app.results and {r.to_dict()["delivery"] for r in app.results} == {"acknowledged"}
    assert [r.telegram for r in app.results] == [telegram(r.class_name, reply=True)
                                                for r in app.results]
    assert rn42.messages == [str(GESTURE_NAMES.index(r.class_name) + 1).encode()
                             for r in app.results]


def test_a_hand_that_leaves_flushes(models, stream):
    """Frames without a hand name what is pending at once and start afresh:
    a gesture the recogniser held for a while is named the frame the hand
    leaves, with the same span."""
    fixed = _smoothed_fixed(stream.points)
    plain = run_stream(simulate_stream(models, fixed[:, 0], fixed[:, 1])).results
    held = next(r for r in plain if r.named_at > r.last + 1)
    cut = held.last + 1
    present = np.ones(len(fixed), bool)
    present[cut:cut + 30] = False
    app = run_stream(simulate_stream(models, fixed[:, 0], fixed[:, 1], present))
    again = next(r for r in app.results if r.first == held.first)
    assert (again.class_name, again.last, again.named_at) == (held.class_name, held.last, cut)


def test_fifo_full_and_a_cleared_go_restart_the_stream(models, stream, caplog):
    fixed = _smoothed_fixed(stream.points)
    app = simulate_stream(models, fixed[:, 0], fixed[:, 1])
    peripheral = app.peripheral
    app.run(max_iterations=20)
    assert peripheral.streaming and peripheral.go and app.frames > 0
    peripheral.full = True
    app.run(max_iterations=1)
    assert app.lost == 1 and not peripheral.full and not peripheral.fifo_x
    assert "FIFO-FULL" in caplog.text
    peripheral.write32(0x0C, 0)           # someone cleared GO and STREAM
    app.run(max_iterations=3)             # a bus fault, one probe, the restart
    assert peripheral.go and peripheral.streaming and app.bus_faults == 1
    assert "GO does not read back" in caplog.text and not app.bus_watch.active


def test_a_bus_fault_does_not_end_the_loop(models, caplog):
    class Broken:
        span = 0x1000

        def read32(self, offset):
            raise OSError("bus error")

        def write32(self, offset, value):
            raise OSError("bus error")

    from sw_hps.fifo import FifoPeripheral
    from sw_hps.robot import NullLink
    slept = []
    app = StreamingApp(models, FifoPeripheral(Broken()), NullLink(), sleep=slept.append)
    assert app.run(max_iterations=4) == []
    assert app.errors == 4 and slept == [0.1, 0.2, 0.4, 0.8]
    assert "OSError: bus error" in caplog.text


def test_models_without_spotting_are_refused(models):
    import dataclasses
    from stereogest.pipeline_outputs import shipped_model_path
    with pytest.raises(ValueError, match="'spotting' entry"):
        check_streaming_models(load_models(shipped_model_path()))      # gaussian
    with pytest.raises(ValueError, match="'spotting' entry"):
        check_streaming_models(dataclasses.replace(models, spotting=None))
    with pytest.raises(ValueError, match=r"spotting step must be an integer in \[1, 640\]"):
        dataclasses.replace(models, spotting={"step": 0})


def test_model_file_keeps_the_spotting_options(models, tmp_path):
    path = tmp_path / "m.json"
    save_models(models, path)
    again = load_models(path)
    assert again.spotting == models.spotting and again.spotting["step"] == STEP


def test_a_frame_without_a_hand_flushes_as_the_board_does(models, corpus):
    """Streams whose out-of-view distractors hide the hand: the measured
    spotter (spot_stream with ``present``) and the board's StreamSpotter on the
    same records (no hand = area 0) name the same gestures at the same frames."""
    import dataclasses
    from types import SimpleNamespace

    from stereogest.pipeline_outputs import stream_results
    # a long end delay: what is pending when the hand leaves is named then
    models = dataclasses.replace(models, spotting=dict(models.spotting, end_delay=50))
    held = corpus.subset(np.flatnonzero(corpus.subject == 2))
    streams = [s for s in subject_streams(held, per_stream=4, seed=3, distractors=True)
               if not s.present.all()]
    # and one made to test it: a gesture, the hand gone two frames after its end
    one = held.trajectory(0)
    hidden = np.concatenate([one, np.repeat(one[-1:], 30, axis=0)])
    present = np.ones(len(hidden), bool)
    present[len(one) + 2:len(one) + 20] = False
    streams.append(GestureStream(hidden, [[0, len(one) - 1]], [str(held.label[0])],
                                 present=present))
    for s in streams:
        golden = spot_stream(ContinuousRecogniser(models, **models.spotting), s.points, STEP,
                             "camera", s.present)
        # the board's StreamSpotter on the records, as the benchmarks run it
        board = stream_results(models, SimpleNamespace(
            smoothed=_smoothed_fixed(s.points, s.present), area=s.present), 640)
        assert [(d["name"], d["first"], d["last"], d["named_at"]) for d in board] == \
            [(d.name, d.first, d.last, d.named_at) for d in golden]
    assert [(d.name, d.named_at) for d in golden] == [(s.labels[0], len(one) + 2)]


def test_command_line_continuous(models, stream, tmp_path, capsys):
    from sw_hps.__main__ import main
    path = tmp_path / "m.json"
    save_models(models, path)
    fixed = _smoothed_fixed(stream.points)
    csv = tmp_path / "t.csv"
    csv.write_text("frame,x,y,flag\n" + "".join(
        f"{n},{x / 256:.4f},{y / 256:.4f},0\n" for n, (x, y) in enumerate(fixed)))
    assert main(["--model", str(path), "--bus", "sim", "--robot", "none", "--spotting",
                 "continuous", "--sim-trajectory", str(csv), "--poll-ms", "0.01",
                 "--log-level", "error"]) == 0
    got = json.loads(capsys.readouterr().out.splitlines()[-1])["gestures"]
    golden = spot_stream(ContinuousRecogniser(models, **models.spotting), stream.points, STEP,
                         "camera")
    assert [(g["name"], g["first"], g["last"]) for g in got] == \
        [(d.name, d.first, d.last) for d in golden]
    from stereogest.pipeline_outputs import shipped_model_path
    assert main(["--model", str(shipped_model_path()), "--bus", "sim", "--robot", "none",
                 "--spotting", "continuous"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "argument --spotting: continuous spotting needs" in err


def test_train_continuous_command(tmp_path, capsys):
    from recognition.datasets import save_trajectories
    from stereogest.cli import main
    data = synthetic_corpus(per_class=4, people=2, seed=9)
    path = tmp_path / "c.npz"
    save_trajectories(data, path)
    out = tmp_path / "m.json"
    assert main(["train", str(path), "-o", str(out), "--emission", "discrete", "--continuous",
                 "--states", "4", "--step", "10", "--quiet"]) == 0
    report = json.loads(capsys.readouterr().out.splitlines()[-1])
    m = load_models(out)
    assert m.spotting == report["spotting"] and m.spotting["step"] == 10
    calibration = report["calibration_f1"]
    assert m.spotting["threshold_bias"] in [float(b) for b in calibration["threshold_bias"]]
    assert m.spotting["end_delay"] in [int(d) for d in calibration["end_delay"]]
    for argv, message in (
            (["--continuous"], "--continuous needs --emission discrete"),
            (["--emission", "discrete", "--step", "5"], "--step applies to --continuous"),
            (["--emission", "discrete", "--continuous", "--step", "0"],
             "--step must be in 1..640"),
            (["--emission", "discrete", "--continuous", "--resample", "32"],
             "--resample does not apply with --continuous")):
        assert main(["train", str(path), "-o", str(tmp_path / "x.json"), *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
        assert not (tmp_path / "x.json").exists()


def test_each_gesture_names_the_posture_held_over_it(models, stream):
    """With a posture tracker the loop reads the posture after each poll's
    records, as the posture of the last frame popped, and each named gesture
    carries the posture held over most of its frames."""
    from sw_hps.posture import PostureTracker

    class Reader:                   # the slave's latest record: one per frame
        def __init__(self):
            self.frame = -1

        def read(self):
            self.frame += 1
            return None

    fixed = _smoothed_fixed(stream.points)
    polled = []

    class Tracker(PostureTracker):
        def poll(self, frame):
            polled.append(frame)
            self.names[frame] = "fist" if frame % 4 else None   # 3 frames in 4

    tracker = Tracker(Reader(), model=None)
    app = run_stream(simulate_stream(models, fixed[:, 0], fixed[:, 1], posture=tracker))
    assert app.results and polled == sorted(set(polled))
    for r in app.results:
        frames = range(r.first, r.last + 1)
        known = [f for f in frames if f in tracker.names]
        assert len(known) >= len(frames) // 2     # polls reach most frames here
        assert r.posture == "fist" and r.to_dict()["posture_share"] == r.posture_share
        assert r.posture_share == round(sum(tracker.names.get(f) == "fist" for f in frames)
                                        / len(frames), 3)


def test_the_tracker_classifies_each_new_record_once():
    from sw_hps.bus import SimBus
    from sw_hps.posture import POSTURE_OFFSET, PostureReader, PostureTracker
    from sw_hps.simulated import SimulatedPostureSlave
    from soc.hps_interface import POSTURE_WORD_COUNT, posture_word_offsets

    class Model:
        calls = 0

        def classify(self, features):
            Model.calls += 1
            return "fist" if features[0] > 0 else None
    slave, bus = SimulatedPostureSlave(), SimBus()
    bus.attach(POSTURE_OFFSET, slave)
    tracker = PostureTracker(PostureReader(bus), Model(), keep=4)
    at = posture_word_offsets()
    hand = [0] * POSTURE_WORD_COUNT
    hand[at["reference_width"]], hand[at["polar"]] = 10, 50
    none = [0] * POSTURE_WORD_COUNT
    for frame, record in enumerate([hand, hand, none, hand]):
        slave.push_record(record)
        tracker.poll(frame)
        tracker.poll(frame)          # nothing new: no second decision
    assert Model.calls == 3                      # the frame without a hand is not classified
    assert tracker.names == {0: "fist", 1: "fist", 2: None, 3: "fist"} and tracker.last == "fist"
    assert tracker.held(1, 4) == ("fist", 0.667)      # frame 4 was never read: not counted
    assert tracker.held(2, 10 ** 9) == (None, None)     # the last keep frames: none read
    assert tracker.held(2, 3) == ("fist", 0.5)          # a tie goes to the named posture
    assert tracker.held(None, 4) == (None, None)        # no record when the gesture began
    slave.read32 = lambda offset: 1 / 0          # a fault costs the frame, not the loop
    tracker.poll(4)
    assert tracker.errors == 1 and 4 not in tracker.names


@pytest.fixture(scope="module")
def verifier(corpus):
    """Gaussian models with rejection of the same two people as ``models``."""
    from recognition.recogniser import Recogniser
    train = corpus.subset(np.flatnonzero(corpus.subject != 2))
    recogniser = Recogniser()
    return recogniser.fit(recogniser.samples(train), train.label, train.class_names,
                          groups=train.subject)


def _named(models, stream):
    from types import SimpleNamespace

    from stereogest.pipeline_outputs import stream_results
    fixed = _smoothed_fixed(stream.points)
    return stream_results(models, SimpleNamespace(smoothed=fixed,
                                                  area=np.ones(len(fixed), np.int64)), 640)


def test_the_verifier_confirms_each_spotted_gesture(models, verifier, stream, caplog):
    """A verifier names every command over its span the same class without
    refusing it; one whose classes are shuffled confirms none of them and
    says why."""
    import dataclasses
    import logging

    from sw_hps.streaming import StreamSpotter
    plain = _named(models, stream)
    checked = _named(dataclasses.replace(models, verifier=verifier), stream)
    assert checked and len(checked) <= len(plain) + 1
    fixed = _smoothed_fixed(stream.points) >> 8
    for d in checked:
        scores = verifier.scores_of_points(fixed[d["first"]:d["last"] + 1].astype(float))
        index, _ = verifier.decide(scores)
        assert verifier.class_names[index] == d["name"]
    # the same verifier with its classes rotated names every path another class
    names = verifier.class_names
    wrong = dataclasses.replace(verifier, class_names=names[1:] + names[:1])
    spotter = StreamSpotter(dataclasses.replace(models, verifier=wrong), 640)
    with caplog.at_level(logging.INFO, logger="sw_hps.streaming"):
        named = [d for x, y in _smoothed_fixed(stream.points) for d in spotter.take(x, y, True)]
        named += spotter.flush()
    assert named == [] and spotter.unconfirmed >= len(plain)
    assert "is not confirmed by the verifier" in caplog.text


def test_the_verifier_lives_in_the_model_file(models, verifier, tmp_path):
    import dataclasses

    from sw_hps.hmm import check_verifier
    path = tmp_path / "m.json"
    save_models(dataclasses.replace(models, verifier=verifier), path)
    again = load_models(path)
    assert again.verifier.class_names == verifier.class_names
    assert again.verifier.thresholds == verifier.thresholds
    data = json.loads(path.read_text())
    assert data["version"] == 6 and data["verifier"]["emission"] == "gaussian"
    # a version 5 file has no verifier, whatever it holds
    data["version"] = 5
    path.write_text(json.dumps(data))
    assert load_models(path).verifier is None
    for bad, message in (
            (models, "verifier must be gaussian models"),
            (dataclasses.replace(verifier, class_names=tuple("abcdefg")),
             "verifier classes"),
            (verifier.with_thresholds(None), "verifier must have rejection thresholds")):
        with pytest.raises(ValueError, match=message):
            check_verifier(bad, models.class_names)
    with pytest.raises(ValueError, match="verifier needs a spotting entry"):
        dataclasses.replace(models, spotting=None, verifier=verifier)
    data["version"] = 6
    data["verifier"] = {"format": "stereogest-hmm", "version": 6, "emission": "discrete"}
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="verifier: must be a gaussian model file's object"):
        load_models(path)


def test_train_continuous_with_a_verifier(verifier, tmp_path, capsys):
    from recognition.datasets import save_trajectories
    from sw_hps.hmm import save_models as save
    from stereogest.cli import main
    data = synthetic_corpus(per_class=4, people=2, seed=9)
    path = tmp_path / "c.npz"
    save_trajectories(data, path)
    save(verifier, tmp_path / "v.json")
    out = tmp_path / "m.json"
    assert main(["train", str(path), "-o", str(out), "--emission", "discrete", "--continuous",
                 "--states", "4", "--verifier", str(tmp_path / "v.json"), "--quiet"]) == 0
    capsys.readouterr()
    assert load_models(out).verifier.class_names == verifier.class_names
    import dataclasses
    save(dataclasses.replace(verifier, class_names=tuple("abcdefg")), tmp_path / "w.json")
    save(verifier.with_thresholds(None), tmp_path / "n.json")
    for argv, message in (
            (["--emission", "discrete", "--verifier", str(tmp_path / "v.json")],
             "--verifier applies to --continuous"),
            (["--emission", "discrete", "--continuous", "--verifier", str(tmp_path / "no.json")],
             "--verifier: "),
            (["--emission", "discrete", "--continuous", "--verifier", str(tmp_path / "w.json")],
             "--verifier: verifier classes"),
            (["--emission", "discrete", "--continuous", "--verifier", str(tmp_path / "n.json")],
             "--verifier: verifier must have rejection thresholds"),
            (["--emission", "discrete", "--continuous", "--verifier", str(out)],
             "--verifier: verifier must be gaussian models")):
        assert main(["train", str(path), "-o", str(tmp_path / "x.json"), *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
        assert not (tmp_path / "x.json").exists()


def test_the_verifier_may_leave_out_the_start_of_a_spotted_span(models, verifier, corpus,
                                                                monkeypatch):
    """A held-out person's gestures led in by a stroke from below a sixth of
    their length: the span from the lead-in's first frame is confirmed more
    often with the start left out (VERIFY_TRIMS) than without."""
    import dataclasses

    import sw_hps.streaming as streaming
    held = corpus.subset(np.flatnonzero(corpus.subject == 2))

    def confirmed(trims):
        monkeypatch.setattr(streaming, "VERIFY_TRIMS", trims)
        count = 0
        for i in range(len(held)):
            points = np.asarray(held.trajectory(i), np.float64)
            lead = points[0] + np.outer(np.linspace(1, 0, len(points) // 6, endpoint=False),
                                        [0, 60])
            path = _smoothed_fixed(np.vstack([lead, points])) >> 8
            spotter = streaming.StreamSpotter(dataclasses.replace(models, verifier=verifier),
                                              640)
            spotter._path.extend((f, int(x), int(y)) for f, (x, y) in enumerate(path))
            count += spotter._confirmed(models.class_names.index(str(held.label[i])), 0,
                                        len(path) - 1)
        return count

    shipped = streaming.VERIFY_TRIMS
    plain, trimmed = confirmed((0.0,)), confirmed(shipped)
    assert trimmed >= plain + len(held) // 3, (plain, trimmed)
