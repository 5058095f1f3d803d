"""Soak of the live page under load: ``stereogest live --clip CLIP --loop`` (a
rendered gesture at 320x240, replayed without end) with ``--clients`` clients
that poll it as the page does (``/state.json`` every 100 ms after the last
answer, the nine panels whenever the frame changed) for ``--minutes``, while
a misbehaving client keeps sending what a browser never sends: requests cut
off mid-line, connections closed in the middle of a response, malformed
request lines, methods the page does not serve, paths that do not exist, an
over-long line.

Reported: the server's frame rate (its own ``fps``, sampled every second:
median and lowest, and frames per wall second over the run; the first
``--warm-up`` seconds left out), its resident memory and open descriptors
after warm-up and at the end, good requests answered and failed (every good
request must be answered), what the server answered to the bad ones, and
that Ctrl-C still ends it with status 0.

Run: ``python benchmarks/soak_live.py [--minutes 10] [--clients 20]``; the
last line of output is JSON.
"""
from __future__ import annotations

import argparse
import http.client
import json
import os
import random
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: The page's polling period (the script in stereogest/live.py waits 100 ms).
POLL = 0.1
#: Growth of the server's memory the run accepts, MB.
MAX_RSS_GROWTH_MB = 2.0


def _clip(cache: Path) -> Path:
    """A rendered gesture kept in ``cache`` (rendered once)."""
    from sim.clip import is_clip_dir, save_clip
    from sim.render import render_clip
    cache.mkdir(parents=True, exist_ok=True)
    path = cache / "rotate-right-320x240"
    if not is_clip_dir(path):
        save_clip(render_clip("rotate-right", 1, 320, 240, n_pre_rest=10), path)
    return path


def _proc(pid: int):
    """(resident MB, open descriptors) of a process."""
    with open(f"/proc/{pid}/statm") as handle:
        rss = int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    return rss, len(os.listdir(f"/proc/{pid}/fd"))


class Client(threading.Thread):
    """One open page: state, then the panels when the frame changed."""

    def __init__(self, port: int, panels, until: float, counts, lock):
        super().__init__(daemon=True)
        self.port, self.panels, self.until = port, panels, until
        self.counts, self.lock = counts, lock

    def _get(self, path: str):
        connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        try:
            connection.request("GET", path)
            response = connection.getresponse()
            body = response.read()
            ok = response.status == 200 and len(body) > 0
        except (OSError, http.client.HTTPException):
            ok, body = False, b""
        finally:
            connection.close()
        with self.lock:
            self.counts["good" if ok else "failed"] += 1
        return body if ok else None

    def run(self):
        shown = None
        while time.monotonic() < self.until:
            body = self._get("/state.json")
            if body is not None:
                frame = json.loads(body)["frame"]
                if frame != shown and frame >= 0:
                    shown = frame
                    for panel in self.panels:
                        self._get(f"/panel/{panel}.jpg?frame={frame}")
            time.sleep(POLL)


BAD_REQUESTS = {
    "cut off mid-line": b"GET /state.js",
    "malformed request line": b"GARBAGE\r\n\r\n",
    "bad version": b"GET / HTTP/9.9\r\n\r\n",
    "POST": b"POST /state.json HTTP/1.0\r\nContent-Length: 3\r\n\r\nabc",
    "unknown path": b"GET /../../etc/passwd HTTP/1.0\r\n\r\n",
    "unknown panel": b"GET /panel/nothing.jpg HTTP/1.0\r\n\r\n",
    "over-long line": b"GET /" + b"a" * 70000 + b" HTTP/1.0\r\n\r\n",
    "not UTF-8": b"GET /\xff\xfe HTTP/1.0\r\n\r\n",
}


