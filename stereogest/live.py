"""The live view: the golden model and the recogniser frame by frame on two
cameras, two video files or a clip, shown on a local web page.

:class:`LiveSession` reads frame pairs (:mod:`sim.footage` sources, or a clip),
runs each through every pixel stage (:func:`sim.model.pipeline.process_frame`),
tracks the centroid (moving average, spotting, orientation symbols: the
pipeline's :func:`~sim.model.pipeline.track` over the frames so far, which is
causal) and, when a gesture ends, runs the board application's HMMs on it
(:func:`sw_hps.simulated.run_on_trajectory`) for the gesture's name and its NXT
telegram. :class:`LiveServer` serves the page on 127.0.0.1 only: the two
cameras, the six stages of thesis Table 22, the trajectory and the last
recognised gesture, refreshed as frames arrive (the page polls
``/state.json`` and reloads the pictures of a new frame). opencv-python-headless
has no windows, hence a page.
"""
from __future__ import annotations

import json
import sys
import threading
import time
from http import HTTPStatus
from types import SimpleNamespace
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np

__all__ = ["LiveSession", "LiveServer", "PANELS", "HISTORY"]

#: The page's pictures: the cameras as they come, then thesis Table 22's six
#: stages (SW[9:7] of the board's VGA output), then the trajectory.
PANELS = ("left camera", "right camera", "left", "right", "disparity", "skin", "band",
          "opening", "trajectory")
#: Frames of history the tracker and the recogniser look back over.
HISTORY = 900


#: Recognised gestures a session keeps (a looped clip or cameras run for days),
#: and the latest of them the page's state lists.
GESTURES_KEPT = 1000
PAGE_GESTURES = 20


def _slug(name: str) -> str:
    return name.replace(" ", "-")


