"""Tests for sw_hps.robot: NXT telegrams and the links to the robot (thesis §7.4.1, §8.5)."""
import logging
import os
import re
import threading
import time

import pytest

from sw_hps.bus import SimBus
from soc.hps_interface import UART_RXDATA, UART_STATUS, UART_TXDATA
from sw_hps.robot import (ACKNOWLEDGED, FAILED, RN42_GUARD_TIME, UNCONFIRMED, Delivery, NullLink,
                          RobotChannel, SerialLink, UartLink, configure_rn42, deliver_gesture,
                          normalise_bt_address)
from sw_hps.telegram import GESTURE_NAMES, find_reply, gesture_index, status_text, telegram
from sw_hps.simulated import SimulatedRn42, SimulatedUart


# ---- telegrams --------------------------------------------------------------------------
def test_telegram_table():
    assert telegram("forward") == bytes.fromhex("06 00 80 09 00 02 31 00")
    for index, name in enumerate(GESTURE_NAMES):
        expected = bytes([6, 0, 0x80, 0x09, 0, 2, ord("1") + index, 0])
        assert telegram(name) == telegram(index) == expected
    assert GESTURE_NAMES == ("forward", "back", "right", "left", "rotate-right",
                             "rotate-left", "stop")


def test_telegrams_match_nxt_python_framing():
    """Oracle: nxt-python's own telegram and its Bluetooth backend's framing."""
    bluetooth = pytest.importorskip("nxt.backend.bluetooth")  # a dev tool: not on the board's floor
    import nxt.telegram as nxt_telegram

    class CaptureSocket:
        def __init__(self):
            self.sent = b""

        def send(self, data):
            self.sent += data

    for index, name in enumerate(GESTURE_NAMES):
        message = str(index + 1).encode()
        tgram = nxt_telegram.Telegram(nxt_telegram.Opcode.DIRECT_MESSAGE_WRITE, reply_req=False)
        tgram.add_u8(0)
        tgram.add_u8(len(message) + 1)
        tgram.add_bytes(message)
        tgram.add_u8(0)
        sock = bluetooth.BluetoothSock(None, "00:00:00:00:00:00")
        sock._sock = CaptureSocket()  # the backend frames, the capture records
        sock.send(tgram.to_bytes())
        assert telegram(name) == sock._sock.sent


@pytest.mark.parametrize("bad", ["jump", 7, -1, True, 1.0, None, "Forward"])
def test_telegram_rejects_unknown_gestures(bad):
    with pytest.raises(ValueError, match="gesture"):
        telegram(bad)


def test_gesture_index():
    assert gesture_index("stop") == 6 and gesture_index(2) == 2


def test_null_link_records():
    link = NullLink(keep=2)
    for name in ("forward", "back", "stop"):
        assert link.send(telegram(name))
    assert list(link.sent) == [telegram("back"), telegram("stop")]


# ---- serial link over a pty pair --------------------------------------------------------
class FakeClock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now


def read_exactly(fd, count, timeout=2.0):
    data = bytearray()
    deadline = time.monotonic() + timeout
    os.set_blocking(fd, False)
    while len(data) < count and time.monotonic() < deadline:
        try:
            data += os.read(fd, count - len(data))
        except BlockingIOError:
            time.sleep(0.005)
    return bytes(data)


@pytest.fixture
def pty_pair():
    master, slave = os.openpty()
    name = os.ttyname(slave)
    os.close(slave)
    yield master, name
    try:
        os.close(master)
    except OSError:
        pass


def test_serial_link_sends_bytes_exactly_raw(pty_pair):
    master, name = pty_pair
    link = SerialLink(name, 115200)
    assert link.connected
    # \n, \r, ^C, XON, XOFF would be translated or eaten by a cooked tty.
    payload = b"".join(telegram(g) for g in GESTURE_NAMES) + b"\n\r\x03\x11\x13\x7f\xff"
    assert link.send(payload)
    assert read_exactly(master, len(payload)) == payload
    os.write(master, b"hello")
    assert link.read_until(b"lo", timeout=1.0) == b"hello"
    link.close()
    assert not link.connected


