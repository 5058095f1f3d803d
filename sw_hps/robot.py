"""Links to the LEGO NXT robot that carry the telegrams of :mod:`sw_hps.telegram`
(thesis §8.5), and what became of each telegram.

Runs on the board's ARM: Python 3.7+ and numpy only, and :mod:`soc.hps_interface`
(shipped with it; the serial port is driven with ``termios``/``os``, no pyserial).
How to reach the NXT (RN-42 on the FPGA UART, a serial adapter, a USB Bluetooth
dongle with BlueZ and ``rfcomm``) is described in ``docs/robot-link.md``.

Links
-----
* :class:`SerialLink`: a Bluetooth serial adapter (RN-42 or any SPP link, or
  ``/dev/rfcomm0``) on a tty, raw 8N1; reopens with capped exponential back-off
  when the tty fails or disappears; never raises on send.
* :class:`UartLink`: the FPGA's UART, a slave on the same bridge as the FIFO
  (register map :data:`soc.hps_interface.UART_REGISTERS`); reads by polling
  STATUS.RX_VALID.
* :class:`NullLink`: no robot; logs and records the telegrams.

Both real links can send and read, so :func:`configure_rn42` puts an RN-42 on
either one in master mode and connects it to the brick.

Deliveries
----------
:class:`RobotChannel` is what the applications talk to
(:func:`deliver_gesture`): it builds a gesture's telegram, writes it and says
what became of it in a :class:`Delivery`:

* ``"acknowledged"``: the brick answered the telegram with status 0 (only with
  ``ack_timeout``, ``--robot-ack``, which sends the telegram with "reply
  required"; see :mod:`sw_hps.telegram`);
* ``"unconfirmed"``: the link took the bytes but cannot know whether they
  arrived (no ``--robot-ack``, or a link that cannot read);
* ``"failed"``: the link is down, the write failed, the brick answered an error
  status, or no reply came within ``ack_timeout``.

With ``rn42_address`` (``--rn42-address``) the channel also keeps the RN-42
connected: it sets the module up again, with capped back-off, after
:data:`RN42_FAILURES_BEFORE_SETUP` consecutive sends without a reply, when the
module reports ``%DISCONNECT`` (its status string, enabled by the set-up) or
when the serial port was reopened. A set-up blocks the caller for at most
:data:`RN42_GUARD_TIME` + 3 x ``setup_timeout`` + ``connect_wait`` seconds
(about 9 s with the defaults) and runs only when a gesture is being sent.
"""
from __future__ import annotations

import logging
import os
import re
import select
import termios
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable

try:  # Python 3.8+; on 3.7 the interface is only documented
    from typing import Protocol
except ImportError:
    Protocol = object

from soc.hps_interface import (UART_RXDATA, UART_STATUS, UART_STATUS_RX_VALID,
                               UART_STATUS_TX_READY, UART_TXDATA)

from .busfault import FAULT_REMINDER, RepeatFilter
from .telegram import find_reply, hex_bytes, probe_telegram, status_text, telegram

__all__ = ["Link", "NullLink", "SerialLink", "UartLink", "configure_rn42",
           "normalise_bt_address", "Delivery", "RobotChannel", "deliver_gesture",
           "ACKNOWLEDGED", "UNCONFIRMED", "FAILED", "DEFAULT_ACK_TIMEOUT", "ACK_TIMEOUT_RANGE",
           "RN42_STATUS_PREFIX", "RN42_GUARD_TIME", "RN42_FAILURES_BEFORE_SETUP"]

log = logging.getLogger(__name__)

ACKNOWLEDGED = "acknowledged"
UNCONFIRMED = "unconfirmed"
FAILED = "failed"
#: Seconds ``--robot-ack`` waits for the brick's reply unless told otherwise;
#: a Bluetooth round trip to the NXT takes some tens of milliseconds.
DEFAULT_ACK_TIMEOUT = 0.3
#: Allowed reply timeouts (s): shorter misses replies, longer stalls the loop.
ACK_TIMEOUT_RANGE = (0.05, 5.0)
#: The RN-42's status string (``SO,%``): it then prints ``%CONNECT`` and
#: ``%DISCONNECT`` on its UART (Roving Networks "RN Commands" user guide v4.25,
#: command SO). In master mode its first character also breaks the connection
#: when sent as data; no telegram contains 0x25.
RN42_STATUS_PREFIX = b"%"
RN42_CONNECT = RN42_STATUS_PREFIX + b"CONNECT"
RN42_DISCONNECT = RN42_STATUS_PREFIX + b"DISCONNECT"
#: Silence the RN-42 needs around ``$$$`` to enter command mode (1 s window, same
#: guide, command $$$).
RN42_GUARD_TIME = 1.0
#: Longest sleep between two calls of ``RobotChannel.while_waiting`` (s): less
#: than a video frame.
WAIT_SLICE = 0.01
#: Consecutive sends without a reply (with ``--robot-ack``) that make a channel
#: with an RN-42 address set the module up again.
RN42_FAILURES_BEFORE_SETUP = 3


