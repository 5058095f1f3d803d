"""The supervisor of the board application (sw_hps.guard; `python -m sw_hps` for the
mapped buses): a real SIGBUS becomes one line and exit status 1 (or a retry),
SIGINT/SIGTERM reach the application, SIGHUP reloads a good model file and keeps
the running application on a bad one, the child's exit status passes through.

The SIGBUS is real: the bus maps a temporary file (a plain file stands in for a
UIO device; DevMemBus takes one as its path) and the test truncates it to 0
bytes, so the next load from the mapping faults as a dead bridge does.
"""
import os
import queue
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from soc.hps_interface import CONTROL, CORE_MAGIC, ID, VERSION, version_word
from sw_hps.__main__ import WINDOW_SPAN, main, parse_args
from sw_hps.busfault import CHECK_HINT, LIKELY_CAUSE
from sw_hps.guard import MAX_FAULT_RETRIES, supervise
from tests.test_hps_app import model_file  # noqa: F401  (a fixture)

REPO = Path(__file__).resolve().parents[1]
#: Seconds any one expected event may take (the machine may be busy).
PATIENCE = 30.0

pytestmark = pytest.mark.skipif(not hasattr(signal, "sigwaitinfo"),
                                reason="the guard needs POSIX signals (sigwaitinfo)")


def core_image(magic=CORE_MAGIC):
    """The register window of an idle stereogest core, as a file's bytes."""
    words = bytearray(WINDOW_SPAN)
    for offset, value in ((ID, magic), (VERSION, version_word())):
        words[offset:offset + 4] = value.to_bytes(4, "little")
    return bytes(words)


def control_word(path):
    data = Path(path).read_bytes()
    return int.from_bytes(data[CONTROL:CONTROL + 4], "little") if len(data) >= 16 else None


def environment():
    env = dict(os.environ, PYTHONPATH=str(REPO))
    env.pop("PYTHONFAULTHANDLER", None)   # the point is that nothing but our line appears
    return env


class Running:
    """A subprocess whose stderr lines are collected by a thread, so that the test
    can wait for one without blocking forever."""

    def __init__(self, argv):
        self.process = subprocess.Popen(argv, cwd=str(REPO), env=environment(),
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                        universal_newlines=True)
        self.lines = []
        self._queue = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.process.stderr:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def wait_for(self, text, timeout=PATIENCE, nth=None):
        """The next line containing ``text`` (earlier lines are kept in ``lines``);
        with ``nth``, the nth such line since the start, which may have been read
        already: the parent's and the child's lines reach the pipe in either order."""
        if nth is not None:
            seen = [line for line in self.lines if text in line]
            if len(seen) >= nth:
                return seen[nth - 1]
            for _ in range(nth - len(seen) - 1):
                self.wait_for(text, timeout)
        end = time.monotonic() + timeout
        while True:
            try:
                line = self._queue.get(timeout=max(0.0, end - time.monotonic()))
            except queue.Empty:
                raise AssertionError(f"no line with {text!r} within {timeout} s; got "
                                     f"{self.lines}") from None
            if line is None:
                raise AssertionError(f"stderr ended without {text!r}: {self.lines}")
            self.lines.append(line)
            if text in line:
                return line

    def finish(self, timeout=PATIENCE):
        """Exit status and every stderr line."""
        try:
            self.process.wait(timeout=timeout)
        finally:
            if self.process.poll() is None:
                self.process.kill()
        self._reader.join(timeout=5)
        while True:
            line = self._queue.get_nowait() if not self._queue.empty() else None
            if line is None:
                break
            self.lines.append(line)
        self.process.stdout.close()
        return self.process.returncode, self.lines


@pytest.fixture
def device(tmp_path):
    """A plain file standing in for /dev/uio0: an idle core's registers."""
    path = tmp_path / "uio0"
    path.write_bytes(core_image())
    return path


def start_app(model_file, device, *options):
    return Running([sys.executable, "-m", "sw_hps", "--model", str(model_file), "--bus", "uio",
                    "--uio", str(device), "--robot", "none", "--poll-ms", "1", *options])


def wait_until(condition, what, timeout=PATIENCE):
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise AssertionError(f"{what} did not happen within {timeout} s")
        time.sleep(0.02)