def test_serial_link_rejects_bad_baudrate():
    with pytest.raises(ValueError, match="baudrate"):
        SerialLink("/dev/null", 123)


def test_serial_link_reconnects_with_growing_backoff(tmp_path):
    clock = FakeClock()
    master, slave = os.openpty()
    device = tmp_path / "rfcomm0"
    device.symlink_to(os.ttyname(slave))
    os.close(slave)
    link = SerialLink(str(device), clock=clock, initial_backoff=0.5, max_backoff=4.0)
    assert link.send(b"ok") and read_exactly(master, 2) == b"ok"

    # The adapter vanishes: the node disappears and the peer hangs up.
    device.unlink()
    os.close(master)
    assert link.send(telegram("stop")) is False        # write fails: no exception
    assert not link.connected
    attempts_at = [clock.now]
    attempts = link.open_attempts
    for _ in range(240):                               # 30 s of sends every 1/8 s
        clock.now += 0.125
        assert link.send(b"x") is False
        if link.open_attempts != attempts:
            attempts = link.open_attempts
            attempts_at.append(clock.now)
    gaps = [b - a for a, b in zip(attempts_at, attempts_at[1:])]
    assert gaps[:4] == [0.5, 1.0, 2.0, 4.0]
    assert set(gaps[3:]) == {4.0}                      # capped at max_backoff

    # It comes back: the next send after the back-off succeeds.
    master, slave = os.openpty()
    device.symlink_to(os.ttyname(slave))
    os.close(slave)
    try:
        clock.now += 4.0
        assert link.send(b"back") is True
        assert read_exactly(master, 4) == b"back"
        assert link.backoff == 0.5
    finally:
        link.close()
        os.close(master)


def test_serial_link_missing_device_starts_disconnected(tmp_path):
    clock = FakeClock()
    link = SerialLink(str(tmp_path / "none"), clock=clock)
    assert not link.connected and link.open_attempts == 1
    assert link.send(b"a") is False and link.open_attempts == 1   # still backing off
    assert link.read_until(b"x", 0.01) is None
    assert link.read_available() == b""


# ---- RN-42 set-up ------------------------------------------------------------------------
def rn42_peer(master, answers, log, stop):
    os.set_blocking(master, False)
    buffer = b""
    while not stop.is_set():
        try:
            buffer += os.read(master, 100)
        except BlockingIOError:
            time.sleep(0.002)
            continue
        except OSError:
            return
        for command, reply in answers.items():
            if command in buffer:
                log.append(command)
                buffer = buffer.replace(command, b"", 1)
                if reply:
                    os.write(master, reply)
        if b"\r" in buffer and buffer.startswith(b"C,"):
            log.append(buffer)
            buffer = b""


def test_configure_rn42_with_an_answering_module(pty_pair):
    master, name = pty_pair
    log, stop = [], threading.Event()
    link = SerialLink(name)     # first: a master reads EIO while no slave is open
    peer = threading.Thread(target=rn42_peer, args=(
        master, {b"$$$": b"CMD\r\n", b"SM,1\r": b"AOK\r\n", b"SO,%\r": b"AOK\r\n"}, log, stop),
        daemon=True)
    peer.start()
    try:
        assert configure_rn42(link, "00:16:53:0a:0b:0c", timeout=2.0) is True
        deadline = time.monotonic() + 2
        while len(log) < 4 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert log == [b"$$$", b"SM,1\r", b"SO,%\r", b"C,0016530A0B0C\r"]
    finally:
        stop.set()
        peer.join(2)
        link.close()


def test_configure_rn42_fails_within_timeout_on_a_silent_module(pty_pair, caplog):
    master, name = pty_pair
    link = SerialLink(name)
    start = time.monotonic()
    assert configure_rn42(link, "0016530A0B0C", timeout=0.2) is False
    assert time.monotonic() - start < 1.0
    assert "no 'CMD' reply" in caplog.text
    assert read_exactly(master, 3, timeout=0.5) == b"$$$"
    link.close()