class LiveSession:
    """Frame-by-frame golden model and recogniser.

    Parameters
    ----------
    params : sim.model.pipeline.PipelineParams
    models : sw_hps.hmm.GestureModels
    threads : int, optional
        Worker threads of the stereo cost stage.
    """

    def __init__(self, params, models, *, threads: int | None = None,
                 spotting: str = "thesis", width: int | None = None, posture_model=None):
        self.params, self.models, self.threads = params, models, threads
        self.posture_model = posture_model
        if spotting not in ("thesis", "continuous"):
            raise ValueError(f"spotting must be 'thesis' or 'continuous', got {spotting!r}")
        self.spotting = spotting
        self._spotter = None
        if spotting == "continuous":
            from sw_hps.streaming import StreamSpotter
            self._spotter = StreamSpotter(models, 640 if width is None else width)
        # thesis spotting: the posture commands the board's loop applies (the
        # streaming spotter applies them itself)
        self._commands = None
        self._stop_at = -1         # the frame the last stop by posture fired at
        if getattr(models, "postures", None) is not None:
            if posture_model is None:
                raise ValueError("the model file's postures entry needs a posture model")
            from sw_hps.posture_commands import PostureCommands, postures_for_frame
            postures = postures_for_frame(models.postures, 640 if width is None else width)
            if spotting == "thesis" and postures is not None:
                self._commands = PostureCommands(postures)
        self.lock = threading.Lock()
        self.frames = 0
        self.state = {"frame": -1, "fps": 0.0, "centroid": None, "flag": False, "posture": None,
                      "recognised": None, "telegram": None, "recognised_at": None,
                      "history": [], "gestures": [], "done": False, "error": None}
        self.pictures: dict[str, bytes] = {}
        self._cents: list = []
        self._following = {}       # the next frame's centroid gate and posture reference
        self._postures: list = []  # each frame's posture name (None: none), as _cents
        self._areas: list = []
        self._first = 0            # frame number of _cents[0]
        self._times: list = []
        self._was_flagged = False
        self._traj = None          # the last frame's trajectory (track() of the history)
        #: the latest GESTURES_KEPT recognised gestures (name, first and last
        #: flagged frame, telegram, score); the page's state has the latest PAGE_GESTURES
        self.gestures: list[dict] = []

    def step(self, left_bytes, right_bytes) -> dict:
        """Process one frame pair (4:2:2 byte streams); returns the new state."""
        import cv2

        from sim.footage import frame_to_bgr
        from sim.model.pipeline import process_frame, track, video_picture
        from sim.pictures import disparity_picture, trajectory_picture
        p = self.params
        stages = process_frame(left_bytes, right_bytes, p, threads=self.threads,
                               **self._following)
        self._following = stages.following()
        self._postures.append(self._posture(stages))
        self._cents.append((stages.centroid.x, stages.centroid.y))
        self._areas.append(stages.centroid.area)
        if len(self._cents) > HISTORY:
            drop = len(self._cents) - HISTORY
            del self._cents[:drop], self._areas[:drop], self._postures[:drop]
            self._first += drop
        n = self.frames
        if self._commands is not None and self._commands.take(n, self._postures[-1]):
            self._stopped(n, self._commands.stop_started)
        traj = track(np.array(self._cents, np.int64), np.array(self._areas, np.int64), p)
        self._traj = traj
        flag = bool(traj.flag[-1])
        if self._spotter is not None:     # every frame's record, as the board takes it
            x_fixed, y_fixed = (int(v) for v in traj.smoothed[-1])
            self._name(n, self._spotter.take(x_fixed, y_fixed, bool(stages.centroid.area),
                                             self._postures[-1]))
        else:
            ended = self._was_flagged and not flag
            self._was_flagged = flag
            if ended:
                self._recognise(traj, n)
        pictures = {"left camera": frame_to_bgr(left_bytes),
                    "right camera": frame_to_bgr(right_bytes)}
        bits = max(1, (p.max_disparity - 1).bit_length())
        for stage in ("left", "right", "skin", "band", "opening"):
            pictures[stage] = video_picture(stages, stage, bits)
        pictures["disparity"] = disparity_picture(stages.disparity, p.max_disparity)[:, :, ::-1]
        pictures["trajectory"] = trajectory_picture(stages.left, traj.smoothed, traj.flag,
                                                    p.frac_bits)[:, :, ::-1]
        encoded = {name: cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 85])[1]
                   .tobytes() for name, image in pictures.items()}
        now = time.perf_counter()
        self._times = [t for t in self._times if now - t < 2.0] + [now]
        scale = 1 << p.frac_bits
        x, y = traj.smoothed[-1] / scale
        with self.lock:
            self.frames += 1
            self.pictures = encoded
            self.state.update(
                frame=n, flag=flag, area=int(stages.centroid.area), posture=self._postures[-1],
                centroid=[round(float(x), 1), round(float(y), 1)] if stages.centroid.area
                else None,
                fps=round((len(self._times) - 1) / max(1e-9, now - self._times[0]), 1)
                if len(self._times) > 1 else 0.0)
            return dict(self.state)

    def _posture(self, stages):
        """The frame's posture by the posture model (None: no model, no
        record, no hand, or refused)."""
        from sw_hps.posture import record_posture
        if stages.posture is None or self.posture_model is None:
            return None
        return record_posture(self.posture_model, stages.posture_words())

    def _with_posture(self, entry: dict) -> dict:
        """``entry`` with the posture held over it (as it is without a model)."""
        from stereogest.pipeline_outputs import add_postures
        if self.posture_model is None:
            return entry
        return add_postures([entry], self._postures, first_frame=self._first)[0]

    def _recognise(self, traj, n: int) -> None:
        """The board application on the frames so far (a simulated FIFO): the
        gesture that just ended, named at frame ``n``."""
        from stereogest.pipeline_outputs import board_results
        results = board_results(self.models, traj, first_frame=self._first)
        if not results:
            return
        last = results[-1]
        entry = None
        if last["outcome"] == "recognised":
            entry = self._with_posture({key: last[key] for key in (
                "name", "first", "last", "telegram", "score")})
            if self._commands is not None:     # as the board's S3 judges it
                verdict = self._commands.judge(last["first"], last["last"])
                if not verdict.commands or last["first"] <= self._stop_at:
                    return
                from sw_hps.telegram import GESTURE_NAMES, telegram
                entry.update(posture=verdict.posture, posture_share=verdict.share,
                             power=verdict.power, telegram=telegram(
                                 last["name"], power=verdict.power).hex(" ")
                             if last["name"] in GESTURE_NAMES else None)
                last = dict(last, telegram=entry["telegram"])
        with self.lock:
            if entry is not None:
                self.gestures = self.gestures + [entry]
                self.state["gestures"] = self.gestures
                self.state.update(recognised=last["name"], telegram=last["telegram"],
                                  recognised_at=n)
            self.state["history"] = (self.state["history"] + [
                {"frame": n, "recognised": last["name"], "telegram": last["telegram"],
                 "first": last["first"], "last": last["last"]}])[-10:]

    def _stopped(self, n: int, first: int) -> None:
        """Thesis spotting: the stop posture held since ``first`` stops at ``n``
        (a gesture in progress is dropped, as the board drops it)."""
        self._stop_at = n
        self._name(n, [SimpleNamespace(name="stop", first=first, last=n, score=0.0,
                                       posture=self._commands.options["stop"], power=None,
                                       posture_share=None, by_posture=True)])

    def _name(self, n: int, detections) -> None:
        """The commands named at frame ``n`` (continuous spotting's, or a stop)."""
        from sw_hps.telegram import GESTURE_NAMES, telegram
        for d in detections:
            code = telegram(d.name, power=d.power).hex(" ") if d.name in GESTURE_NAMES else None
            entry = {"name": d.name, "first": d.first, "last": d.last, "telegram": code,
                     "score": round(float(d.score), 3)}
            if getattr(d, "posture_share", None) is not None or getattr(d, "by_posture", False):
                entry.update(posture=d.posture, posture_share=d.posture_share, power=d.power,
                             by_posture=d.by_posture)
            else:
                entry = self._with_posture(entry)
            with self.lock:
                self.gestures = (self.gestures + [entry])[-GESTURES_KEPT:]
                self.state["gestures"] = self.gestures[-PAGE_GESTURES:]
                self.state.update(recognised=d.name, telegram=code, recognised_at=n)
                self.state["history"] = (self.state["history"] + [
                    {"frame": n, "recognised": d.name, "telegram": code, "first": d.first,
                     "last": d.last}])[-10:]

    def end(self) -> None:
        """The source ended (a clip's or video's last frame, ``--frames``
        reached, Ctrl-C): a gesture still flagged ends here, as when the
        cameras hold the hand still (what ``stereogest pipeline`` does at a
        clip's end), and is named; continuous spotting names what is pending."""
        if self._spotter is not None:
            self._name(self.frames, self._spotter.flush())
            return
        if self._was_flagged and self._traj is not None:
            self._was_flagged = False
            self._recognise(self._traj, self.frames)

    def snapshot(self) -> tuple[dict, dict]:
        with self.lock:
            return dict(self.state), dict(self.pictures)

    def finish(self, error: str | None = None) -> None:
        with self.lock:
            self.state.update(done=True, error=error)