def test_sigbus_on_the_bridge_is_one_line_and_status_1(model_file, device):
    app = start_app(model_file, device, "--log-level", "error")
    # The child wrote Control (FIFO-CLR | GO): it is running and polling the file.
    wait_until(lambda: control_word(device) not in (None, 0), "the first write to Control")
    os.truncate(str(device), 0)                   # the next load from the mapping faults
    status, lines = app.finish()
    assert status == 1, lines
    (line,) = lines
    assert "died of SIGBUS" in line and "a bus error on --bus uio, %s map 0" % device in line
    assert LIKELY_CAUSE in line and CHECK_HINT in line and "exiting with status 1" in line
    assert not any("Traceback" in x or "Fatal Python error" in x for x in lines)


def test_a_fault_retry_starts_the_application_again(model_file, device):
    app = start_app(model_file, device, "--fault-retries", "1")
    first = app.wait_for("application started (process", nth=1)
    app.wait_for("running: bus uio", nth=1)
    os.truncate(str(device), 0)
    fault = app.wait_for("died of SIGBUS")
    device.write_bytes(core_image())              # the bridge is back before the retry
    assert "starting it again in 1 s (fault retry 1 of 1)" in fault
    second = app.wait_for("application started (process", nth=2)
    assert second != first
    app.wait_for("running: bus uio", nth=2)
    app.process.send_signal(signal.SIGTERM)
    status, lines = app.finish()
    assert status == 0, lines
    assert [x for x in lines if " ERROR " in x] == [fault]


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_stop_signals_reach_the_application(model_file, device, signum):
    app = start_app(model_file, device)
    pid = int(app.wait_for("application started (process", nth=1).split("process ")[1]
              .rstrip(")"))
    app.wait_for("running: bus uio", nth=1)
    app.process.send_signal(signum)
    app.wait_for("signal %d: stopping" % signum)  # the child's own handler got it
    status, lines = app.finish()
    assert status == 0, lines
    assert not any(" ERROR " in x or "Traceback" in x for x in lines)
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)                           # the child is gone, and reaped


def test_sighup_reloads_a_good_model_file_and_keeps_running_on_a_bad_one(model_file, device):
    app = start_app(model_file, device)
    first = int(app.wait_for("application started (process", nth=1).split("process ")[1]
                .rstrip(")"))
    app.wait_for("running: bus uio", nth=1)
    app.process.send_signal(signal.SIGHUP)
    app.wait_for("SIGHUP: model file checked; restarting the application", nth=1)
    second = int(app.wait_for("application started (process", nth=2).split("process ")[1]
                 .rstrip(")"))
    app.wait_for("running: bus uio", nth=2)
    assert second != first
    model_file.write_text("{}")                   # broken: refused, the child goes on
    app.process.send_signal(signal.SIGHUP)
    refused = app.wait_for("SIGHUP: not reloaded")
    assert "the running application keeps its model" in refused and str(model_file) in refused
    time.sleep(0.5)
    os.kill(second, 0)                            # still running
    app.process.send_signal(signal.SIGTERM)
    status, lines = app.finish()
    assert status == 0, lines
    assert sum("application started" in x for x in lines) == 2
    assert [x for x in lines if " ERROR " in x] == [refused]


def test_the_childs_exit_status_passes_through(model_file, device):
    device.write_bytes(core_image(magic=0))       # no ID: the start-up check refuses it
    app = start_app(model_file, device)
    status, lines = app.finish()
    assert status == 1, lines
    errors = [x for x in lines if "error" in x.lower()]
    assert len(errors) == 1 and "ID reads 0" in errors[0] and "died of" not in errors[0]


GUARDED = textwrap.dedent("""
    import logging, os, signal, sys, time
    from sw_hps.bus import DevMemBus
    from sw_hps.busfault import describe_bus
    from sw_hps.guard import supervise
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    bus = DevMemBus(base=0, offset=0x1000, span=0x1000, path=sys.argv[1])

    def serve(_):
        how = sys.argv[2]
        if how == "exit":
            return 3
        if how == "kill":
            os.kill(os.getpid(), signal.SIGKILL)
        logging.info("serving")
        while True:
            bus.read32(0x0C)
            time.sleep(0.001)

    sys.exit(supervise(serve, where=describe_bus(bus)))
""")