def test_configure_rn42_fails_when_aok_missing(pty_pair, caplog):
    master, name = pty_pair
    log, stop = [], threading.Event()
    link = SerialLink(name)
    peer = threading.Thread(target=rn42_peer, args=(master, {b"$$$": b"CMD\r\n", b"SM,1\r": b""},
                                                    log, stop), daemon=True)
    peer.start()
    try:
        assert configure_rn42(link, "0016530A0B0C", timeout=0.2) is False
        assert log == [b"$$$", b"SM,1\r"] and "no 'AOK' reply" in caplog.text
    finally:
        stop.set()
        peer.join(2)
        link.close()


@pytest.mark.parametrize("bad", ["0016530A0B0", "0016530A0B0G", "00:16:53:0A:0B",
                                 "00-16-53-0A-0B-0C",
                                 "0:016:53:0A:0B:0C", 16530, None])
def test_bluetooth_address_validation(bad):
    with pytest.raises(ValueError, match="address"):
        normalise_bt_address(bad)
    with pytest.raises(ValueError, match="address"):
        configure_rn42(NullLink(), bad)


def test_bluetooth_address_normalised():
    assert normalise_bt_address("00:16:53:0a:0b:0c") == "0016530A0B0C"
    assert normalise_bt_address("0016530a0b0c") == "0016530A0B0C"


# ---- FPGA UART ----------------------------------------------------------------------------
def test_uart_register_map():
    assert (UART_TXDATA, UART_STATUS, UART_RXDATA) == (0x00, 0x04, 0x08)


def test_uart_link_waits_for_tx_ready():
    uart = SimulatedUart(busy_reads=3)
    bus = SimBus()
    bus.attach(0x100, uart)
    link = UartLink(bus, 0x100)
    data = telegram("rotate-left")
    assert link.send(data)
    assert bytes(uart.transmitted) == data and uart.overruns == 0


def test_uart_link_gives_up_on_a_stuck_uart():
    uart = SimulatedUart(stuck=True)
    link = UartLink(SimBus(uart), 0, spin_limit=50)
    start = time.monotonic()
    assert link.send(b"abc") is False
    assert time.monotonic() - start < 0.5 and not uart.transmitted


def test_uart_link_reports_bus_errors():
    class BrokenBus:
        def read32(self, offset):
            raise OSError(5, "bridge error")

        def write32(self, offset, value):
            raise OSError(5, "bridge error")

    assert UartLink(BrokenBus(), 0x100).send(b"a") is False
    with pytest.raises(ValueError, match="offset"):
        UartLink(BrokenBus(), 3)


def test_simulated_uart_receive_side():
    uart = SimulatedUart()
    uart.receive_queue.extend(b"ok")
    assert uart.read32(UART_STATUS) == 3
    assert bytes([uart.read32(UART_RXDATA), uart.read32(UART_RXDATA)]) == b"ok"
    assert uart.read32(UART_STATUS) == 1


# ---- acknowledged telegrams (--robot-ack) ------------------------------------------------
def test_reply_flag_changes_only_the_command_type():
    for name in GESTURE_NAMES:
        plain, asking = telegram(name), telegram(name, reply=True)
        assert plain[2] == 0x80 and asking[2] == 0x00
        assert plain[:2] + plain[3:] == asking[:2] + asking[3:]
        # 0x25 '%' would break an RN-42 master's connection (its status string's
        # first character), 0x0D would end an RN-42 command line
        assert 0x25 not in plain + asking and 0x0D not in plain + asking
    assert telegram("forward", reply=True) == bytes.fromhex("06 00 00 09 00 02 31 00")


