"""The live view (stereogest/live.py, `stereogest live`): the frame-by-frame
session against the batch golden model, the page and its routes, the command,
and the page in a real headless browser when Chromium is installed."""
from __future__ import annotations

import json
import shutil
import subprocess
import urllib.error
import urllib.request

import numpy as np
import pytest

from sim.model.pipeline import PipelineParams, run_clip
from sim.render import render_clip
from stereogest.cli import main
from stereogest.pipeline_outputs import recognise, shipped_model_path
from stereogest.live import PANELS, LiveServer, LiveSession, run_source
from sw_hps.hmm import load_models


@pytest.fixture(scope="module")
def gesture():
    """A rendered gesture, then its last frame held for 30 frames (the hand
    still: the gesture ends before the clip does)."""
    clip = render_clip("rotate-right", 1, 320, 240, n_pre_rest=10)
    clip.left = np.concatenate([clip.left, np.repeat(clip.left[-1:], 30, axis=0)])
    clip.right = np.concatenate([clip.right, np.repeat(clip.right[-1:], 30, axis=0)])
    return clip


@pytest.fixture(scope="module")
def models():
    return load_models(shipped_model_path())


@pytest.fixture(scope="module")
def session(gesture, models):
    params = PipelineParams.for_frame(320)
    s = LiveSession(params, models)
    states = []
    run_source(s, zip(gesture.left, gesture.right), on_frame=lambda s: states.append(
        dict(s.state)))
    return s, states


def test_session_follows_the_batch_model_frame_by_frame(session, gesture, models):
    s, states = session
    params = PipelineParams.for_frame(320)
    trajectory, _ = run_clip(gesture.left, gesture.right, params)
    assert s.frames == gesture.frames and s.state["done"] and s.state["error"] is None
    assert [st["frame"] for st in states] == list(range(gesture.frames))
    assert [st["flag"] for st in states] == trajectory.flag.tolist()
    for st, xy, area in zip(states, trajectory.smoothed, trajectory.area):
        if area:
            assert st["centroid"] == [round(float(v) / 256, 1) for v in xy]
    # the gesture is named when it ends, as the board application names it
    name, telegram = recognise(models, trajectory)
    assert name == "rotate-right"
    assert s.state["recognised"] == name and s.state["telegram"] == telegram
    assert s.state["history"][-1]["recognised"] == name
    ended = [st["frame"] for st, nxt in zip(states, states[1:]) if st["flag"] and not nxt["flag"]]
    assert s.state["recognised_at"] in [e + 1 for e in ended]


def test_session_passes_the_hand_tracking_its_previous_centroid(models):
    """With hand tracking (a forearm and an intruder in the scene) the live
    session, frame by frame, equals the batch model, which gives each frame the
    previous one's centroid."""
    from sim.difficulties import Difficulties
    clip = render_clip("left", 3, 320, 240, n_pre_rest=2, n_motion=10, n_post_rest=0,
                       difficulties=Difficulties(forearm=True, intruder=True))
    params = PipelineParams.for_frame(320, hand_tracking=True)
    s = LiveSession(params, models)
    states = []
    run_source(s, zip(clip.left, clip.right), on_frame=lambda s: states.append(dict(s.state)))
    trajectory, _ = run_clip(clip.left, clip.right, params)
    assert (trajectory.area > 0).all()
    assert [st["centroid"] for st in states] == [[round(float(v) / 256, 1) for v in xy]
                                                 for xy in trajectory.smoothed]
    plain, _ = run_clip(clip.left, clip.right, PipelineParams.for_frame(320))
    assert not np.array_equal(plain.centroid, trajectory.centroid)


def test_page_and_routes(session):
    s, _ = session
    server = LiveServer(s, 320, 240, port=0)
    try:
        assert server.httpd.server_address[0] == "127.0.0.1"      # local only
        page = urllib.request.urlopen(server.url, timeout=10).read().decode()
        for name in PANELS:
            assert f'alt="{name}"' in page
        state = json.loads(urllib.request.urlopen(server.url + "state.json", timeout=10).read())
        assert state["frame"] == s.frames - 1 and state["recognised"] == "rotate-right"
        for name in PANELS:
            body = urllib.request.urlopen(
                f"{server.url}panel/{name.replace(' ', '-')}.jpg?frame=3", timeout=10).read()
            assert body[:2] == b"\xff\xd8", name                    # a JPEG
        with pytest.raises(urllib.error.HTTPError) as exc:
            urllib.request.urlopen(server.url + "panel/nothing.jpg", timeout=10)
        assert exc.value.code == 404
    finally:
        server.close()