def run_source(session: LiveSession, pairs, *, fps: float | None = None,
               stop: threading.Event | None = None, on_frame=None) -> None:
    """Feed ``pairs`` (an iterable of 4:2:2 frame pairs) to ``session``, at most
    ``fps`` pairs per second (None: as fast as the model goes), until
    ``stop`` is set; the session is marked done (with the error, if any)."""
    error = None
    try:
        period = 1.0 / fps if fps else 0.0
        due = time.perf_counter()
        for left, right in pairs:
            if stop is not None and stop.is_set():
                break
            session.step(left, right)
            if on_frame is not None:
                on_frame(session)
            if period:
                due += period
                pause = due - time.perf_counter()
                if pause > 0:
                    time.sleep(pause)
                else:
                    due = time.perf_counter()
    except (ValueError, OSError) as exc:     # a source ends badly: say so on the page
        error = str(exc)
    finally:
        if error is None:
            session.end()
        session.finish(error)
    if error is not None:
        raise ValueError(error)


_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>stereogest live</title>
<style>
body {{ background: #181818; color: #eee; font: 14px sans-serif; margin: 12px; }}
h1 {{ font-size: 18px; margin: 0 0 8px 0; }}
#status {{ font-size: 16px; margin-bottom: 10px; }}
#gesture {{ font-size: 22px; color: #ff6a4d; font-weight: bold; }}
.grid {{ display: grid; grid-template-columns: repeat(3, {w}px); gap: 10px; }}
figure {{ margin: 0; }} figcaption {{ margin-bottom: 3px; }}
img {{ width: {w}px; height: {h}px; background: #333; display: block; }}
#panel-trajectory {{ height: auto; }}
</style></head><body>
<h1>stereogest live: golden model and recogniser, frame by frame</h1>
<div id="status">frame <span id="frame">-</span> &middot; <span id="fps">0</span> frames/s
&middot; <span id="flag">no gesture</span> &middot; centroid <span id="centroid">-</span>
&middot; posture <span id="posture">-</span></div>
<div>last recognised gesture: <span id="gesture">none yet</span>
<span id="telegram"></span></div>
<div>commands sent: <span id="commands">none yet</span></div><p></p>
<div class="grid">
{figures}
</div>
<script>
let shown = -1;
async function tick() {{
  try {{
    const r = await fetch('/state.json', {{cache: 'no-store'}});
    const s = await r.json();
    if (s.frame !== shown && s.frame >= 0) {{
      shown = s.frame;
      for (const img of document.querySelectorAll('img[data-panel]'))
        img.src = '/panel/' + img.dataset.panel + '.jpg?frame=' + s.frame;
    }}
    document.getElementById('frame').textContent = s.frame;
    document.getElementById('fps').textContent = s.fps;
    document.getElementById('flag').textContent = s.flag ? 'GESTURE' : 'no gesture';
    document.getElementById('centroid').textContent =
      s.centroid ? '(' + s.centroid[0] + ', ' + s.centroid[1] + ')' : '-';
    document.getElementById('posture').textContent = s.posture || '-';
    if (s.recognised_at !== null) {{
      document.getElementById('gesture').textContent = s.recognised || 'none';
      document.getElementById('telegram').textContent =
        s.telegram ? ' (NXT telegram ' + s.telegram + ', frame ' + s.recognised_at + ')' : '';
    }}
    if (s.gestures.length)
      document.getElementById('commands').textContent = s.gestures.map(
        g => g.name + ' (frames ' + g.first + '-' + g.last
             + (g.posture ? ', ' + g.posture : '')
             + (g.power !== undefined && g.power !== null ? ', power ' + g.power : '')
             + (g.by_posture ? ', stop posture' : '') + ')').join(', ');
    if (s.error) document.getElementById('status').textContent = 'stopped: ' + s.error;
  }} catch (e) {{}}
  setTimeout(tick, 100);
}}
tick();
</script></body></html>
"""


class LiveServer:
    """The page of a :class:`LiveSession` on ``127.0.0.1:port`` (0: any free
    port; :attr:`port` says which), served from a background thread."""

    def __init__(self, session: LiveSession, width: int, height: int, port: int = 8642):
        from sim.model.validation import check_int
        check_int("--port", port, 0, 65535)
        page = _PAGE.format(w=width, h=height, figures="\n".join(
            f'<figure><figcaption>{name}</figcaption><img id="panel-{_slug(name)}" '
            f'data-panel="{_slug(name)}" alt="{name}"></figure>' for name in PANELS)).encode()
        names = {_slug(name): name for name in PANELS}

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):                  # noqa: N802 (the http.server API)
                path = self.path.split("?", 1)[0]
                state, pictures = session.snapshot()
                if path in ("/", "/index.html"):
                    return self._send(page, "text/html; charset=utf-8")
                if path == "/state.json":
                    return self._send(json.dumps(state).encode(), "application/json")
                if path.startswith("/panel/") and path.endswith(".jpg"):
                    name = names.get(path[len("/panel/"):-len(".jpg")])
                    if name is not None and name in pictures:
                        return self._send(pictures[name], "image/jpeg")
                self.send_error(HTTPStatus.NOT_FOUND)

            def _send(self, body: bytes, kind: str):
                self.send_response(HTTPStatus.OK)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):    # quiet: the command prints its own lines
                pass

        class Server(ThreadingHTTPServer):
            daemon_threads = True

            def handle_error(self, request, client_address):
                # A page closed or reloaded mid-response is no error; anything
                # else is one line, not socketserver's traceback per request.
                error = sys.exc_info()[1]
                if not isinstance(error, (ConnectionError, TimeoutError)):
                    print(f"live page: request from {client_address[0]} failed: "
                          f"{type(error).__name__}: {error}", file=sys.stderr, flush=True)

        try:
            self.httpd = Server(("127.0.0.1", port), Handler)
        except OSError as exc:
            raise ValueError(f"--port: cannot listen on 127.0.0.1:{port} ({exc.strerror})") \
                from None
        self.port = self.httpd.server_address[1]
        self.url = f"http://127.0.0.1:{self.port}/"
        self._thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