def test_reply_telegrams_and_replies_match_nxt_python():
    """Oracle: nxt-python builds the same reply-required MessageWrite, and its
    reply parser agrees with find_reply on the status of the same bytes."""
    nxt_telegram = pytest.importorskip("nxt.telegram")   # a dev tool: not on the board's floor
    import nxt.error

    for index, name in enumerate(GESTURE_NAMES):
        tgram = nxt_telegram.Telegram(nxt_telegram.Opcode.DIRECT_MESSAGE_WRITE)
        assert tgram.reply_req
        tgram.add_u8(0)
        tgram.add_u8(2)
        tgram.add_bytes(str(index + 1).encode())
        tgram.add_u8(0)
        body = tgram.to_bytes()
        assert telegram(name, reply=True) == bytes([len(body), 0]) + body
    for status in (0x00, 0xEC, 0xEE, 0xDF):
        body = bytes([0x02, 0x09, status])
        reply = nxt_telegram.Telegram(nxt_telegram.Opcode.DIRECT_MESSAGE_WRITE, pkt=body)
        if status:
            with pytest.raises(nxt.error.DirectProtocolError) as raised:
                reply.check_status()
            assert str(raised.value).startswith(status_text(status).split("(")[1][:-1])
        else:
            reply.check_status()
        assert find_reply(b"%CONNECT\r\n" + bytes([3, 0]) + body + b"\x06") == status


def test_find_reply_needs_the_whole_reply():
    reply = bytes.fromhex("03 00 02 09 00")
    assert find_reply(reply) == 0
    assert find_reply(reply[:-1]) is None and find_reply(b"") is None
    assert find_reply(bytes.fromhex("03 00 02 13 00")) is None      # not a MessageWrite reply
    assert status_text(0xEC) == "0xec (no active program)"
    assert status_text(0x42) == "0x42 (unknown status)"


# ---- the FPGA UART's receiver --------------------------------------------------------------
class FakeTime:
    """A monotonic clock and a sleep that advances it."""

    def __init__(self):
        self.now = 1000.0
        self.slept = []

    def clock(self):
        return self.now

    def sleep(self, seconds):
        self.slept.append(seconds)
        self.now += seconds


def uart_robot(fake, **rn42_options):
    """An RN-42 (and brick) on a simulated FPGA UART, read with a fake clock."""
    rn42 = SimulatedRn42(clock=fake.clock, **rn42_options)
    uart = SimulatedUart(responder=rn42)
    link = UartLink(SimBus(uart), 0, clock=fake.clock, sleep=fake.sleep)
    return rn42, uart, link


def test_uart_link_reads_what_the_uart_received():
    fake = FakeTime()
    uart = SimulatedUart()
    link = UartLink(SimBus(uart), 0, clock=fake.clock, sleep=fake.sleep, poll_interval=0.01)
    assert link.read_available() == b""
    uart.receive_queue.extend(b"CMD\r\nrest")
    assert link.read_until(b"CMD", timeout=1.0) == b"CMD\r\nrest"
    assert fake.slept == [] and not uart.receive_queue
    start = fake.now
    assert link.read_until(b"AOK", timeout=0.5) is None            # nothing comes
    assert 0.5 <= fake.now - start <= 0.52 and set(fake.slept) == {0.01}


def test_uart_link_reads_are_bounded_on_a_bus_of_ones_and_stop_on_bus_errors(caplog):
    class Ones:
        def read32(self, offset):
            return 0xFFFFFFFF

        def write32(self, offset, value):
            pass

    fake = FakeTime()
    link = UartLink(Ones(), 0, clock=fake.clock, sleep=fake.sleep)
    assert link.read_available() == b"\xff" * UartLink.READ_LIMIT
    assert link.read_until(b"CMD", timeout=0.1) is None              # returns at the deadline

    class Broken(Ones):
        def read32(self, offset):
            raise OSError(5, "bridge error")

    link = UartLink(Broken(), 0, clock=fake.clock, sleep=fake.sleep)
    start = fake.now
    assert link.read_until(b"CMD", timeout=5.0) is None and fake.now == start
    assert link.read_available() == b"" and "bus error while reading" in caplog.text
    # A lasting fault, read at every poll, is one line, then one a minute with the count.
    caplog.clear()
    for _ in range(600):                         # ten seconds of polls
        link.read_available()
        fake.sleep(1 / 60)
    assert caplog.text.count("bus error while reading") == 0   # still within the minute
    fake.sleep(60)
    link.read_available()
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and lines[0].endswith("(601 more not logged)"), lines
    with pytest.raises(ValueError, match="poll_interval"):
        UartLink(Ones(), 0, poll_interval=0)