class Link(Protocol):
    """Byte transport to the robot: ``send`` never raises, it returns success."""

    def send(self, data: bytes) -> bool: ...

    def close(self) -> None: ...


class NullLink:
    """No robot: logs each telegram and keeps the last ``keep`` in :attr:`sent`."""

    def __init__(self, keep: int = 1000):
        self.sent: deque[bytes] = deque(maxlen=keep)

    def send(self, data: bytes) -> bool:
        data = bytes(data)
        log.info("robot none: telegram %s", hex_bytes(data))
        self.sent.append(data)
        return True

    def close(self) -> None:
        pass


def _baud_constant(baudrate) -> int:
    value = getattr(termios, f"B{baudrate}", None) if isinstance(baudrate, int) \
        and not isinstance(baudrate, bool) else None
    if value is None:
        raise ValueError(f"baudrate must be a standard termios rate (e.g. 9600, 115200), "
                         f"got {baudrate!r}")
    return value


class SerialLink:
    """Serial port (Bluetooth SPP adapter such as the RN-42), raw 8N1.

    Parameters
    ----------
    device : str
        Path of the tty.
    baudrate : int
        A standard rate (``termios.B<rate>`` must exist).
    write_timeout : float
        Seconds a whole send may wait for the port to accept the bytes.
    initial_backoff, max_backoff : float
        Delay before the first reconnect attempt after a failure, doubled after
        each failed attempt up to ``max_backoff``.
    clock : callable
        Monotonic seconds for the back-off (injectable for tests); reads use
        real time.

    Notes
    -----
    The port is opened at construction; if that fails the link starts
    disconnected and the next :meth:`send` tries again (after the back-off).
    A send never raises: it logs and returns False. A write or read error (EIO,
    ENODEV: the adapter was unplugged or ``rfcomm`` dropped the connection) or a
    hung-up tty closes the port; the next send after the back-off reopens it
    (:attr:`opens` counts the successful opens, so a caller can tell that an
    RN-42 behind it may need setting up again).
    """

    def __init__(self, device: str, baudrate: int = 115200, *, write_timeout: float = 1.0,
                 initial_backoff: float = 0.5, max_backoff: float = 30.0,
                 clock: Callable[[], float] = time.monotonic):
        self.device = str(device)
        self.baudrate = baudrate
        self._speed = _baud_constant(baudrate)
        if not initial_backoff > 0 or not max_backoff >= initial_backoff:
            raise ValueError("initial_backoff must be > 0 and max_backoff >= initial_backoff, "
                             f"got {initial_backoff!r}, {max_backoff!r}")
        self.write_timeout = float(write_timeout)
        self.initial_backoff = float(initial_backoff)
        self.max_backoff = float(max_backoff)
        self._clock = clock
        self._fd: int | None = None
        #: Delay that the next failure will wait before retrying.
        self.backoff = self.initial_backoff
        #: Clock time before which no reconnect is tried.
        self.retry_at = float("-inf")
        #: Open attempts made so far (including the first one).
        self.open_attempts = 0
        #: Successful opens so far.
        self.opens = 0
        self._open()

    @property
    def connected(self) -> bool:
        return self._fd is not None

    def _configure(self, fd: int) -> None:
        iflag, oflag, cflag, lflag, _, _, cc = termios.tcgetattr(fd)
        iflag &= ~(termios.IGNBRK | termios.BRKINT | termios.PARMRK | termios.ISTRIP
                   | termios.INLCR | termios.IGNCR | termios.ICRNL | termios.IXON
                   | termios.IXOFF | termios.IXANY)
        oflag &= ~termios.OPOST
        lflag &= ~(termios.ECHO | termios.ECHONL | termios.ICANON | termios.ISIG
                   | termios.IEXTEN)
        cflag &= ~(termios.CSIZE | termios.PARENB | termios.CSTOPB
                   | getattr(termios, "CRTSCTS", 0))
        cflag |= termios.CS8 | termios.CREAD | termios.CLOCAL
        cc = list(cc)
        cc[termios.VMIN] = 0
        cc[termios.VTIME] = 0
        termios.tcsetattr(fd, termios.TCSANOW,
                          [iflag, oflag, cflag, lflag, self._speed, self._speed, cc])

    def _open(self) -> bool:
        self.open_attempts += 1
        try:
            fd = os.open(self.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as exc:
            self._failed(f"cannot open {self.device}: {exc.strerror}")
            return False
        try:
            self._configure(fd)
        except (OSError, termios.error) as exc:
            os.close(fd)
            self._failed(f"cannot configure {self.device} as a raw 8N1 port: {exc}")
            return False
        self._fd = fd
        self.opens += 1
        self.backoff = self.initial_backoff
        self.retry_at = float("-inf")
        log.info("serial link open: %s at %d baud", self.device, self.baudrate)
        return True

    def _failed(self, reason: str) -> None:
        self._drop()
        delay = self.backoff
        self.retry_at = self._clock() + delay
        self.backoff = min(self.backoff * 2, self.max_backoff)
        log.warning("%s; retrying in %.1f s", reason, delay)

    def _drop(self) -> None:
        if self._fd is not None:
            try:
                os.close(self._fd)
            except OSError:
                pass
            self._fd = None

    def _ensure_open(self) -> bool:
        if self._fd is not None:
            return True
        if self._clock() < self.retry_at:
            log.debug("serial link %s down; next attempt in %.2f s", self.device,
                      self.retry_at - self._clock())
            return False
        return self._open()

    def send(self, data: bytes) -> bool:
        """Write all of ``data``; False (logged) if the port is down or the write fails."""
        data = bytes(data)
        if not self._ensure_open():
            log.warning("serial link %s down: %d bytes not sent", self.device, len(data))
            return False
        deadline = time.monotonic() + self.write_timeout
        view = memoryview(data)
        try:
            while view:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    self._failed(f"write to {self.device} timed out")
                    return False
                _, writable, _ = select.select([], [self._fd], [], remaining)
                if not writable:
                    continue
                try:
                    written = os.write(self._fd, view)
                except BlockingIOError:
                    continue
                view = view[written:]
        except (OSError, ValueError) as exc:
            self._failed(f"write to {self.device} failed: {getattr(exc, 'strerror', exc)}")
            return False
        return True

    def read_available(self) -> bytes:
        """Bytes already received (possibly empty); empty if the port is down."""
        if self._fd is None:
            return b""
        chunks = []
        try:
            while True:
                chunk = os.read(self._fd, 4096)
                if not chunk:
                    break
                chunks.append(chunk)
        except BlockingIOError:
            pass
        except OSError as exc:
            self._failed(f"read from {self.device} failed: {exc.strerror}")
        return b"".join(chunks)

    def read_until(self, expected: bytes, timeout: float) -> bytes | None:
        """Read until ``expected`` has arrived; return everything read, or None if
        it did not arrive within ``timeout`` seconds (or the port is down)."""
        if not self._ensure_open():
            return None
        received = bytearray()
        deadline = time.monotonic() + timeout
        while expected not in received:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or self._fd is None:
                log.debug("read_until %r: got %r", expected, bytes(received))
                return None
            try:
                readable, _, _ = select.select([self._fd], [], [], remaining)
            except (OSError, ValueError) as exc:
                self._failed(f"read from {self.device} failed: {exc}")
                return None
            if readable:
                chunk = self.read_available()
                if not chunk and self._fd is not None:
                    # readable yet nothing to read: the tty was hung up
                    self._failed(f"{self.device} hung up")
                    return None
                received += chunk
        return bytes(received)

    def close(self) -> None:
        self._drop()


_BT_PLAIN = re.compile(r"[0-9A-Fa-f]{12}")
_BT_COLONS = re.compile(r"([0-9A-Fa-f]{2}:){5}[0-9A-Fa-f]{2}")


def normalise_bt_address(address) -> str:
    """Bluetooth address as the 12 upper-case hex digits the RN-42 wants.

    Accepts ``"0016530A0B0C"`` or ``"00:16:53:0A:0B:0C"``; ``ValueError`` naming
    ``address`` otherwise.
    """
    if isinstance(address, str) and (_BT_PLAIN.fullmatch(address)
                                     or _BT_COLONS.fullmatch(address)):
        return address.replace(":", "").upper()
    raise ValueError(f"address must be 12 hex digits (e.g. 00165301A2B3 or "
                     f"00:16:53:01:A2:B3), got {address!r}")


def configure_rn42(link, address, timeout: float = 2.0, *, level: int = logging.WARNING) -> bool:
    """Make an RN-42 Bluetooth module connect to the NXT brick as master.

    Command mode (``$$$`` -> ``CMD``), master mode (``SM,1`` -> ``AOK``), the
    status string (``SO,%`` -> ``AOK``: ``%CONNECT``/``%DISCONNECT`` on the UART
    once the module has restarted, set commands being stored in flash), then
    connect (``C,<address>``). The module enters command mode only after 1 s
    without data around ``$$$`` (:data:`RN42_GUARD_TIME`); a module already
    connected may pass ``$$$`` on to the brick instead (then no ``CMD``).

    Parameters
    ----------
    link : SerialLink or UartLink
        Any link with ``send``, ``read_available`` and ``read_until``.
    address : str
        The brick's Bluetooth address (12 hex digits, colons allowed).
    timeout : float
        Seconds to wait for each reply (``CMD`` comes after the 1 s window).
    level : int
        Logging level of the failure lines (a caller retrying often lowers it).

    Returns
    -------
    bool
        True once the connect command was sent; False (reason logged) if a
        reply did not come or the link is down.

    Raises
    ------
    ValueError
        Malformed ``address``, or a link that cannot read.
    """
    address = normalise_bt_address(address)
    if not _can_read(link):
        raise ValueError(f"link must be able to read replies (read_available, read_until) to "
                         f"set up an RN-42, got {type(link).__name__}")
    link.read_available()  # stale bytes would satisfy the first expectation
    for command, reply in ((b"$$$", b"CMD"), (b"SM,1\r", b"AOK"),
                           (b"SO," + RN42_STATUS_PREFIX + b"\r", b"AOK")):
        if not link.send(command):
            log.log(level, "RN-42: could not send %r (link down)", command)
            return False
        if link.read_until(reply, timeout) is None:
            log.log(level, "RN-42: no %r reply to %r within %.1f s", reply.decode(),
                    command.decode().strip(), timeout)
            return False
    if not link.send(f"C,{address}\r".encode("ascii")):
        log.log(level, "RN-42: could not send the connect command (link down)")
        return False
    log.info("RN-42: master mode, connecting to %s", address)
    return True


def _can_read(link) -> bool:
    return callable(getattr(link, "read_available", None)) \
        and callable(getattr(link, "read_until", None))


class UartLink:
    """The FPGA's UART (register map in the module docstring) on a bus.

    Parameters
    ----------
    bus : Bus
        Register access.
    offset : int
        Byte offset of the UART slave in the bus window.
    spin_limit : int
        STATUS reads to wait for TX ready per byte before giving up.
    poll_interval : float
        Seconds :meth:`read_until` sleeps between polls of an empty receiver
        (the core's receive FIFO holds 16 bytes, ``soc.uart``'s default: 1.4 ms
        at 115200 baud; the replies awaited are 5 bytes).
    clock, sleep : callable
        Monotonic seconds and ``sleep(seconds)`` for :meth:`read_until`
        (injectable for tests).
    """

    #: Bytes one :meth:`read_available` pops at most (a bus reading all ones
    #: shows RX_VALID forever).
    READ_LIMIT = 256

    def __init__(self, bus, offset: int = 0x100, spin_limit: int = 100_000, *,
                 poll_interval: float = 0.001, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        if isinstance(offset, bool) or not isinstance(offset, int) or offset < 0 or offset % 4:
            raise ValueError(f"offset must be a non-negative multiple of 4, got {offset!r}")
        if isinstance(spin_limit, bool) or not isinstance(spin_limit, int) or spin_limit < 1:
            raise ValueError(f"spin_limit must be an int >= 1, got {spin_limit!r}")
        if not (isinstance(poll_interval, (int, float)) and 0 < poll_interval <= 0.1):
            raise ValueError(f"poll_interval must be in (0, 0.1] seconds, got {poll_interval!r}")
        self.bus = bus
        self.offset = offset
        self.spin_limit = spin_limit
        self.poll_interval = float(poll_interval)
        self._clock = clock
        self._sleep = sleep
        # the robot channel reads at every poll: a lasting bus fault must not
        # log a line each time
        self._read_errors = RepeatFilter(FAULT_REMINDER, clock)

    def send(self, data: bytes) -> bool:
        """Write each byte once TX ready; False (logged) on a stuck UART or bus error."""
        try:
            for position, byte in enumerate(bytes(data)):
                for _ in range(self.spin_limit):
                    if self.bus.read32(self.offset + UART_STATUS) & UART_STATUS_TX_READY:
                        break
                else:
                    log.warning("UART at %#x: TX not ready after %d polls; %d of %d bytes sent",
                                self.offset, self.spin_limit, position, len(data))
                    return False
                self.bus.write32(self.offset + UART_TXDATA, byte)
        except (OSError, ValueError) as exc:
            log.warning("UART at %#x: bus error: %s", self.offset, exc)
            return False
        return True

    def _read(self):
        """(bytes received so far, bus error or None)."""
        received = bytearray()
        try:
            while len(received) < self.READ_LIMIT \
                    and self.bus.read32(self.offset + UART_STATUS) & UART_STATUS_RX_VALID:
                received.append(self.bus.read32(self.offset + UART_RXDATA) & 0xFF)
        except (OSError, ValueError) as exc:
            return bytes(received), exc
        return bytes(received), None

    def _read_error(self, error) -> None:
        """One warning for a run of bus errors while reading, then at most one
        per :data:`~sw_hps.busfault.FAULT_REMINDER` with the count left out."""
        left_out = self._read_errors.admit("bus error while reading")
        if left_out is not None:
            log.warning("UART at %#x: bus error while reading: %s%s", self.offset, error,
                        f" ({left_out} more not logged)" if left_out else "")

    def read_available(self) -> bytes:
        """Bytes the UART has received (possibly empty; logged bus errors end it)."""
        received, error = self._read()
        if error is not None:
            self._read_error(error)
        return received

    def read_until(self, expected: bytes, timeout: float) -> bytes | None:
        """Read until ``expected`` has arrived; return everything read, or None if
        it did not arrive within ``timeout`` seconds (or the bus failed)."""
        received = bytearray()
        deadline = self._clock() + timeout
        while True:
            chunk, error = self._read()
            received += chunk
            if expected in received:
                return bytes(received)
            del received[:-4096]       # a bus reading all ones never runs dry
            if error is not None:
                self._read_error(error)
                return None
            if self._clock() >= deadline:
                log.debug("read_until %r: got %r", expected, bytes(received[-64:]))
                return None
            self._sleep(self.poll_interval)

    def close(self) -> None:
        pass


@dataclass(frozen=True)
class Delivery:
    """What became of one gesture's telegram.

    Attributes
    ----------
    telegram : bytes
        The telegram (with the reply flag when acknowledgements were asked for).
    status : str
        :data:`ACKNOWLEDGED`, :data:`UNCONFIRMED` or :data:`FAILED` (module docstring).
    written : bool
        The link took all the bytes (a result's ``sent``).
    reason : str or None
        Why it is unconfirmed or failed.
    """
    telegram: bytes
    status: str
    written: bool
    reason: str | None = None

    def describe(self) -> str:
        """For log lines: "sent" only when the brick acknowledged."""
        if self.status == ACKNOWLEDGED:
            return "sent, acknowledged by the NXT"
        if self.status == UNCONFIRMED:
            return f"written, unconfirmed ({self.reason})"
        return f"not delivered: {self.reason}"


def _write(link, data: bytes):
    """(written, reason): a link's ``send`` that must not raise, made sure not to."""
    try:
        if link.send(data):
            return True, None
        return False, "link down or write failed"
    except Exception as exc:  # a link must not raise; do not lose the result if it does
        log.error("robot link raised %s: %s", type(exc).__name__, exc)
        return False, f"link raised {type(exc).__name__}: {exc}"


def deliver_gesture(link, gesture, power=None) -> Delivery:
    """Send a gesture's telegram (with ``power``, :func:`sw_hps.telegram.telegram`)
    over ``link`` and say what became of it.

    A :class:`RobotChannel` (anything with ``send_gesture``) decides itself;
    any other link (``send(bytes) -> bool``) gives :data:`UNCONFIRMED` when it
    took the bytes, :data:`FAILED` otherwise. Never raises for the link's faults.
    """
    send_gesture = getattr(link, "send_gesture", None)
    if send_gesture is not None:
        try:
            return send_gesture(gesture) if power is None else send_gesture(gesture, power)
        except Exception as exc:
            log.error("robot link raised %s: %s", type(exc).__name__, exc)
            return Delivery(telegram(gesture, power=power), FAILED, False,
                            f"link raised {type(exc).__name__}: {exc}")
    data = telegram(gesture, power=power)
    written, reason = _write(link, data)
    if written:
        return Delivery(data, UNCONFIRMED, True, "this link cannot confirm")
    return Delivery(data, FAILED, False, reason)


class RobotChannel:
    """A link to the robot, with acknowledgements and an RN-42 kept connected
    (module docstring).

    Parameters
    ----------
    link : SerialLink, UartLink, NullLink or similar
        The transport (``send``; ``read_available`` for acknowledgements and
        the RN-42's status strings).
    ack_timeout : float, optional
        Ask the brick to confirm each telegram and wait this many seconds (in
        :data:`ACK_TIMEOUT_RANGE`) for its reply; None: telegrams without the
        reply flag, byte for byte those of :func:`sw_hps.telegram.telegram`.
    rn42_address : str, optional
        The brick's address: an RN-42 on ``link`` is set up (again) to connect
        to it. Needs a link that can read.
    setup_timeout : float
        Seconds :func:`configure_rn42` waits for each reply.
    connect_wait : float
        Seconds a set-up waits for ``%CONNECT`` before the telegram is sent anyway.
    failures_before_setup : int
        Consecutive sends without a reply (``ack_timeout`` set) before a set-up.
    initial_backoff, max_backoff : float
        Delay before the first set-up after trouble, doubled after each set-up
        that did not bring the brick back, up to ``max_backoff``.
    clock, sleep : callable
        Monotonic seconds and ``sleep(seconds)`` (injectable for tests).

    Attributes
    ----------
    while_waiting : callable or None
        Called with no argument at least every :data:`WAIT_SLICE` seconds while
        the channel waits (a reply, the RN-42's guard time, its connection), so
        that the caller's loop keeps up with its inputs meanwhile (the
        streaming loop reads the FIFO and the posture slave, which keeps only
        the latest record). It must not send and must not raise.
    """

    def __init__(self, link, *, ack_timeout: float | None = None,
                 rn42_address: str | None = None, setup_timeout: float = 2.0,
                 connect_wait: float = 2.0,
                 failures_before_setup: int = RN42_FAILURES_BEFORE_SETUP,
                 initial_backoff: float = 2.0, max_backoff: float = 60.0,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep):
        low, high = ACK_TIMEOUT_RANGE
        if ack_timeout is not None and not (isinstance(ack_timeout, (int, float))
                                            and low <= ack_timeout <= high):
            raise ValueError(f"ack_timeout must be in [{low:g}, {high:g}] seconds, "
                             f"got {ack_timeout!r}")
        if rn42_address is not None:
            rn42_address = normalise_bt_address(rn42_address)
            if not _can_read(link):
                raise ValueError(f"rn42_address needs a link that can read, got "
                                 f"{type(link).__name__}")
        if ack_timeout is not None and not _can_read(link):
            log.info("robot link %s cannot read replies: deliveries stay unconfirmed",
                     type(link).__name__)
        if isinstance(failures_before_setup, bool) or not isinstance(failures_before_setup, int) \
                or failures_before_setup < 1:
            raise ValueError(f"failures_before_setup must be an int >= 1, "
                             f"got {failures_before_setup!r}")
        if not (initial_backoff >= RN42_GUARD_TIME and max_backoff >= initial_backoff):
            raise ValueError(f"initial_backoff must be >= {RN42_GUARD_TIME:g} s (the RN-42's "
                             f"guard time) and max_backoff >= initial_backoff, got "
                             f"{initial_backoff!r}, {max_backoff!r}")
        self.link = link
        self.ack_timeout = None if ack_timeout is None else float(ack_timeout)
        self.rn42_address = rn42_address
        self.setup_timeout = float(setup_timeout)
        self.connect_wait = float(connect_wait)
        self.failures_before_setup = failures_before_setup
        self.initial_backoff = float(initial_backoff)
        self.max_backoff = float(max_backoff)
        self._clock = clock
        self._sleep = sleep
        self._reads = _can_read(link)
        #: Consecutive sends the brick did not answer (``ack_timeout`` set).
        self.consecutive_failures = 0
        #: RN-42 set-ups run so far (including the one at start).
        self.setups = 0
        #: Delay before the next set-up once trouble is seen.
        self.backoff = self.initial_backoff
        #: Clock time of the next set-up, None while none is due.
        self.setup_due = None
        #: Deliveries so far by status.
        self.deliveries = {ACKNOWLEDGED: 0, UNCONFIRMED: 0, FAILED: 0}
        self._recovering = False
        self._attempt = 0             # set-ups since the trouble began
        self._logged_backoff = None
        self._last_write = float("-inf")
        self._tail = b""              # end of the last bytes read (split status strings)
        self._opens = getattr(link, "opens", None)
        self._told_no_address = False
        self.while_waiting: Callable[[], None] | None = None

    # ---- the RN-42 ---------------------------------------------------------------
    def setup(self) -> bool:
        """Set the RN-42 up now (after the guard time since the last write),
        unless the brick answers a probe (:func:`sw_hps.telegram.probe_telegram`)
        first: a connected module would pass ``$$$`` on to the brick as data.

        Returns
        -------
        bool
            True if the brick answered, or once the connect command went out
            (see :func:`configure_rn42`).
        """
        if self.rn42_address is None:
            raise ValueError("setup needs rn42_address")
        # A connected RN-42 passes '$$$' on to the brick as data, which garbles
        # its framing of every telegram after: set it up only if the brick is
        # out of reach (a restarted application, telegrams lost on the bus).
        if self._brick_answers():
            log.info("robot link: the NXT answers; no RN-42 set-up needed")
            self.setup_due = None
            self._healthy()
            return True
        quiet = self._clock() - self._last_write
        if quiet < RN42_GUARD_TIME:
            self._pause(RN42_GUARD_TIME - quiet)
        self.setups += 1
        self.setup_due = None
        # the first attempt says why it failed; later ones are summed up by _schedule
        done = configure_rn42(self.link, self.rn42_address, timeout=self.setup_timeout,
                              level=logging.WARNING if self._attempt <= 1 else logging.DEBUG)
        self._last_write = self._clock()
        self._opens = getattr(self.link, "opens", None)
        if done:
            self._await_connect()
        return done

    def _brick_answers(self) -> bool:
        """Whether the brick answers a probe (:func:`sw_hps.telegram.probe_telegram`)
        within ``ack_timeout`` (default :data:`DEFAULT_ACK_TIMEOUT`)."""
        self._watch(self.link.read_available())      # drops stale bytes
        written, _ = _write(self.link, probe_telegram())
        self._last_write = self._clock()
        return written and self._await_reply(self.ack_timeout or DEFAULT_ACK_TIMEOUT) is not None

    def _await_connect(self) -> None:
        deadline = self._clock() + self.connect_wait
        while self._clock() < deadline:
            if self._watch(self.link.read_available()) == "connect":
                return
            self._pause(0.01)
        log.info("RN-42: no %s within %.1f s (status strings off until the module restarts, "
                 "or not connected yet)", RN42_CONNECT.decode(), self.connect_wait)

    def _schedule(self, reason: str, delay: float | None = None) -> None:
        if self.rn42_address is None:
            if not self._told_no_address:
                log.warning("robot link: %s (with an RN-42, --rn42-address lets the app "
                            "set it up again)", reason)
                self._told_no_address = True
            return
        if self.setup_due is not None:
            return
        delay = self.backoff if delay is None else delay
        self.setup_due = self._clock() + delay
        self._recovering = True
        if self._logged_backoff != self.backoff:    # once per back-off level
            self._logged_backoff = self.backoff
            log.warning("robot link: %s; setting the RN-42 up again in %.1f s (attempt %d)",
                        reason, delay, self._attempt + 1)
        else:
            log.debug("robot link: %s; RN-42 set-up again in %.1f s", reason, delay)

    def _healthy(self) -> None:
        self.consecutive_failures = 0
        if self._recovering:
            log.info("robot link: the NXT is reachable again (after %d RN-42 set-ups)",
                     self._attempt)
        self._recovering = False
        self._attempt = 0
        self.backoff = self.initial_backoff
        self._logged_backoff = None

    def _watch(self, received: bytes):
        """Note the RN-42's status strings in ``received``; the last one seen
        (``"connect"``, ``"disconnect"`` or None)."""
        if not received:
            return None
        text = self._tail + received
        up, down = text.rfind(RN42_CONNECT), text.rfind(RN42_DISCONNECT)
        end = max(up + len(RN42_CONNECT) if up >= 0 else 0,
                  down + len(RN42_DISCONNECT) if down >= 0 else 0)
        # keep what a status string split over two reads may have begun with
        self._tail = text[end:][-(len(RN42_DISCONNECT) - 1):]
        if up < 0 and down < 0:
            return None
        if up > down:
            log.info("RN-42 reports %s", RN42_CONNECT.decode())
            self._healthy()
            return "connect"
        self._schedule(f"RN-42 reports {RN42_DISCONNECT.decode()}")
        return "disconnect"

    def _before_send(self) -> None:
        opens = getattr(self.link, "opens", None)
        if self.rn42_address is not None and opens != self._opens and opens:
            self._opens = opens
            self._schedule("serial port reopened", delay=0.0)
        if self._reads and (self.ack_timeout is not None or self.rn42_address is not None):
            self._watch(self.link.read_available())    # also drops stale replies
        self.maintain()

    def maintain(self) -> None:
        """Run a set-up that is due (after trouble, :meth:`_schedule`). Called
        before each telegram, and by the loops while they idle, so that the
        set-up's seconds pass between gestures rather than right after one."""
        if self.setup_due is not None and self._clock() >= self.setup_due:
            self._attempt += 1
            done = self.setup()
            self.backoff = min(self.backoff * 2, self.max_backoff)
            if not done:
                self._schedule("RN-42 set-up failed")

    # ---- sending -----------------------------------------------------------------
    def send(self, data: bytes) -> bool:
        """Raw bytes to the link (no telegram, no acknowledgement)."""
        written, _ = _write(self.link, data)
        self._last_write = self._clock()
        return written

    def send_gesture(self, gesture, power=None) -> Delivery:
        """Send a gesture's telegram (with ``power``); the :class:`Delivery` says
        what became of it."""
        self._before_send()
        asks = self.ack_timeout is not None
        data = telegram(gesture, reply=asks, power=power)
        written, reason = _write(self.link, data)
        self._last_write = self._clock()
        if not written:
            return self._done(Delivery(data, FAILED, False, reason), lost=asks)
        if not asks:
            return self._done(Delivery(data, UNCONFIRMED, True, "no --robot-ack"))
        if not self._reads:
            return self._done(Delivery(data, UNCONFIRMED, True, "this link cannot read replies"))
        status = self._await_reply()
        if status is None:
            return self._done(Delivery(data, FAILED, True,
                                       f"no reply from the NXT within {self.ack_timeout:g} s"),
                              lost=True)
        self._healthy()            # the brick answered: the link works
        if status != 0:
            return self._done(Delivery(data, FAILED, True,
                                       f"the NXT answered status {status_text(status)}"))
        return self._done(Delivery(data, ACKNOWLEDGED, True))

    def _await_reply(self, timeout: float | None = None):
        """The status of the brick's next MessageWrite reply, or None after
        ``timeout`` seconds (default ``ack_timeout``)."""
        received = b""
        deadline = self._clock() + (self.ack_timeout if timeout is None else timeout)
        while True:
            chunk = self.link.read_available()
            if chunk:
                received = (received + chunk)[-64:]   # a reply is 5 bytes
                self._watch(chunk)
                status = find_reply(received)
                if status is not None:
                    return status
            if self._clock() >= deadline:
                if received:
                    log.debug("no MessageWrite reply in %s", hex_bytes(received))
                return None
            self._pause(0.002)

    def _pause(self, seconds: float) -> None:
        """Sleep ``seconds``, running :attr:`while_waiting` first and then at
        least every :data:`WAIT_SLICE` seconds."""
        if self.while_waiting is None:
            self._sleep(seconds)
            return
        end = self._clock() + seconds
        while True:
            self.while_waiting()
            left = end - self._clock()
            if left <= 0:
                return
            self._sleep(min(left, WAIT_SLICE))

    def _done(self, delivery: Delivery, lost: bool = False) -> Delivery:
        self.deliveries[delivery.status] += 1
        if lost:
            self.consecutive_failures += 1
            if self.consecutive_failures >= self.failures_before_setup:
                self._schedule(f"{self.consecutive_failures} telegrams in a row not answered")
        return delivery

    def close(self) -> None:
        self.link.close()
