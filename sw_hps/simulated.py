"""In-process models of the FPGA slaves, and the unmodified board application
run against them, for tests and for running without a board (thesis §7.4.1,
Tables 12-13; ``python -m sw_hps --bus sim``).

Runs on the board's ARM too: Python 3 and numpy only (and the shared
:mod:`soc.hps_interface`).

:class:`SimulatedFifoPeripheral` has exactly the register semantics of
:data:`soc.hps_interface.FIFO_REGISTERS` described in :mod:`sw_hps.fifo`;
:class:`SimulatedUart` those of :data:`soc.hps_interface.UART_REGISTERS`. Both implement ``read32`` / ``write32`` (offsets relative to
their own base), so :class:`sw_hps.bus.SimBus` can wrap them.

Time (video frames) in the FIFO model
-------------------------------------
The hardware pushes one pair per video frame; the model advances one frame when

* a test calls :meth:`SimulatedFifoPeripheral.push_frame` (that frame's values), or
* a test calls :meth:`SimulatedFifoPeripheral.step` (the next frame of a trajectory
  queued with :meth:`~SimulatedFifoPeripheral.queue_trajectory`; once the queue is
  empty a step is an idle frame whose spotting flag is 0), or
* ``reads_per_frame = N`` is set: every N-th read of the Control register first
  steps one frame. The board application reads Control exactly once per poll (in
  :meth:`sw_hps.fifo.FifoPeripheral.status`), so ``N = 1`` means "one video frame
  between two polls", ``N = 3`` "the ARM polls three times per frame". This is how
  the unmodified application is run against a whole trajectory.
"""
from __future__ import annotations

import csv
import logging
from collections import deque
from pathlib import Path
from typing import Callable

import numpy as np

from .app import GestureApp, GestureResult, State
from .bus import SimBus
from .fifo import (CONTROL, CORE_MAGIC, CTRL_FIFO_CLR, CTRL_FIFO_DATA, CTRL_FIFO_FULL, CTRL_GO,
                   CTRL_NO_GESTURE, CTRL_STREAM, DATA_MASK, DATO_X, DATO_X_FLAG, DATO_Y,
                   DATO_Y_PRESENT, FIFO_DEPTH, FRAME_HEIGHT as FIFO_FRAME_HEIGHT,
                   FRAME_WIDTH as FIFO_FRAME_WIDTH, ID, LONGITUD_X, LONGITUD_Y, REGISTER_SPAN,
                   VERSION, FifoPeripheral, to_fixed)
from .hmm import GestureModels
from soc.hps_interface import (POSTURE_DATA, POSTURE_INDEX, POSTURE_LAYOUT, POSTURE_SPAN,
                               POSTURE_STATUS, POSTURE_WORD_COUNT, UART_RXDATA, UART_SPAN,
                               UART_STATUS, UART_STATUS_RX_VALID, UART_STATUS_TX_READY,
                               UART_TXDATA, posture_layout_word, version_word)

from .robot import RN42_GUARD_TIME, NullLink, normalise_bt_address
from .telegram import NXT_DIRECT_NO_REPLY, NXT_MESSAGEWRITE, NXT_REPLY

__all__ = ["SimulatedFifoPeripheral", "SimulatedUart", "SimulatedPostureSlave", "SimulatedRn42", "read_trajectory_csv",
           "SimulatedClock", "SimulationRun", "simulate_trajectory", "run_on_trajectory",
           "streaming_words", "simulate_stream", "run_stream"]

log = logging.getLogger(__name__)


