"""Tests for sw_hps.robot: NXT telegrams and the links to the robot (thesis §7.4.1, §8.5)."""
import os
import threading
import time

import pytest

from sw_hps.bus import SimBus
from soc.hps_interface import UART_RXDATA, UART_STATUS, UART_TXDATA
from sw_hps.robot import NullLink, SerialLink, UartLink, configure_rn42, normalise_bt_address
from sw_hps.telegram import GESTURE_NAMES, gesture_index, telegram
from sw_hps.simulated import SimulatedUart


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
    import nxt.backend.bluetooth as bluetooth
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
        master, {b"$$$": b"CMD\r\n", b"SM,1\r": b"AOK\r\n"}, log, stop), daemon=True)
    peer.start()
    try:
        assert configure_rn42(link, "00:16:53:0a:0b:0c", timeout=2.0) is True
        deadline = time.monotonic() + 2
        while len(log) < 3 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert log == [b"$$$", b"SM,1\r", b"C,0016530A0B0C\r"]
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