# ---- RN-42 on the FPGA UART ---------------------------------------------------------------
def test_configure_rn42_over_the_fpga_uart():
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, nxt_address="0016530A0B0C")
    assert not rn42.connected
    fake.now += RN42_GUARD_TIME                        # quiet since power-up
    assert configure_rn42(link, "00:16:53:0a:0b:0c", timeout=2.0) is True
    assert rn42.commands == [b"$$$", b"SM,1", b"SO,%", b"C,0016530A0B0C"]
    assert rn42.connected and bytes(uart.transmitted).startswith(b"$$$SM,1\r")


def test_configure_rn42_fails_in_bounded_time_when_the_module_is_connected(caplog):
    """A connected master passes $$$ to the brick: no CMD, False after the timeout."""
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, nxt_address="0016530A0B0C", connected=True)
    start = fake.now
    assert configure_rn42(link, "0016530A0B0C", timeout=0.4) is False
    assert 0.4 <= fake.now - start < 0.45 and "no 'CMD' reply" in caplog.text
    assert rn42.commands == [] and bytes(uart.transmitted) == b"$$$"


def test_configure_rn42_needs_a_link_that_reads():
    with pytest.raises(ValueError, match="read"):
        configure_rn42(NullLink(), "0016530A0B0C")


# ---- deliveries ---------------------------------------------------------------------------
def test_without_robot_ack_telegrams_are_unchanged_and_unconfirmed():
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake)               # connected, brick answers if asked
    channel = RobotChannel(link, clock=fake.clock, sleep=fake.sleep)
    deliveries = [channel.send_gesture(name) for name in GESTURE_NAMES]
    assert bytes(uart.transmitted) == b"".join(telegram(name) for name in GESTURE_NAMES)
    assert {d.status for d in deliveries} == {UNCONFIRMED} and all(d.written for d in deliveries)
    assert deliveries[0].describe() == "written, unconfirmed (no --robot-ack)"
    assert rn42.messages == [str(n).encode() for n in range(1, 8)]
    assert not uart.receive_queue and fake.slept == []   # no reply asked, none awaited


def test_robot_ack_acknowledged():
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake)
    channel = RobotChannel(link, ack_timeout=0.3, clock=fake.clock, sleep=fake.sleep)
    delivery = channel.send_gesture("left")
    assert delivery == Delivery(telegram("left", reply=True), ACKNOWLEDGED, True)
    assert delivery.describe() == "sent, acknowledged by the NXT"
    assert bytes(uart.transmitted) == telegram("left", reply=True) and rn42.messages == [b"4"]
    assert channel.deliveries == {ACKNOWLEDGED: 1, UNCONFIRMED: 0, FAILED: 0}


def test_robot_ack_nak_is_failed_but_the_link_is_fine():
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, nxt_status=0xEC)     # no program running on the brick
    channel = RobotChannel(link, ack_timeout=0.3, clock=fake.clock, sleep=fake.sleep)
    for _ in range(5):
        delivery = channel.send_gesture("stop")
        assert delivery.status == FAILED and delivery.written
        assert delivery.describe() == \
            "not delivered: the NXT answered status 0xec (no active program)"
    assert channel.consecutive_failures == 0 and channel.setup_due is None