def _bad_client(port: int, until: float, answers, lock, rng: random.Random):
    """Bad requests one after another, and good ones dropped mid-response."""
    while time.monotonic() < until:
        kind = rng.choice(list(BAD_REQUESTS) + ["closed mid-response"])
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
                if kind == "closed mid-response":
                    sock.sendall(b"GET /panel/left-camera.jpg HTTP/1.0\r\n\r\n")
                    sock.recv(64)                      # the first bytes, then gone
                    answer = "closed by us"
                else:
                    sock.sendall(BAD_REQUESTS[kind])
                    if kind == "cut off mid-line":
                        sock.shutdown(socket.SHUT_WR)
                    reply = sock.recv(64)
                    if reply.startswith(b"<!DOCTYPE"):   # no status line: an HTTP/0.9 error
                        answer = "error page without a status line"
                    else:
                        answer = reply.split(b"\r\n")[0].decode("latin-1")[:40] or "closed"
        except OSError as exc:
            answer = f"{type(exc).__name__}"
        with lock:
            answers.setdefault(kind, {}).setdefault(answer, 0)
            answers[kind][answer] += 1
        time.sleep(0.2)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=10.0,
                    help="length of the run under load (default 10)")
    ap.add_argument("--clients", type=int, default=20, help="pages polling (default 20)")
    ap.add_argument("--warm-up", type=float, default=30.0, metavar="SECONDS",
                    help="seconds left out of the figures at the start (default 30)")
    ap.add_argument("--cache", default=str(Path(os.environ.get("STEREOGEST_BUILD_DIR",
                                                               ROOT / "build")) / "soak_live"),
                    help="where the rendered clip is kept (default build/soak_live)")
    ap.add_argument("--max-rss-growth", type=float, default=MAX_RSS_GROWTH_MB, metavar="MB",
                    help=f"memory growth under load the run accepts (default "
                    f"{MAX_RSS_GROWTH_MB:g}; a run of a minute or two still measures warming up)")
    ap.add_argument("--json", help="also write the report to this file")
    args = ap.parse_args(argv)
    if not 0.1 <= args.minutes <= 24 * 60:
        ap.error(f"--minutes must be in [0.1, 1440], got {args.minutes}")
    if not 0 <= args.clients <= 200:
        ap.error(f"--clients must be in 0..200, got {args.clients}")
    if not 0 <= args.warm_up < args.minutes * 60:
        ap.error(f"--warm-up must be in [0, the run's length), got {args.warm_up}")
    if not 0 <= args.max_rss_growth <= 1000:
        ap.error(f"--max-rss-growth must be in [0, 1000] MB, got {args.max_rss_growth}")
    if not Path("/proc/self/statm").exists():
        ap.error("the soak reads the server's memory and descriptors from /proc (Linux)")

    from stereogest.live import PANELS, _slug
    clip = _clip(Path(args.cache))
    server = subprocess.Popen(
        [sys.executable, "-m", "stereogest", "live", "--clip", str(clip), "--loop", "--port",
         "0", "--quiet"], cwd=str(ROOT), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)),
        # Ctrl-C as in a terminal, even when this runs in the background (which
        # ignores SIGINT, and Python then keeps it ignored)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        first = server.stdout.readline()
        if " on http://127.0.0.1:" not in first:
            raise SystemExit(f"soak_live: the server did not start: {first!r} "
                             f"{server.stderr.read()[-500:]!r}")
        port = int(first.split("http://127.0.0.1:")[1].split("/")[0])
        # Drain both pipes: a full pipe would stall the server, not the load.
        output = {"stdout": [], "stderr": []}

        def drain(stream, lines):
            for line in stream:
                lines.append(line.rstrip("\n"))
        for name in ("stdout", "stderr"):
            threading.Thread(target=drain, daemon=True,
                             args=(getattr(server, name), output[name])).start()
        started = time.monotonic()
        until = started + 60 * args.minutes
        warm = started + args.warm_up
        counts = {"good": 0, "failed": 0}
        answers: dict = {}
        lock = threading.Lock()
        panels = [_slug(name) for name in PANELS]
        workers = [Client(port, panels, until, counts, lock) for _ in range(args.clients)]
        workers.append(threading.Thread(target=_bad_client, daemon=True,
                                        args=(port, until, answers, lock, random.Random(1))))
        time.sleep(2.0)
        _, fds_before = _proc(server.pid)              # before the load
        for worker in workers:
            worker.start()
        fps, samples, at_warm = [], [], None
        probe = http.client.HTTPConnection
        while time.monotonic() < until and server.poll() is None:
            time.sleep(1.0)
            now = time.monotonic()
            try:
                connection = probe("127.0.0.1", port, timeout=30)
                connection.request("GET", "/state.json")
                state = json.loads(connection.getresponse().read())
                connection.close()
            except (OSError, http.client.HTTPException, ValueError):
                continue
            rss, fds = _proc(server.pid)
            samples.append((now, state["frame"], rss, fds))
            if now >= warm:
                fps.append(state["fps"])
                if at_warm is None:
                    at_warm = samples[-1]
        for worker in workers:
            worker.join(timeout=60)
        alive = server.poll() is None
        time.sleep(2.0)
        rss_after, fds_after = _proc(server.pid) if alive else (None, None)   # load gone
        end = samples[-1] if samples else None
        server.send_signal(signal.SIGINT)                 # Ctrl-C
        try:
            status = server.wait(timeout=60)
        except subprocess.TimeoutExpired:
            server.kill()
            status = None
    finally:
        if server.poll() is None:
            server.kill()
    if at_warm is None or end is None:
        raise SystemExit("soak_live: no sample after the warm-up (a run too short?)")
    wall = end[0] - at_warm[0]
    report = {
        "minutes": args.minutes, "clients": args.clients, "warm_up_s": args.warm_up,
        "server_alive_to_the_end": alive, "exit_status_after_ctrl_c": status,
        "fps_median": round(statistics.median(fps), 1) if fps else None,
        "fps_lowest": min(fps) if fps else None,
        "frames_per_wall_second": round((end[1] - at_warm[1]) / wall, 2) if wall > 0 else None,
        "good_requests": counts["good"], "failed_good_requests": counts["failed"],
        "good_requests_per_second": round(counts["good"] / (60 * args.minutes), 1),
        "bad_requests": answers,
        "rss_warm_mb": round(at_warm[2], 2), "rss_end_mb": round(end[2], 2),
        "rss_growth_mb": round(end[2] - at_warm[2], 2),
        "rss_after_load_mb": None if rss_after is None else round(rss_after, 2),
        "fd_before_load": fds_before, "fd_after_load": fds_after,
        "server_stderr_lines": len(output["stderr"]), "server_stderr_first": output["stderr"][:3],
    }
    report["passed"] = bool(alive and status == 0 and counts["failed"] == 0
                            and not output["stderr"]
                            and report["rss_growth_mb"] <= args.max_rss_growth
                            and fds_after == fds_before)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    print(f"{args.clients} clients for {args.minutes:g} min: {report['fps_median']} frames/s "
          f"median ({report['fps_lowest']} lowest; {report['frames_per_wall_second']} per wall "
          f"second), {counts['good']} good requests answered, {counts['failed']} failed; "
          f"rss {report['rss_warm_mb']} -> {report['rss_end_mb']} MB under load, fds "
          f"{fds_before} before the load and {fds_after} after; exit status {status} after "
          f"Ctrl-C", flush=True)
    print(json.dumps(report))
    return 0 if report["passed"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