def test_command_replays_a_clip(tmp_path, gesture, capsys):
    from sim.clip import save_clip
    path = save_clip(render_clip("rotate-right", 1, 320, 240, n_pre_rest=10), tmp_path / "clip")
    assert main(["live", "--clip", str(path), "--fast", "--frames", "5", "--port", "0",
                 "--quiet", "--json"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith(f"live view of clip {path} (320x240) on http://127.0.0.1:")
    assert out[-2] == "5 frame pairs; last recognised: none"
    assert json.loads(out[-1]) == {"source": f"clip {path}", "width": 320, "height": 240,
                                   "frames": 5, "recognised": None, "telegram": None,
                                   "gestures": []}


def test_command_loops_a_clip(tmp_path, capsys):
    """--loop replays the clip from its start: each pass names its gesture."""
    from sim.clip import save_clip
    clip = render_clip("rotate-right", 1, 320, 240, n_pre_rest=10)
    path = save_clip(clip, tmp_path / "clip")
    frames = 2 * clip.frames
    assert main(["live", "--clip", str(path), "--loop", "--fast", "--frames", str(frames),
                 "--port", "0", "--quiet", "--json"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("(Ctrl-C stops)") and ", looped (320x240)" in out[0]
    report = json.loads(out[-1])
    assert report["frames"] == frames
    assert [g["name"] for g in report["gestures"]] == ["rotate-right", "rotate-right"]
    assert report["gestures"][1]["first"] >= clip.frames


def test_session_keeps_the_latest_gestures(models, monkeypatch):
    """A session that runs for days keeps the latest GESTURES_KEPT gestures and
    puts the latest PAGE_GESTURES in the page's state."""
    from types import SimpleNamespace

    import stereogest.live as live
    monkeypatch.setattr(live, "GESTURES_KEPT", 30)
    s = LiveSession(PipelineParams.for_frame(320), models)
    for n in range(45):
        s._name(n, [SimpleNamespace(name="left", first=n, last=n, score=0.0, power=None,
                                    posture=None, posture_share=None, by_posture=False)])
    assert [g["first"] for g in s.gestures] == list(range(15, 45))
    state, _ = s.snapshot()
    assert [g["first"] for g in state["gestures"]] == list(range(45 - live.PAGE_GESTURES, 45))


@pytest.fixture(scope="module")
def held_clips(tmp_path_factory):
    """Every gesture, each clip ending inside the spotting hold: the hand is
    still for fewer frames than the hold at the clip's last frame."""
    from sim.clip import save_clip
    from sim.gesture_shapes import GESTURE_NAMES
    hold = PipelineParams.for_frame(320).spot_hold
    root = tmp_path_factory.mktemp("held")
    return {name: save_clip(render_clip(name, 5 + k, 320, 240, n_pre_rest=3,
                                        n_post_rest=hold // 2), root / name)
            for k, name in enumerate(GESTURE_NAMES)}


def test_live_and_pipeline_name_the_same_gestures(held_clips, tmp_path, capsys):
    """`live` and `pipeline` on the same clips name the same gestures with the
    same frame spans and telegrams (issue 29), the last one at the source's
    end, inside the hold; `live --json` lists them."""
    from sim.clip import load_clip
    for name, path in held_clips.items():
        clip = load_clip(path)
        assert main(["pipeline", str(path), "-o", str(tmp_path / name), "--json",
                     "--quiet"]) == 0
        batch = json.loads(capsys.readouterr().out.splitlines()[-1])
        assert main(["live", "--clip", str(path), "--fast", "--port", "0", "--quiet",
                     "--frames", str(clip.frames), "--json"]) == 0
        out = capsys.readouterr().out.splitlines()
        live = json.loads(out[-1])
        assert batch["recognised"] == name, (name, batch)
        assert live["gestures"] == batch["gestures"] and live["gestures"], (name, live, batch)
        assert live["gestures"][-1]["last"] == clip.frames - 1       # flagged to the end
        assert (live["recognised"], live["telegram"]) == (batch["recognised"],
                                                          batch["telegram"])
        assert out[-2] == (f"{clip.frames} frame pairs; last recognised: {name} "
                           f"(NXT telegram {batch['telegram']})")


def test_session_names_every_gesture_once(models):
    """Two gestures in one source: each named once, when it ends, with its own
    frame span (the second at the source's end); the page's state lists both."""
    clips = [render_clip(g, 2, 320, 240, n_pre_rest=3, n_post_rest=r)
             for g, r in (("stop", 40), ("left", 8))]
    left = np.concatenate([c.left for c in clips])
    right = np.concatenate([c.right for c in clips])
    params = PipelineParams.for_frame(320)
    s = LiveSession(params, models)
    run_source(s, zip(left, right))
    trajectory, _ = run_clip(left, right, params)
    from stereogest.pipeline_outputs import board_results, flagged_spans, recognised_gestures
    batch = recognised_gestures(board_results(models, trajectory))
    assert [g["name"] for g in s.gestures] == ["stop", "left"]
    assert s.gestures == batch == s.state["gestures"]
    assert [(g["first"], g["last"]) for g in s.gestures] == flagged_spans(trajectory.flag)
    assert [h["recognised"] for h in s.state["history"]] == ["stop", "left"]


@pytest.mark.parametrize("argv, message", [
    ([], "give either --clip CLIP or both --left and --right"),
    (["--left", "0"], "give either --clip CLIP or both --left and --right"),
    (["--clip", "x", "--left", "0", "--right", "1"], "give either --clip"),
    (["--clip", "{clip}", "--port", "70000"], "--port must be in [0, 65535]"),
    (["--clip", "{clip}", "--frames", "0"], "--frames must be in [1, 1800]"),
    (["--clip", "{clip}", "--fps", "0"], "--fps must be in [1, 1000]"),
    (["--clip", "{tmp}/none"], "not a clip directory"),
    (["--left", "{tmp}/a.avi", "--right", "{tmp}/b.avi"], "--left: '"),
])
def test_command_bad_input(tmp_path, gesture, capsys, argv, message):
    from sim.clip import save_clip
    clip = save_clip(render_clip("stop", 1, 96, 64, n_pre_rest=1, n_motion=2, n_post_rest=0),
                     tmp_path / "c")
    argv = [a.format(clip=clip, tmp=tmp_path) for a in argv]
    assert main(["live", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


@pytest.mark.skipif(_chromium() is None,
                    reason="no Chromium: .ci/run installs Debian's chromium when it can "
                           "(apt-get, root); the page's routes are tested above without it")
def test_page_in_a_headless_browser(session, tmp_path):
    """Chromium loads the page, runs its script and shows every panel: each of
    the nine pictures the server holds is found in the screenshot, three per
    row in the page's order, and the recognised gesture is written out."""
    import cv2
    s, _ = session
    server = LiveServer(s, 320, 240, port=0)
    shot = tmp_path / "page.png"
    try:
        proc = subprocess.run(
            [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
             "--virtual-time-budget=3000", "--window-size=1100,1150",
             f"--screenshot={shot}", server.url],
            capture_output=True, text=True, timeout=120)
        _, pictures = s.snapshot()
        dom = subprocess.run(
            [_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
             "--virtual-time-budget=3000", "--dump-dom", server.url],
            capture_output=True, text=True, timeout=120).stdout
    finally:
        server.close()
    assert shot.exists(), proc.stderr[-2000:]
    page = cv2.imread(str(shot))
    found = []
    for name in PANELS:
        panel = cv2.imdecode(np.frombuffer(pictures[name], np.uint8), cv2.IMREAD_COLOR)
        scores = cv2.matchTemplate(page, panel, cv2.TM_CCOEFF_NORMED)
        _, best, _, (x, y) = cv2.minMaxLoc(scores)
        assert best > 0.9, (name, best)
        found.append((x, y))
    for k in range(0, len(PANELS), 3):                 # rows of three, left to right
        row = found[k:k + 3]
        assert row[0][0] < row[1][0] < row[2][0], found
        assert max(abs(y - row[0][1]) for _, y in row) <= 2, found
    assert found[0][1] < found[3][1] < found[6][1], found
    # the page's script filled in the state: frame, recognised gesture, telegram
    assert f'<span id="frame">{s.frames - 1}</span>' in dom
    assert '<span id="gesture">rotate-right</span>' in dom
    assert f"NXT telegram {s.state['telegram']}" in dom


@pytest.mark.skipif(_chromium() is None,
                    reason="no Chromium: .ci/run installs Debian's chromium when it can "
                           "(apt-get, root); the session's state is tested above without it")
def test_page_names_a_gesture_the_source_ended_inside(held_clips, models):
    """A clip that ends inside the spotting hold: after the source ended, the
    page shows the gesture's name and the command with its frame span."""
    from sim.clip import load_clip
    clip = load_clip(held_clips["stop"])
    s = LiveSession(PipelineParams.for_frame(320), models)
    run_source(s, zip(clip.left, clip.right))
    assert s.state["done"] and s.state["flag"]        # still flagged at the last frame
    server = LiveServer(s, 320, 240, port=0)
    try:
        dom = subprocess.run(
            [_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
             "--virtual-time-budget=3000", "--dump-dom", server.url],
            capture_output=True, text=True, timeout=120).stdout
    finally:
        server.close()
    (g,) = s.gestures
    assert '<span id="gesture">stop</span>' in dom
    assert f'<span id="commands">stop (frames {g["first"]}-{clip.frames - 1})</span>' in dom


def test_live_and_pipeline_continuous_spotting_agree(tmp_path, capsys):
    """--spotting continuous (the board's continuous spotting on every frame's
    record): two gestures back to back, the second ending with the clip;
    `live` and `pipeline` name the same gestures with the same spans, as the
    board's loop does on the streaming FIFO (sw_hps.streaming.StreamSpotter,
    tested against the measured spotter in tests/test_hps_streaming.py)."""
    from sim.clip import save_clip
    import dataclasses
    first = render_clip("right", 4, 320, 240, n_pre_rest=5, n_post_rest=2)
    second = render_clip("stop", 4, 320, 240, n_pre_rest=0, n_post_rest=3)
    both = dataclasses.replace(
        first, left=np.concatenate([first.left, second.left]),
        right=np.concatenate([first.right, second.right]),
        hand_xy=np.concatenate([first.hand_xy, second.hand_xy]),
        hand_area=np.concatenate([first.hand_area, second.hand_area]),
        postures=first.postures + second.postures)
    path = save_clip(both, tmp_path / "two")
    frames = len(both.left)
    assert main(["pipeline", str(path), "-o", str(tmp_path / "out"), "--spotting",
                 "continuous", "--json", "--quiet"]) == 0
    batch = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert main(["live", "--clip", str(path), "--fast", "--port", "0", "--quiet",
                 "--frames", str(frames), "--spotting", "continuous", "--json"]) == 0
    live = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert live["gestures"] == batch["gestures"]
    assert [g["name"] for g in batch["gestures"]] == ["right", "stop"], batch["gestures"]


def test_session_shows_the_posture_of_each_frame_and_gesture(models, tmp_path):
    """With a posture model the page's state has each frame's posture (the
    batch model's records through the classifier) and each gesture's."""
    from sim.clip import save_clip  # noqa: F401  (the clip stays in memory)
    from stereogest.pipeline_outputs import frame_postures, load_posture_model
    clip = render_clip("rotate-right", 1, 320, 240, n_pre_rest=2, n_motion=10, n_post_rest=20,
                       posture="fist")
    data, model = tmp_path / "postures.npz", tmp_path / "posture.json"
    assert main(["postures", "-o", str(data), "--people", "2", "--seed", "1", "--postures",
                 "fist,open", "--width", "320", "--height", "240", "--quiet"]) == 0
    assert main(["train-posture", str(data), "-o", str(model), "--copies", "0"]) == 0
    posture_model = load_posture_model(model)
    params = PipelineParams.for_frame(320)
    s = LiveSession(params, models, posture_model=posture_model)
    states = []
    run_source(s, zip(clip.left, clip.right), on_frame=lambda s: states.append(dict(s.state)))
    trajectory, _ = run_clip(clip.left, clip.right, params)
    assert [st["posture"] for st in states] == frame_postures(posture_model, trajectory)
    assert sum(st["posture"] == "fist" for st in states) > len(states) // 2
    assert s.gestures and all(g["posture"] == "fist" for g in s.gestures)