def test_robot_ack_missing_reply_fails_within_the_timeout():
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, connected=False)     # nobody at the far end
    channel = RobotChannel(link, ack_timeout=0.3, clock=fake.clock, sleep=fake.sleep)
    start = fake.now
    delivery = channel.send_gesture("back")
    assert delivery.status == FAILED and delivery.written
    assert delivery.reason == "no reply from the NXT within 0.3 s"
    assert 0.3 <= fake.now - start < 0.31 and channel.consecutive_failures == 1


def test_while_waiting_runs_through_every_wait():
    """The caller's loop keeps up while the channel waits for a reply and
    through an RN-42 set-up: called at once, then at least every WAIT_SLICE."""
    from sw_hps.robot import WAIT_SLICE
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, connected=False)
    channel = RobotChannel(link, ack_timeout=0.3, rn42_address="00:16:53:0a:0b:0c",
                           clock=fake.clock, sleep=fake.sleep)
    calls = []
    channel.while_waiting = lambda: calls.append(fake.now)
    start = fake.now
    assert channel.send_gesture("back").status == FAILED
    assert calls[0] == start and fake.now - start >= 0.3
    assert max(b - a for a, b in zip(calls, calls[1:])) <= WAIT_SLICE + 1e-9
    calls.clear()
    channel.setup()                     # the guard time (1 s) and the wait for CONNECT
    assert len(calls) >= 1.0 / WAIT_SLICE
    assert max(b - a for a, b in zip(calls, calls[1:])) <= WAIT_SLICE + 1e-9


@pytest.mark.parametrize("ack", [None, 0.3])
def test_setup_leaves_a_connected_module_alone(ack):
    """An application started again finds the RN-42 connected: the probe is
    answered, no '$$$' reaches the brick as data, and telegrams still arrive."""
    from sw_hps.telegram import PROBE_INBOX, probe_telegram
    address = "00:16:53:0a:0b:0c"
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, nxt_address=address, connected=True)
    channel = RobotChannel(link, ack_timeout=ack, rn42_address=address, clock=fake.clock,
                           sleep=fake.sleep)
    assert channel.setup() and channel.setups == 0 and rn42.commands == []
    assert bytes(uart.transmitted) == probe_telegram() and probe_telegram()[4] == PROBE_INBOX
    assert channel.send_gesture("back").written
    assert rn42.messages[-1] == b"2"                 # framed right after the probe
    # Not connected: the probe goes unanswered and the module is set up.
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, nxt_address=address, connected=False)
    channel = RobotChannel(link, ack_timeout=ack, rn42_address=address, clock=fake.clock,
                           sleep=fake.sleep)
    assert channel.setup() and channel.setups == 1 and rn42.connected
    assert b"$$$" in rn42.commands


def test_maintain_runs_a_due_set_up_while_idle():
    """The loops call maintain() while they idle: a set-up that is due runs
    then, so the next telegram goes out without waiting for it."""
    fake = FakeTime()
    rn42, uart, channel = set_up_channel(fake)
    rn42.drop()
    rn42.reachable = False
    for _ in range(3):
        channel.send_gesture("left")
    due = channel.setup_due
    setups = channel.setups
    channel.maintain()                               # not due yet: nothing
    assert channel.setups == setups and channel.setup_due == due
    rn42.reachable = True
    fake.now = due
    channel.maintain()
    assert channel.setups == setups + 1 and channel.setup_due is None and rn42.connected
    start = fake.now
    assert channel.send_gesture("left").status == ACKNOWLEDGED and fake.now - start < 0.01


def test_stale_reply_does_not_acknowledge_the_next_telegram():
    fake = FakeTime()
    rn42, uart, link = uart_robot(fake, connected=False)
    channel = RobotChannel(link, ack_timeout=0.3, clock=fake.clock, sleep=fake.sleep)
    uart.receive_queue.extend(bytes.fromhex("03 00 02 09 00"))   # late answer to an old one
    assert channel.send_gesture("back").status == FAILED


