"""Bus faults: register reads that no working stereogest core gives, and how the
board's loops back off while they last (issue 30).

Runs on the board's ARM: Python 3.7 and numpy 1.16, nothing else from this project.

A working FIFO slave (:data:`soc.hps_interface.FIFO_REGISTERS`) never reads

* a Control word with a bit outside :data:`~soc.hps_interface.CTRL_READABLE_MASK`
  set (bits [31:6] and FIFO_CLR read 0): all ones, as a bridge without a slave
  behind it may return, always has such bits;
* Control without GO once the application set it, or STREAM other than the
  application wrote it: all zeros (a core held in reset, or nothing decoding the
  address) reads GO = 0 right after GO was written;
* Longitud_X or Longitud_Y above :data:`~soc.hps_interface.FIFO_DEPTH`;
* an ID register other than :data:`~soc.hps_interface.CORE_MAGIC` (checked once a
  fault was seen, before the loop trusts the bus again).

:class:`sw_hps.app.GestureApp` and :class:`sw_hps.streaming.StreamingApp` raise
:class:`BusFault` inside a step when they read such a pattern; their ``run``
hands it to a :class:`BusFaultWatch`, which logs one warning naming what was read
and the likely cause, then has the loop probe the registers (reads only) with a
capped exponential back-off until they look sane again; the loop then
re-initialises the core (FIFO-CLR and GO, plus STREAM in the continuous mode) and,
once GO reads back, the watch logs the recovery.

A synchronous bus error (SIGBUS) cannot be handled inside Python: see
:mod:`sw_hps.guard`, which shares :data:`LIKELY_CAUSE` and :data:`CHECK_HINT`.
"""
from __future__ import annotations

import logging
import time
from typing import Callable

from soc.hps_interface import (CORE_MAGIC, CTRL_GO, CTRL_READABLE_MASK, CTRL_STREAM,
                               FIFO_DEPTH, ID)

from .bus import DevMemBus, SimBus, UioBus

__all__ = ["BusFault", "BusFaultWatch", "RepeatFilter", "control_fault", "lengths_fault",
           "describe_bus", "read_id", "LIKELY_CAUSE", "CHECK_HINT", "MAX_FAULT_INTERVAL",
           "MIN_FAULT_INTERVAL", "FAULT_REMINDER", "MAX_BUSY_STEPS"]

#: What usually makes the bridge read garbage or fault (one place for every message).
LIKELY_CAUSE = ("the lightweight HPS-to-FPGA bridge is disabled or held in reset, the FPGA "
                "is not configured (or runs another design), or the core is held in reset")
#: The command that tells these apart (sw_hps.__main__, ``--check``).
CHECK_HINT = "check with 'python3 -m sw_hps --check'"
#: Longest sleep between two probes of a faulty bus, seconds.
MAX_FAULT_INTERVAL = 1.0
#: Shortest first sleep after a fault (a poll interval of 0 must not make it spin).
MIN_FAULT_INTERVAL = 0.001
#: Seconds between two reminders of a lasting fault when the loop has no heartbeat.
FAULT_REMINDER = 60.0
#: Steps in a row without any sleep after which a loop sleeps one poll interval anyway
#: (a step that pops data or changes state needs none, but nothing may spin forever).
MAX_BUSY_STEPS = 100


class BusFault(Exception):
    """Register reads that no working core gives; ``str()`` says what was read and
    why it is impossible."""


def control_fault(control: int, *, stream: bool, just_set: bool) -> str | None:
    """Why a Control word is impossible while the application keeps GO set (and
    STREAM = ``stream``), or None.

    Parameters
    ----------
    control : int
        The word read.
    stream : bool
        Whether the application wrote STREAM = 1.
    just_set : bool
        The application wrote Control right before this read (the message then
        says that GO does not read back, rather than that it was cleared).
    """
    control &= 0xFFFFFFFF
    extra = control & ~CTRL_READABLE_MASK
    if extra:
        return (f"Control reads {control:#010x}: bits {extra:#x} set, which the core never "
                f"sets (only {CTRL_READABLE_MASK:#x} can read 1)")
    if not control & CTRL_GO:
        if just_set:
            return (f"Control reads {control:#010x}: GO does not read back after the "
                    "application set it")
        return (f"Control reads {control:#010x}: GO reads 0 although the application set "
                "it (the core was reset, the FPGA reconfigured, or another program wrote "
                "Control)")
    if bool(control & CTRL_STREAM) != stream:
        return (f"Control reads {control:#010x}: STREAM reads {int(not stream)} although the "
                f"application wrote {int(stream)}")
    return None