@pytest.mark.parametrize("how", ["fault", "exit", "kill"])
def test_supervise_a_devmem_bus(tmp_path, how):
    memory = tmp_path / "mem"
    memory.write_bytes(bytes(0x3000))
    script = tmp_path / "guarded.py"
    script.write_text(GUARDED)
    app = Running([sys.executable, str(script), str(memory), how])
    if how == "fault":
        app.wait_for("serving")
        os.truncate(str(memory), 0)
    status, lines = app.finish()
    errors = [x for x in lines if x.startswith("ERROR")]
    if how == "fault":
        assert status == 1 and len(errors) == 1
        assert "died of SIGBUS" in errors[0]
        assert "%s window 0x00001000-0x00001fff" % memory in errors[0]
    elif how == "exit":
        assert status == 3 and errors == []
    else:
        assert status == 1 and len(errors) == 1 and "killed by SIGKILL" in errors[0]


@pytest.mark.parametrize("value, message", [
    ("-1", "argument --fault-retries: must be in [0, %d], got -1" % MAX_FAULT_RETRIES),
    ("1001", "argument --fault-retries: must be in [0, %d], got 1001" % MAX_FAULT_RETRIES),
    ("x", "argument --fault-retries: invalid int value: 'x'")])
def test_bad_fault_retries_is_one_line(model_file, capsys, value, message):
    code = main(["--model", str(model_file), "--bus", "uio", "--robot", "none",
                 "--fault-retries", value])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err


def test_fault_retries_only_with_a_mapped_bus(model_file, capsys):
    base = ["--model", str(model_file), "--robot", "none"]
    assert parse_args(base + ["--bus", "devmem", "--fault-retries", "5"]).fault_retries == 5
    assert parse_args(base + ["--bus", "sim"]).fault_retries == 0
    assert main(base + ["--bus", "sim", "--fault-retries", "2"]) == 2
    assert "--fault-retries: only with --bus devmem or uio" in capsys.readouterr().err
    with pytest.raises(ValueError, match="fault_retries must be an int in"):
        supervise(lambda _: 0, where="x", fault_retries=-1)


def _uid_of(pid):
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("Uid:"):
            return {int(x) for x in line.split()[1:]}
    raise AssertionError(f"no Uid line for process {pid}")


needs_root_and_nobody = pytest.mark.skipif(
    os.geteuid() != 0 or not Path("/proc/self/status").exists()
    or "nobody" not in Path("/etc/passwd").read_text(),
    reason="--user is exercised as root, switching to the user 'nobody' (Linux)")


@needs_root_and_nobody
def test_user_gives_up_root_once_the_device_is_mapped(tmp_path, model_file):
    import pwd
    nobody = pwd.getpwnam("nobody").pw_uid
    import shutil
    import tempfile
    shared = Path(tempfile.mkdtemp(dir="/tmp"))       # outside tmp_path, which is root's alone
    shared.chmod(0o755)
    try:
        model = shared / "model.json"
        model.write_bytes(model_file.read_bytes())
        model.chmod(0o644)
        device = shared / "uio0"                      # root's alone, as /dev/mem is
        device.write_bytes(core_image())
        device.chmod(0o600)
        app = start_app(model, device, "--user", "nobody")
        app.wait_for("running as user nobody")
        child = int(app.wait_for("application started (process", nth=1).split("process ")[1]
                    .rstrip(")"))
        app.wait_for("running: bus uio", nth=1)
        assert _uid_of(app.process.pid) == {nobody} and _uid_of(child) == {nobody}
        app.process.send_signal(signal.SIGHUP)        # the model is read again, as nobody
        app.wait_for("running: bus uio", nth=2)
        app.process.send_signal(signal.SIGTERM)
        status, lines = app.finish()
        assert status == 0 and not [x for x in lines if " ERROR " in x], lines
    finally:
        shutil.rmtree(shared)


@needs_root_and_nobody
def test_user_who_cannot_read_the_model_is_refused_at_start(tmp_path, model_file, device):
    import grp
    import pwd
    group = grp.getgrgid(pwd.getpwnam("nobody").pw_gid).gr_name
    tmp_path.chmod(0o700)                             # nobody cannot enter it
    app = start_app(model_file, device, "--user", "nobody")
    status, lines = app.finish()
    assert status == 1
    assert lines == [f"python -m sw_hps: error: argument --user: 'nobody' cannot read "
                     f"{model_file}: install the application where nobody:{group} can read "
                     f"it (e.g. /opt/stereogest), or leave --user out"]