def test_links_that_cannot_read_or_that_raise():
    channel = RobotChannel(NullLink(), ack_timeout=0.3)
    delivery = channel.send_gesture("forward")
    assert delivery.status == UNCONFIRMED and delivery.reason == "this link cannot read replies"
    assert channel.link.sent[-1] == telegram("forward", reply=True)

    class Exploding:
        def send(self, data):
            raise RuntimeError("boom")

    delivery = deliver_gesture(Exploding(), "stop")
    assert (delivery.status, delivery.written, delivery.telegram) == (FAILED, False,
                                                                      telegram("stop"))
    assert delivery.describe() == "not delivered: link raised RuntimeError: boom"
    assert deliver_gesture(NullLink(), "stop").status == UNCONFIRMED
    with pytest.raises(ValueError, match="ack_timeout"):
        RobotChannel(NullLink(), ack_timeout=10)
    with pytest.raises(ValueError, match="read"):
        RobotChannel(NullLink(), rn42_address="0016530A0B0C")


# ---- RN-42 reconnection --------------------------------------------------------------------
def set_up_channel(fake, **rn42_options):
    rn42, uart, link = uart_robot(fake, nxt_address="0016530A0B0C", **rn42_options)
    channel = RobotChannel(link, ack_timeout=0.3, rn42_address="0016530A0B0C",
                           initial_backoff=2.0, max_backoff=16.0,
                           clock=fake.clock, sleep=fake.sleep)
    fake.now += RN42_GUARD_TIME
    assert channel.setup() and rn42.connected
    return rn42, uart, channel


def test_rn42_disconnect_string_sets_the_module_up_again(caplog):
    fake = FakeTime()
    rn42, uart, channel = set_up_channel(fake, status_prefix=b"%")
    assert channel.send_gesture("forward").status == ACKNOWLEDGED
    uart.receive_queue.extend(rn42.drop())           # brick out of range: "%DISCONNECT"
    caplog.set_level(logging.INFO)
    assert channel.send_gesture("back").status == FAILED
    assert channel.setup_due == pytest.approx(fake.now - 0.3 + 2.0, abs=0.01)
    assert "RN-42 reports %DISCONNECT; setting the RN-42 up again in 2.0 s" in caplog.text
    fake.now = channel.setup_due                     # the next gesture after the back-off
    delivery = channel.send_gesture("stop")
    assert delivery.status == ACKNOWLEDGED and rn42.connected and channel.setups == 2
    assert rn42.commands[-4:] == [b"$$$", b"SM,1", b"SO,%", b"C,0016530A0B0C"]
    assert rn42.messages == [b"1", b"7"]             # "back" went nowhere
    assert "the NXT is reachable again (after 1 RN-42 set-ups)" in caplog.text
    assert channel.backoff == 2.0


def test_rn42_silent_drop_found_by_missing_replies_with_capped_backoff(caplog):
    """No status strings: three unanswered telegrams start set-ups; they back
    off 2, 4, 8, 16, 16 s while the brick is away; one warning per level."""
    fake = FakeTime()
    rn42, uart, channel = set_up_channel(fake)
    rn42.drop()
    rn42.reachable = False
    caplog.set_level(logging.DEBUG, logger="sw_hps.robot")
    for _ in range(3):
        assert channel.send_gesture("left").status == FAILED
    assert channel.setup_due == pytest.approx(fake.now + 2.0)
    attempts = []
    for _ in range(200):                             # a gesture every 0.5 s
        fake.now += 0.5
        setups = channel.setups
        channel.send_gesture("left")
        if channel.setups != setups:
            attempts.append(fake.now)
    delays = [float(d) for d in re.findall(r"again in ([0-9.]+) s", caplog.text)]
    assert delays[:6] == [2.0, 4.0, 8.0, 16.0, 16.0, 16.0] and set(delays[3:]) == {16.0}
    # between two set-ups: the back-off; the set-up's unanswered probe and the
    # guard time after it (1 s), its wait for %CONNECT (2 s); the unanswered
    # telegram (0.3 s) and the wait for the next gesture (< 0.8 s)
    gaps = [b - a for a, b in zip(attempts, attempts[1:])]
    assert all(d + 3.3 <= g <= d + 3.3 + 0.8 for d, g in zip(delays[1:], gaps)), (delays, gaps)
    warnings = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert [r.getMessage().split("; ")[1] for r in warnings if "up again" in r.getMessage()] \
        == ["setting the RN-42 up again in {:.1f} s (attempt {})".format(d, n)
            for n, d in enumerate((2.0, 4.0, 8.0, 16.0), start=1)]
    assert len(warnings) <= 4 + 1                    # + the first set-up's own reason
    assert rn42.commands.count(b"SM,1") == channel.setups   # every $$$ got CMD: guard kept
    rn42.reachable = True
    fake.now = channel.setup_due
    assert channel.send_gesture("left").status == ACKNOWLEDGED
    assert channel.backoff == 2.0 and channel.consecutive_failures == 0