def lengths_fault(length_x: int, length_y: int) -> str | None:
    """Why Longitud_X / Longitud_Y are impossible (above FIFO_DEPTH), or None."""
    over = [name for name, value in (("Longitud_X", length_x), ("Longitud_Y", length_y))
            if value > FIFO_DEPTH]
    if not over:
        return None
    both = f"Longitud_X={length_x} and Longitud_Y={length_y}"
    if len(over) == 2:
        return f"{both} exceed FIFO_DEPTH={FIFO_DEPTH}, more than a FIFO of the core holds"
    return f"{both}: {over[0]} exceeds FIFO_DEPTH={FIFO_DEPTH}, more than a FIFO of the core holds"


def read_id(fifo) -> int:
    """The ID register of a :class:`sw_hps.fifo.FifoPeripheral`'s slave (one read)."""
    return int(fifo.bus.read32(fifo.base + ID)) & 0xFFFFFFFF


def describe_bus(bus, offset: int = 0) -> str:
    """Where a slave at ``offset`` in ``bus`` lives, for messages: the device and the
    address window (physical for ``/dev/mem``)."""
    span = getattr(bus, "span", None)
    if isinstance(bus, DevMemBus):
        start = bus.base + bus.offset
        return (f"{bus.path} window {start:#010x}-{start + span - 1:#010x} (slave at "
                f"{start + offset:#010x})")
    if isinstance(bus, UioBus):
        return f"{bus.path} map 0, bytes 0x0-{span - 1:#x} (slave at offset {offset:#x})"
    if isinstance(bus, SimBus):
        return f"the simulated bus (slave at offset {offset:#x})"
    return f"{type(bus).__name__} (slave at offset {offset:#x})"


class RepeatFilter:
    """Decides whether a log line is written: a line that differs from the last one
    always, the same line again at most once per ``interval`` seconds.

    Parameters
    ----------
    interval : float
        Seconds between two copies of the same line.
    clock : callable
        ``clock() -> seconds``.
    """

    def __init__(self, interval: float, clock: Callable[[], float]):
        self.interval = float(interval)
        self._clock = clock
        self._last: str | None = None
        self._logged_at = 0.0
        #: Copies left out since the last line written.
        self.suppressed = 0

    def admit(self, line: str) -> int | None:
        """None if ``line`` is to be left out; otherwise the number of copies left out
        before it (the caller may say so)."""
        now = self._clock()
        if line == self._last and now - self._logged_at < self.interval:
            self.suppressed += 1
            return None
        left_out, self.suppressed = self.suppressed, 0
        self._last, self._logged_at = line, now
        return left_out