def _check_raw(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or not 0 <= int(value) <= DATA_MASK:
        raise ValueError(f"{name} must be an int in [0, {DATA_MASK}] (10.8 fixed point), "
                         f"got {value!r}")
    return int(value)


class SimulatedFifoPeripheral:
    """Software model of the FIFO slave (register map in :mod:`sw_hps.fifo`).

    Parameters
    ----------
    depth : int >= 1
        Entries per FIFO (the hardware has :data:`soc.hps_interface.FIFO_DEPTH`;
        its depths are powers of two, the model takes any depth, and its
        Version register then reports the power of two below).
    reads_per_frame : int >= 1 or None
        If set, every ``reads_per_frame``-th read of Control steps one frame first
        (see the module docstring). ``None``: frames advance only when the test
        calls :meth:`push_frame` or :meth:`step`.
    frame_width, frame_height : int in [1, 2040]
        Frame size the Version register reports, as the hardware's
        :class:`soc.fifo_slave.FifoSlave` parameters of the same names.

    Attributes
    ----------
    version : int
        What the Version register reads (ID reads :data:`soc.hps_interface.CORE_MAGIC`).
    frames : int
        Video frames seen so far.
    streaming : bool
        Control.STREAM: every frame is pushed.
    dropped : int
        Pairs dropped because a FIFO was full.
    clears : int
        FIFO-CLR writes received.
    """

    span = REGISTER_SPAN

    def __init__(self, depth: int = FIFO_DEPTH, reads_per_frame: int | None = None, *,
                 frame_width: int = FIFO_FRAME_WIDTH, frame_height: int = FIFO_FRAME_HEIGHT):
        if isinstance(depth, bool) or not isinstance(depth, int) or depth < 1:
            raise ValueError(f"depth must be an int >= 1, got {depth!r}")
        # the hardware implements the streaming mode, and so does this model
        self.version = version_word(fifo_depth=depth, streaming=True,
                                    frame_width=frame_width, frame_height=frame_height)
        if reads_per_frame is not None and (isinstance(reads_per_frame, bool)
                                            or not isinstance(reads_per_frame, int)
                                            or reads_per_frame < 1):
            raise ValueError(f"reads_per_frame must be None or an int >= 1, "
                             f"got {reads_per_frame!r}")
        self.depth = depth
        self.reads_per_frame = reads_per_frame
        self.go = False
        self.streaming = False
        self.flag = False
        self.full = False
        self.fifo_x: deque[int] = deque()
        self.fifo_y: deque[int] = deque()
        self._pending: deque[tuple[int, int, bool, bool]] = deque()
        self._control_reads = 0
        self._last = None           # the last frame's (x, y, present)
        self.frames = 0
        self.dropped = 0
        self.clears = 0

    # ---- the video side ---------------------------------------------------------
    def push_frame(self, x_fixed: int, y_fixed: int, flag, present=True) -> None:
        """One video frame: centroid (10.8 fixed point), spotting flag and
        whether the frame saw a hand.

        With GO set and ``flag`` true the pair is pushed (thesis mode); in
        streaming mode (STREAM set) every frame is pushed, with ``flag`` in
        Dato_X's FLAG bit and ``present`` in Dato_Y's PRESENT bit. A push into
        a full FIFO is dropped, setting FIFO-FULL; the gesture bit follows
        ``flag``.
        """
        x_fixed = _check_raw("x_fixed", x_fixed)
        y_fixed = _check_raw("y_fixed", y_fixed)
        self._last = (x_fixed, y_fixed, bool(present))
        self.frames += 1
        self.flag = bool(flag)
        if not (self.go and (self.flag or self.streaming)):
            return
        if len(self.fifo_x) >= self.depth or len(self.fifo_y) >= self.depth:
            self.full = True
            self.dropped += 1
            return
        if self.streaming:
            x_fixed |= DATO_X_FLAG if self.flag else 0
            y_fixed |= DATO_Y_PRESENT if present else 0
        self.fifo_x.append(x_fixed)
        self.fifo_y.append(y_fixed)

    def queue_trajectory(self, x, y, flag, *, pixels: bool = False, present=None) -> None:
        """Append frames to be played by :meth:`step` (or by Control reads).

        Parameters
        ----------
        x, y : (T,) arrays
            Centroid per frame: 10.8 fixed-point integers, or pixels if ``pixels``.
        flag : (T,) array
            Spotting flag per frame (non-zero = gesture in progress).
        present : (T,) array, optional
            Whether each frame saw a hand (the centroid's area > 0; streaming
            mode's PRESENT bit); every frame by default.
        """
        x = np.asarray(x).reshape(-1)
        y = np.asarray(y).reshape(-1)
        flag = np.asarray(flag).reshape(-1)
        present = np.ones(len(x), bool) if present is None else np.asarray(present).reshape(-1)
        if not len(x) == len(y) == len(flag) == len(present):
            raise ValueError(f"x, y, flag and present must have the same length, got "
                             f"{len(x)}, {len(y)}, {len(flag)}, {len(present)}")
        for n in range(len(x)):
            if pixels:
                fx, fy = to_fixed(x[n]), to_fixed(y[n])
            else:
                fx, fy = _check_raw("x", x[n]), _check_raw("y", y[n])
            self._pending.append((fx, fy, bool(flag[n]), bool(present[n])))

    @property
    def frames_pending(self) -> int:
        """Queued frames not yet played."""
        return len(self._pending)

    def step(self, frames: int = 1) -> int:
        """Play ``frames`` queued frames (idle frames, flag 0, once the queue is
        empty, holding the last centroid: in streaming mode they are pushed, as
        the hardware pushes every frame of cameras that see a still hand).
        Returns how many queued frames were played."""
        played = 0
        for _ in range(frames):
            if self._pending:
                self.push_frame(*self._pending.popleft())
                played += 1
            elif self.streaming and self._last is not None:
                self.push_frame(*self._last[:2], False, self._last[2])
            else:
                self.frames += 1
                self.flag = False
        return played

    # ---- the bus side -----------------------------------------------------------
    def control(self) -> int:
        """Control word as the hardware would return it (no side effect)."""
        value = 0
        if self.go:
            value |= CTRL_GO
        if self.fifo_x and self.fifo_y:
            value |= CTRL_FIFO_DATA
        if not (self.go and self.flag):
            value |= CTRL_NO_GESTURE
        if self.full:
            value |= CTRL_FIFO_FULL
        if self.streaming:
            value |= CTRL_STREAM
        return value

    def read32(self, offset: int) -> int:
        if offset == DATO_X:
            return self.fifo_x.popleft() if self.fifo_x else 0
        if offset == DATO_Y:
            return self.fifo_y.popleft() if self.fifo_y else 0
        if offset == CONTROL:
            if self.reads_per_frame is not None:
                self._control_reads += 1
                if self._control_reads >= self.reads_per_frame:
                    self._control_reads = 0
                    self.step()
            return self.control()
        if offset == LONGITUD_X:
            return len(self.fifo_x)
        if offset == LONGITUD_Y:
            return len(self.fifo_y)
        if offset == ID:
            return CORE_MAGIC
        if offset == VERSION:
            return self.version
        return 0  # reserved (and anything else in the window)

    def write32(self, offset: int, value: int) -> None:
        if offset != CONTROL:
            return  # Dato_*, Longitud_*, reserved, ID and Version ignore writes
        self.go = bool(value & CTRL_GO)
        self.streaming = bool(value & CTRL_STREAM)
        if value & CTRL_FIFO_CLR:
            self.fifo_x.clear()
            self.fifo_y.clear()
            self.full = False
            self.clears += 1


class SimulatedUart:
    """Software model of the FPGA UART used by :class:`sw_hps.robot.UartLink`
    (register map in :mod:`sw_hps.robot`).

    Parameters
    ----------
    busy_reads : int >= 0
        After each transmitted byte, STATUS reads TX ready = 0 this many times
        (the byte being shifted out).
    stuck : bool
        TX ready never rises (a hung UART; the link must give up, not hang).
    responder : callable, optional
        What is wired to the pins: called with each transmitted byte, returns
        the bytes it sends back (queued for RXDATA), e.g. a :class:`SimulatedRn42`.

    Attributes
    ----------
    transmitted : bytearray
        Every byte written to TXDATA while TX ready was 1.
    overruns : int
        Bytes written while TX ready was 0 (lost).
    """

    span = UART_SPAN

    def __init__(self, busy_reads: int = 0, stuck: bool = False,
                 responder: Callable[[int], bytes] | None = None):
        self.busy_reads = int(busy_reads)
        self.stuck = bool(stuck)
        self.responder = responder
        self.transmitted = bytearray()
        self.receive_queue: deque[int] = deque()
        self.overruns = 0
        self._busy = 0

    def _tx_ready(self) -> bool:
        return not self.stuck and self._busy == 0

    def read32(self, offset: int) -> int:
        if offset == UART_STATUS:
            value = (UART_STATUS_TX_READY if self._tx_ready() else 0) \
                | (UART_STATUS_RX_VALID if self.receive_queue else 0)
            if self._busy:
                self._busy -= 1
            return value
        if offset == UART_RXDATA:
            return self.receive_queue.popleft() if self.receive_queue else 0
        return 0

    def write32(self, offset: int, value: int) -> None:
        if offset != UART_TXDATA:
            return
        if not self._tx_ready():
            self.overruns += 1
            return
        self.transmitted.append(value & 0xFF)
        self._busy = self.busy_reads
        if self.responder is not None:
            self.receive_queue.extend(self.responder(value & 0xFF))


class SimulatedPostureSlave:
    """The posture slave (:data:`soc.hps_interface.POSTURE_REGISTERS`,
    :class:`soc.posture_slave.PostureSlave`): two banks of 256 words, the
    latest complete record and the one being written.

    Attributes
    ----------
    records : int
        Records pushed so far (Status.SEQ is its low 16 bits).
    """

    span = POSTURE_SPAN
    BANK_WORDS = 256

    def __init__(self):
        self.banks = [[0] * self.BANK_WORDS, [0] * self.BANK_WORDS]
        self.latest = 0          # the bank of the latest complete record
        self.chosen = 0          # the bank Data reads
        self.index = 0
        self.records = 0

    def push_record(self, words) -> None:
        """One frame's record (``POSTURE_WORD_COUNT`` 32-bit words), as the
        descriptor sends it: written into the other bank, then the latest."""
        words = [int(w) for w in words]
        if len(words) != POSTURE_WORD_COUNT or any(not 0 <= w < 1 << 32 for w in words):
            raise ValueError(f"a posture record is {POSTURE_WORD_COUNT} words in [0, 2**32)")
        bank = self.banks[1 - self.latest]
        bank[:POSTURE_WORD_COUNT] = words
        self.latest = 1 - self.latest
        self.records += 1

    def read32(self, offset: int) -> int:
        if offset == POSTURE_STATUS:
            return self.records & 0xFFFF
        if offset == POSTURE_INDEX:
            return self.index
        if offset == POSTURE_DATA:
            word = self.banks[self.chosen][self.index]
            self.index = (self.index + 1) % self.BANK_WORDS
            return word
        if offset == POSTURE_LAYOUT:
            return posture_layout_word()
        return 0

    def write32(self, offset: int, value: int) -> None:
        if offset == POSTURE_INDEX:
            self.index = value & (self.BANK_WORDS - 1)
            self.chosen = self.latest


class SimulatedRn42:
    """An RN-42 Bluetooth module and the NXT brick behind it, as the
    ``responder`` of a :class:`SimulatedUart` (what :func:`sw_hps.robot.configure_rn42`
    and :class:`sw_hps.robot.RobotChannel` expect of the real ones; docs/robot-link.md).

    The module: ``$$$`` enters command mode while not connected (with ``clock``,
    only after :data:`sw_hps.robot.RN42_GUARD_TIME` without data before it) and
    answers ``CMD``; in command mode ``SM,<n>`` and ``SO,<text>`` answer ``AOK``
    (the status string is stored and used from the next :meth:`reboot`, as set
    commands are), ``C,<address>`` connects when the address is the brick's (and
    the brick is :attr:`reachable`), printing ``<status>CONNECT`` (the model
    prints nothing when it fails); other lines answer ``?``. Connected, data goes
    to the brick, which answers a Bluetooth-framed direct command sent with "reply
    required" with ``03 00 02 <opcode> <status>``. Replies come at once (the
    real module waits out its 1 s window before ``CMD``).

    Parameters
    ----------
    nxt_address : str, optional
        The brick's address (12 hex digits). None: any address connects.
    connected : bool, optional
        Connected at power-up (paired and connected by hand); default: only
        when ``nxt_address`` is None.
    status_prefix : bytes
        The status string in effect (b"": the factory setting, no status lines).
    nxt_status : int
        Status byte the brick answers (0 success, 0xEC no program running).
    clock : callable, optional
        Monotonic seconds; enables the guard-time check before ``$$$``.

    Attributes
    ----------
    messages : list of bytes
        The MessageWrite messages the brick received (mailbox contents).
    commands : list of bytes
        Command-mode lines (and ``$$$``) the module received.
    reachable : bool
        The brick is in range and on (a test switches it off).
    """

    def __init__(self, nxt_address: str | None = None, *, connected: bool | None = None,
                 status_prefix: bytes = b"", nxt_status: int = 0,
                 clock: Callable[[], float] | None = None):
        self.nxt_address = None if nxt_address is None else normalise_bt_address(nxt_address)
        self.connected = (nxt_address is None) if connected is None else bool(connected)
        self.status_prefix = bytes(status_prefix)
        self.nxt_status = int(nxt_status)
        self.reachable = True
        self.messages: list[bytes] = []
        self.commands: list[bytes] = []
        self._clock = clock
        self._stored_prefix = self.status_prefix
        self._command_mode = False
        self._line = bytearray()
        self._dollars = 0
        self._quiet_since = float("-inf")   # clock time of the last byte before a '$' run
        self._last_byte_at = float("-inf")
        self._frame = bytearray()            # the brick's receive buffer

    def reboot(self) -> None:
        """Power cycle: disconnected, data mode, stored settings in effect."""
        self.connected = False
        self._command_mode = False
        self.status_prefix = self._stored_prefix
        self._line.clear()
        self._frame.clear()

    def drop(self) -> bytes:
        """The Bluetooth link drops (brick switched off or out of range); returns
        the status line the module prints (queue it on the UART)."""
        self.connected = False
        self._frame.clear()
        return self._status(b"DISCONNECT")

    def _status(self, what: bytes) -> bytes:
        return self.status_prefix + what + b"\r\n" if self.status_prefix else b""

    def __call__(self, byte: int) -> bytes:
        now = self._clock() if self._clock is not None else 0.0
        quiet_before = now - self._last_byte_at
        self._last_byte_at = now
        if self._command_mode:
            return self._command_byte(byte)
        if byte == ord("$"):
            if self._dollars == 0:
                self._quiet_since = quiet_before
            self._dollars += 1
        else:
            self._dollars = 0
        if self._dollars == 3 and not self.connected:
            self._dollars = 0
            self.commands.append(b"$$$")
            if self._clock is None or self._quiet_since >= RN42_GUARD_TIME:
                self._command_mode = True
                return b"CMD\r\n"
            return b""
        if self.connected:
            return self._brick_byte(byte)
        return b""

    def _command_byte(self, byte: int) -> bytes:
        if byte not in (0x0D, 0x0A):
            self._line.append(byte)
            return b""
        line, self._line = bytes(self._line), bytearray()
        if not line:
            return b""
        self.commands.append(line)
        if line.startswith(b"SM,"):
            return b"AOK\r\n"
        if line.startswith(b"SO,"):
            self._stored_prefix = line[3:]
            return b"AOK\r\n"
        if line == b"---":
            self._command_mode = False
            return b"END\r\n"
        if line.startswith(b"C,"):
            self._command_mode = False
            address = line[2:].decode("ascii", "replace").upper()
            if self.reachable and self.nxt_address in (None, address):
                self.connected = True
                return self._status(b"CONNECT")
            return b""
        return b"?\r\n"

    def _brick_byte(self, byte: int) -> bytes:
        self._frame.append(byte)
        if len(self._frame) < 2:
            return b""
        length = self._frame[0] | self._frame[1] << 8
        if not 2 <= length <= 64:          # not a telegram: the brick resynchronises
            self._frame.clear()
            return b""
        if len(self._frame) < 2 + length:
            return b""
        body, self._frame = bytes(self._frame[2:]), bytearray()
        kind, opcode = body[0], body[1]
        if opcode == NXT_MESSAGEWRITE and len(body) >= 4:   # inbox, size, message
            self.messages.append(body[4:4 + body[3]].rstrip(b"\x00"))
        if kind & NXT_DIRECT_NO_REPLY:
            return b""
        return bytes([3, 0, NXT_REPLY, opcode, self.nxt_status])


def read_trajectory_csv(path):
    """Read a ``trajectory.csv`` as written by ``stereogest pipeline``.

    Parameters
    ----------
    path : str or Path
        CSV with a header holding at least ``frame,x,y,flag`` (x, y in pixels;
        other columns such as ``symbol`` are ignored).

    Returns
    -------
    x, y : (T,) float64
        Centroid in pixels per frame, in file order.
    flag : (T,) bool
        Spotting flag per frame.

    Raises
    ------
    ValueError
        Unreadable file, missing column or bad value (message names the file and line).
    """
    path = Path(path)
    try:
        with path.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except OSError as exc:
        raise ValueError(f"{path}: cannot read trajectory ({exc.strerror})") from None
    except (csv.Error, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a CSV file ({exc})") from None
    if not rows:
        raise ValueError(f"{path}: empty trajectory file")
    header = [name.strip() for name in rows[0]]
    missing = [name for name in ("frame", "x", "y", "flag") if name not in header]
    if missing:
        raise ValueError(f"{path}: header must name frame,x,y,flag; missing {missing}")
    ix, iy, iflag = header.index("x"), header.index("y"), header.index("flag")
    xs, ys, flags = [], [], []
    for line, row in enumerate(rows[1:], start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        try:
            x, y, flag = float(row[ix]), float(row[iy]), int(row[iflag])
        except (IndexError, ValueError):
            raise ValueError(f"{path}: line {line}: expected numbers in x, y and an "
                             f"integer flag, got {row}") from None
        if not (np.isfinite(x) and np.isfinite(y)) or x < 0 or y < 0:
            raise ValueError(f"{path}: line {line}: x and y must be finite and >= 0")
        if flag not in (0, 1):
            raise ValueError(f"{path}: line {line}: flag must be 0 or 1, got {flag}")
        xs.append(x)
        ys.append(y)
        flags.append(bool(flag))
    return np.array(xs, dtype=np.float64), np.array(ys, dtype=np.float64), \
        np.array(flags, dtype=bool)


class PostureFifoPeripheral(SimulatedFifoPeripheral):
    """A simulated FIFO whose every video frame also brings ``slave`` (a
    :class:`SimulatedPostureSlave`) that frame's posture record, as the core's
    descriptor does (``records``: one list of words per queued frame; frames
    after the last repeat it, a still hand)."""

    def __init__(self, slave, records, **options):
        super().__init__(**options)
        if not len(records):
            raise ValueError("records must hold a posture record per frame")
        self.slave, self.records = slave, list(records)

    def push_frame(self, x_fixed: int, y_fixed: int, flag, present=True) -> None:
        super().push_frame(x_fixed, y_fixed, flag, present)
        self.slave.push_record(self.records[min(self.frames, len(self.records)) - 1])


class SimulatedClock:
    """Simulated time for the application: ``sleep(seconds)`` advances it, calling
    it reads it (give ``sleep=clock.sleep, clock=clock`` to :class:`GestureApp`).

    Parameters
    ----------
    start : float
        Initial time in seconds.
    """

    def __init__(self, start: float = 0.0):
        self.now = float(start)

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += max(0.0, float(seconds))

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` pass without a sleep (e.g. time spent on the bus)."""
        self.sleep(seconds)


class SimulationRun:
    """The unmodified application wired to a simulated FIFO that plays a trajectory
    (built by :func:`simulate_trajectory`; :func:`run_on_trajectory` also runs it).

    Attributes
    ----------
    app : GestureApp
        The application (its ``request_stop`` ends :meth:`run` early).
    peripheral : SimulatedFifoPeripheral
        The FIFO model, one video frame per Control read (``reads_per_frame``).
    link : object
        The robot link (a recording :class:`~sw_hps.robot.NullLink` by default).
    results : list of GestureResult
        Every finished gesture (filled by :meth:`run`).
    """

    def __init__(self, app: GestureApp, peripheral: SimulatedFifoPeripheral, link,
                 max_iterations: int):
        self.app = app
        self.peripheral = peripheral
        self.link = link
        self.max_iterations = max_iterations
        self.results: list[GestureResult] = []

    def finished(self) -> bool:
        """Every frame played, FIFOs empty, no gesture flagged, application in S1."""
        peripheral = self.peripheral
        return (peripheral.frames_pending == 0 and not peripheral.flag
                and not peripheral.fifo_x and self.app.state is State.WAIT)

    def run(self) -> "SimulationRun":
        """Run the application until :meth:`finished` (or the iteration bound)."""
        self.results.extend(self.app.run(max_iterations=self.max_iterations,
                                         until=self.finished))
        return self

    @property
    def recognised(self) -> list[str]:
        """Names of the recognised gestures, in order."""
        return [r.class_name for r in self.results if r.recognised]

    @property
    def telegrams(self) -> list[bytes]:
        """Telegrams the link accepted, in order."""
        return [r.telegram for r in self.results if r.sent and r.telegram is not None]


def simulate_trajectory(models: GestureModels, x, y, flag, *, pixels: bool = True,
                        link=None, bus: SimBus | None = None, reads_per_frame: int = 1,
                        depth: int = FIFO_DEPTH,
                        sleep: Callable[[float], None] | None = None,
                        max_iterations: int | None = None, posture_records=None,
                        posture_model=None, **app_options) -> SimulationRun:
    """Wire the unmodified application to a simulated FIFO playing a trajectory.

    Parameters
    ----------
    models : GestureModels
        Class models.
    x, y : (T,) arrays
        Smoothed centroid per video frame, in pixels (``pixels=True``, as in
        ``trajectory.csv``) or raw 10.8 fixed point.
    flag : (T,) array
        Spotting flag per frame.
    link : optional
        Robot link; a recording :class:`~sw_hps.robot.NullLink` by default.
    bus : SimBus, optional
        Bus to attach the simulated FIFO to at offset 0 (e.g. one that already
        holds a simulated UART); a new one by default.
    reads_per_frame : int
        Control reads (= application polls) per video frame.
    depth : int
        Simulated FIFO depth.
    sleep : callable, optional
        The application's sleep. By default a :class:`SimulatedClock` (no real
        waiting) that is also the application's ``clock``, unless ``clock`` is given.
    max_iterations : int, optional
        Safety bound on steps (default: generous, from the trajectory length).
    posture_records, posture_model : optional
        Each frame's posture record (words) and the posture classifier: a
        simulated posture slave then gets each frame's record with its pair,
        and the application a tracker of it (``posture``).
    **app_options
        Passed to :class:`GestureApp` (``min_symbols``, ``max_points``,
        ``on_result``, ...).

    Returns
    -------
    SimulationRun
        Not yet run: call its ``run()``.
    """
    if posture_model is not None:
        slave = SimulatedPostureSlave()
        peripheral = PostureFifoPeripheral(slave, posture_records, depth=depth,
                                           reads_per_frame=reads_per_frame)
    else:
        peripheral = SimulatedFifoPeripheral(depth=depth, reads_per_frame=reads_per_frame)
    peripheral.queue_trajectory(x, y, flag, pixels=pixels)
    if bus is None:
        bus = SimBus(peripheral)
    else:
        bus.attach(0, peripheral)
    if posture_model is not None:
        from .posture import POSTURE_OFFSET, PostureReader, PostureTracker
        bus.attach(POSTURE_OFFSET, slave)
        app_options["posture"] = PostureTracker(PostureReader(bus), posture_model)
    link = link if link is not None else NullLink()
    if sleep is None:
        simulated = SimulatedClock()
        sleep = simulated.sleep
        app_options.setdefault("clock", simulated)
    app = GestureApp(models, FifoPeripheral(bus), link, sleep=sleep, **app_options)
    if max_iterations is None:
        max_iterations = 20 * (peripheral.frames_pending + 10) * reads_per_frame + 1000
    return SimulationRun(app, peripheral, link, max_iterations)


def run_on_trajectory(models: GestureModels, x, y, flag, **options) -> SimulationRun:
    """:func:`simulate_trajectory` and run it; the returned object holds
    ``results``, ``recognised`` (names) and ``telegrams`` (bytes sent)."""
    return simulate_trajectory(models, x, y, flag, **options).run()


def streaming_words(trajectory, depth: int = FIFO_DEPTH) -> list[tuple[int, int]]:
    """The (Dato_X, Dato_Y) words the FIFO slave holds in streaming mode
    (Control = GO | STREAM before the first frame) after ``trajectory``'s
    frames (a :class:`sim.model.pipeline.Trajectory`), popped in order: every
    frame's smoothed position with its FLAG and PRESENT bits, the golden model
    of the hardware's streaming mode."""
    peripheral = SimulatedFifoPeripheral(depth=depth)
    peripheral.write32(CONTROL, CTRL_GO | CTRL_STREAM)
    peripheral.queue_trajectory(trajectory.smoothed[:, 0], trajectory.smoothed[:, 1],
                                trajectory.flag, present=np.asarray(trajectory.area) > 0)
    peripheral.step(peripheral.frames_pending)
    return [(peripheral.read32(DATO_X), peripheral.read32(DATO_Y))
            for _ in range(min(len(peripheral.fifo_x), len(peripheral.fifo_y)))]


def simulate_stream(models, x, y, present=None, *, pixels: bool = False, link=None,
                    bus: SimBus | None = None, frame_width: int = FIFO_FRAME_WIDTH,
                    sleep: Callable[[float], None] | None = None, **app_options):
    """The continuous spotting loop (:class:`sw_hps.streaming.StreamingApp`)
    on a simulated FIFO in streaming mode playing a trajectory (one frame per
    Control read), then the frames of a still hand until nothing is pending.
    Returns the app, not yet run (:func:`run_stream` runs it)."""
    from .streaming import StreamingApp
    peripheral = SimulatedFifoPeripheral(reads_per_frame=1, frame_width=frame_width)
    x = np.asarray(x).reshape(-1)
    peripheral.queue_trajectory(x, y, np.zeros(len(x), bool), pixels=pixels, present=present)
    if bus is None:
        bus = SimBus(peripheral)
    else:
        bus.attach(0, peripheral)
    link = link if link is not None else NullLink()
    if sleep is None:              # simulated time: the clock advances by the sleeps
        simulated = SimulatedClock()
        sleep = simulated.sleep
        app_options.setdefault("clock", simulated)
    app = StreamingApp(models, FifoPeripheral(bus), link, sleep=sleep,
                       frame_width=frame_width, **app_options)
    app.peripheral = peripheral
    return app


def run_stream(app):
    """Run an app from :func:`simulate_stream` until every frame was taken and
    nothing is pending; returns it (``app.results``: the gestures it named)."""
    peripheral = app.peripheral

    def finished() -> bool:
        return (peripheral.frames_pending == 0 and not peripheral.fifo_x and app.idle
                and app.frames > 0)

    app.run(max_iterations=4 * (peripheral.frames_pending + 1000), until=finished)
    return app