def test_rn42_set_up_waits_out_the_guard_time():
    fake = FakeTime()
    rn42, uart, channel = set_up_channel(fake, status_prefix=b"%")
    assert channel.send_gesture("forward").status == ACKNOWLEDGED   # a write just now
    rn42.drop()
    fake.slept.clear()
    assert channel.setup() is True and rn42.connected   # the model wants 1 s of quiet
    # the probe first (unanswered, 0.3 s), then the rest of the guard time
    assert sum(fake.slept) >= RN42_GUARD_TIME and fake.slept[-1] < RN42_GUARD_TIME


class Rn42OnAPort:
    """A serial port (what SerialLink gives a channel) with a simulated RN-42."""

    def __init__(self, rn42):
        self.rn42 = rn42
        self.rx = bytearray()
        self.opens = 1

    def send(self, data):
        for byte in bytes(data):
            self.rx += self.rn42(byte)
        return True

    def read_available(self):
        data, self.rx = bytes(self.rx), bytearray()
        return data

    def read_until(self, expected, timeout):
        data = self.read_available()
        return data if expected in data else None

    def close(self):
        pass


def test_reopened_serial_port_sets_the_rn42_up_again(caplog):
    fake = FakeTime()
    rn42 = SimulatedRn42("0016530A0B0C", status_prefix=b"%", clock=fake.clock)
    port = Rn42OnAPort(rn42)
    channel = RobotChannel(port, rn42_address="0016530A0B0C", clock=fake.clock,
                           sleep=fake.sleep)
    fake.now += 5
    assert channel.setup() and channel.send_gesture("forward").status == UNCONFIRMED
    rn42.reboot()                                    # USB adapter replugged: module restarted
    port.opens = 2                                   # ... and SerialLink reopened its tty
    fake.now += 5
    assert channel.send_gesture("right").status == UNCONFIRMED
    assert channel.setups == 2 and rn42.connected and rn42.messages == [b"1", b"3"]
    assert "serial port reopened" in caplog.text


# ---- rfcomm / serial adapter that disappears ---------------------------------------------
def test_serial_link_whose_peer_hangs_up_reopens(tmp_path):
    """rfcomm drops the connection: reads fail (EIO) at once instead of waiting
    out the timeout; the port reopens after the back-off when the node is back."""
    clock = FakeClock()
    master, slave = os.openpty()
    device = tmp_path / "rfcomm0"
    device.symlink_to(os.ttyname(slave))
    os.close(slave)
    link = SerialLink(str(device), clock=clock, initial_backoff=0.5)
    assert link.connected and link.opens == 1
    os.close(master)
    start = time.monotonic()
    assert link.read_until(b"\x02\x09", timeout=2.0) is None
    assert time.monotonic() - start < 0.5 and not link.connected
    assert link.read_available() == b"" and link.send(b"x") is False   # backing off
    device.unlink()
    master, slave = os.openpty()
    device.symlink_to(os.ttyname(slave))
    os.close(slave)
    try:
        clock.now += 0.5
        assert link.send(b"back") and read_exactly(master, 4) == b"back"
        assert link.opens == 2
    finally:
        link.close()
        os.close(master)