class BusFaultWatch:
    """Back-off and log lines of one loop while its bus reads impossible values.

    An *episode* starts with :meth:`fault` and ends with :meth:`confirm`, when the
    loop re-initialised the core and GO read back. In between, :meth:`probe` reads
    the registers (never writes) once per back-off interval. Log lines per episode:
    one warning when it starts, a reminder every ``reminder`` seconds while it lasts,
    one INFO line when it ends. An episode that starts within ``reminder`` seconds
    (:data:`FAULT_REMINDER` if None) of the last line of the previous one (a bus that
    comes and goes) keeps the previous back-off and logs nothing until a reminder is
    due, so a flapping bus cannot flood the log either.

    Parameters
    ----------
    label : str
        Prefix of the lines (which loop).
    where : str
        Where the slave lives (:func:`describe_bus`).
    read_id : callable
        ``read_id() -> int``: reads the ID register (for the messages and the probe).
    poll_interval : float
        The loop's idle sleep: the first back-off interval (at least
        :data:`MIN_FAULT_INTERVAL`).
    max_interval : float
        The back-off doubles up to this many seconds.
    reminder : float or None
        Seconds between reminders of a lasting fault; None: no reminders.
    clock : callable
        ``clock() -> seconds`` (monotonic).
    logger : logging.Logger
        Where the lines go.

    Attributes
    ----------
    episodes : int
        Bus faults seen (episodes started).
    probes : int
        Probes of the registers during the current or last episode.
    """

    def __init__(self, *, label: str, where: str, read_id: Callable[[], int],
                 poll_interval: float, max_interval: float = MAX_FAULT_INTERVAL,
                 reminder: float | None = FAULT_REMINDER,
                 clock: Callable[[], float] = time.monotonic, logger=None):
        if not (isinstance(max_interval, (int, float)) and 0 < max_interval <= 60):
            raise ValueError(f"max_fault_interval must be in (0, 60] seconds, "
                             f"got {max_interval!r}")
        self.label, self.where = label, where
        self._read_id = read_id
        self.first_interval = min(max(float(poll_interval), MIN_FAULT_INTERVAL),
                                  float(max_interval))
        self.max_interval = float(max_interval)
        self.reminder = float(reminder) if reminder else None
        self._clock = clock
        self._log = logger if logger is not None else logging.getLogger(__name__)
        self.active = False
        #: A probe found sane reads; the loop re-initialises the core next.
        self.recovering = False
        self.episodes = 0
        self.probes = 0
        self._delay = self.first_interval
        self._since = 0.0
        self._reason = ""
        self._logged = False              # this episode's start was logged
        self._line_at: float | None = None  # clock of the last line about bus faults
        self._seconds = 0.0               # finished episodes' total length

    @property
    def seconds(self) -> float:
        """Seconds spent in bus faults so far (the current episode included)."""
        return self._seconds + (self._clock() - self._since if self.active else 0.0)

    def counters(self) -> str:
        """For the loop's status lines."""
        return f"{self.episodes} bus faults ({self.seconds:.0f} s)"

    def _quiet_for(self) -> float:
        return self.reminder if self.reminder is not None else FAULT_REMINDER

    def _next_delay(self) -> float:
        delay = self._delay
        self._delay = min(2 * delay, self.max_interval)
        return delay

    def _id_text(self) -> str:
        try:
            magic = self._read_id()
        except Exception as exc:  # the ID read itself may fail on a broken bus
            return f"ID unreadable ({type(exc).__name__}: {exc})"
        if magic == CORE_MAGIC:
            return f"ID reads {magic:#010x} (CORE_MAGIC: the core answers)"
        return f"ID reads {magic:#010x}, not CORE_MAGIC {CORE_MAGIC:#010x}"

    def fault(self, reason: str) -> float:
        """A step read an impossible pattern: start (or continue) an episode; returns
        the seconds the loop sleeps before its next step."""
        now = self._clock()
        self._reason = reason
        if self.active:                    # e.g. the re-initialisation did not hold
            self.recovering = False
            self._remind(now)
            return self._next_delay()
        self.active, self.recovering = True, False
        self.episodes += 1
        self._since = now
        self.probes = 0
        flapping = self._line_at is not None and now - self._line_at < self._quiet_for()
        if not flapping:
            self._delay = self.first_interval
        self._logged = not flapping
        if self._logged:
            self._line_at = now
            self._log.warning(
                "%s: bus fault at %s: %s; %s. Likely %s; %s. Backing off: probing every "
                "%.3g s, doubling up to %.3g s, until the reads look sane", self.label,
                self.where, reason, self._id_text(), LIKELY_CAUSE, CHECK_HINT, self._delay,
                self.max_interval)
        return self._next_delay()

    def _remind(self, now: float) -> None:
        if self.reminder is None or now - self._line_at < self.reminder:
            return
        self._line_at = now
        self._logged = True
        self._log.warning("%s: bus fault persists after %.0f s (%d probes, %d bus faults so "
                          "far): %s; probing every %.3g s; %s", self.label, now - self._since,
                          self.probes, self.episodes, self._reason, self._delay, CHECK_HINT)

    def probe(self, fifo) -> float | None:
        """Read Control, Longitud_X/Y and ID (no writes). None if they look like a
        working core's (the loop then re-initialises it); otherwise the seconds to
        sleep before the next probe."""
        self.probes += 1
        try:
            status = fifo.status()
            magic = read_id(fifo)
        except Exception as exc:  # a bus that raises is as faulty as one that lies
            problem = f"{type(exc).__name__}: {exc}"
        else:
            extra = status.control & ~CTRL_READABLE_MASK
            problem = None
            if extra:
                problem = control_fault(status.control, stream=False, just_set=False)
            if problem is None:
                problem = lengths_fault(status.length_x, status.length_y)
            if problem is None and magic != CORE_MAGIC:
                problem = (f"ID reads {magic:#010x}, not CORE_MAGIC {CORE_MAGIC:#010x} "
                           f"(Control {status.control:#010x})")
        if problem is None:
            self.recovering = True
            return None
        self._reason = problem
        self._remind(self._clock())
        return self._next_delay()

    def confirm(self, what: str) -> None:
        """The loop re-initialised the core (``what`` it wrote) and the first status
        read back looks right: the episode ends."""
        if not self.active:
            return
        now = self._clock()
        self.active = self.recovering = False
        self._seconds += now - self._since
        if self._logged:
            self._line_at = now
            self._log.info("%s: bus reads sane again after %.1f s (%d probes); core "
                           "re-initialised (%s); %s", self.label, now - self._since,
                           self.probes, what, self.counters())
