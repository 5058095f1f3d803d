"""Commands to the LEGO NXT robot: one telegram per recognised gesture (thesis
§7.4.1, §8.5, Table 15).

Runs on the board's ARM: Python 3 only, and :mod:`soc.hps_interface` (shipped
with it) for the gesture classes.

Telegrams
---------
Each recognised gesture is sent as one NXT *MessageWrite* direct command to
mailbox (inbox) 0, carrying the ASCII digit of the class index + 1 and a NUL::

    body     = 0x80 (direct command, no reply wanted), 0x09 (MESSAGEWRITE),
               inbox 0, size incl. NUL = 2, digit, 0x00
    telegram = len(body) as 2 bytes little-endian (Bluetooth framing) + body

The thesis' Table 15 is not available to this project; the mapping below is ours.
An NXT program reading mailbox 0 performs the action (it is not part of this
repository).

With a power (a model file whose ``postures`` entry has a power table,
:mod:`sw_hps.posture_commands`) the message is the digit and the motor power
as three ASCII digits (0-100): ``09 00 80 09 00 05 33 30 37 35 00`` is "right
at power 75"; a program reading the first character alone still acts.

Acknowledged telegrams (``--robot-ack``)
---------------------------------------
``telegram(gesture, reply=True)`` sets the first body byte to 0x00 (direct
command, reply required) instead of 0x80; the brick then answers with a reply
telegram, Bluetooth-framed like the command::

    reply = 03 00 (length 3), 0x02 (reply), 0x09 (MESSAGEWRITE), status

status 0x00 is success; any other value is an error code of the NXT direct
commands (:data:`NXT_STATUS`; e.g. 0xEC: no program running, so nobody reads
the mailbox). :func:`find_reply` picks a reply out of received bytes. Source
of the bytes: the LEGO MINDSTORMS NXT Bluetooth Developer Kit, appendix 2
"Direct commands" (MESSAGEWRITE); checked against nxt-python 3.5's
``nxt.telegram`` and ``nxt.brick.Brick.message_write``.

==  ============  ================================  =========================
#   gesture       robot action                      telegram (hex)
==  ============  ================================  =========================
0   forward       drive forward                     06 00 80 09 00 02 31 00
1   back          drive backward                    06 00 80 09 00 02 32 00
2   right         turn right (pivot), then forward  06 00 80 09 00 02 33 00
3   left          turn left (pivot), then forward   06 00 80 09 00 02 34 00
4   rotate-right  spin clockwise in place           06 00 80 09 00 02 35 00
5   rotate-left   spin counter-clockwise in place   06 00 80 09 00 02 36 00
6   stop          stop both motors                  06 00 80 09 00 02 37 00
==  ============  ================================  =========================
"""
from __future__ import annotations

import struct

from soc.hps_interface import GESTURE_NAMES

__all__ = ["GESTURE_NAMES", "ROBOT_ACTIONS", "NXT_DIRECT_NO_REPLY", "NXT_DIRECT_REPLY",
           "NXT_REPLY", "NXT_MESSAGEWRITE", "NXT_INBOX", "NXT_STATUS", "MESSAGEWRITE_REPLY",
           "POWER_RANGE", "telegram", "probe_telegram", "find_reply", "status_text", "gesture_index", "hex_bytes"]

#: Action the NXT program performs for each gesture (our Table 15).
ROBOT_ACTIONS = ("drive forward", "drive backward", "turn right (pivot), then forward",
                 "turn left (pivot), then forward", "spin clockwise in place",
                 "spin counter-clockwise in place", "stop both motors")

#: Motor power a telegram may carry (the NXT's output power is at most 100).
POWER_RANGE = (0, 100)
NXT_DIRECT_NO_REPLY = 0x80
NXT_DIRECT_REPLY = 0x00
#: First byte of the brick's answer to a command sent with "reply required".
NXT_REPLY = 0x02
NXT_MESSAGEWRITE = 0x09
NXT_INBOX = 0
#: Inbox of the link probe (:func:`probe_telegram`): one the NXT program never reads.
PROBE_INBOX = 9
#: The framed reply to a MessageWrite up to its status byte: length 3, reply, opcode.
MESSAGEWRITE_REPLY = struct.pack("<H", 3) + bytes([NXT_REPLY, NXT_MESSAGEWRITE])
#: Error codes a MessageWrite reply can carry (NXT direct commands appendix).
NXT_STATUS = {
    0x00: "success",
    0xBD: "request failed",
    0xBE: "unknown command opcode",
    0xBF: "insane packet",
    0xC0: "data contains out-of-range values",
    0xDD: "communication bus error",
    0xDE: "no free memory in communication buffer",
    0xDF: "specified channel/connection is not valid",
    0xEC: "no active program",
    0xED: "illegal size specified",
    0xEE: "illegal mailbox queue ID specified",
}


def gesture_index(gesture) -> int:
    """Class index (0..6) of a gesture name or index; ``ValueError`` otherwise."""
    if isinstance(gesture, str):
        if gesture not in GESTURE_NAMES:
            raise ValueError(f"gesture must be one of {list(GESTURE_NAMES)} or 0..6, "
                             f"got {gesture!r}")
        return GESTURE_NAMES.index(gesture)
    if isinstance(gesture, bool) or not hasattr(gesture, "__index__") \
            or not 0 <= int(gesture) < len(GESTURE_NAMES):
        raise ValueError(f"gesture must be one of {list(GESTURE_NAMES)} or 0..6, "
                         f"got {gesture!r}")
    return int(gesture)


def telegram(gesture, reply: bool = False, power=None) -> bytes:
    """Bluetooth-framed NXT MessageWrite telegram for a gesture (see the table above).

    Parameters
    ----------
    gesture : str or int
        A name of :data:`GESTURE_NAMES` or its index.
    reply : bool
        Ask the brick for a reply (first body byte 0x00 instead of 0x80).
    power : int in POWER_RANGE, optional
        Motor power for the action (:mod:`sw_hps.posture_commands`): three ASCII
        digits after the class digit (``"3075"``: right at power 75); None: the
        class digit alone.

    Returns
    -------
    bytes
        E.g. ``06 00 80 09 00 02 31 00`` for ``"forward"`` (``06 00 00 09 00 02
        31 00`` with ``reply=True``).
    """
    message = str(gesture_index(gesture) + 1)
    if power is not None:
        lo, hi = POWER_RANGE
        if isinstance(power, bool) or not isinstance(power, int) or not lo <= power <= hi:
            raise ValueError(f"power must be an integer in [{lo}, {hi}] (NXT motor power), "
                             f"got {power!r}")
        message += "%03d" % power
    message = message.encode("ascii")
    kind = NXT_DIRECT_REPLY if reply else NXT_DIRECT_NO_REPLY
    body = bytes([kind, NXT_MESSAGEWRITE, NXT_INBOX, len(message) + 1]) + message + b"\x00"
    return struct.pack("<H", len(body)) + body


def probe_telegram() -> bytes:
    """A MessageWrite with "reply required" to :data:`PROBE_INBOX` (mailbox 10),
    which the NXT program does not read: whether the brick answers tells
    whether the link is up, without a command to the robot (the brick answers
    a MessageWrite even with no program running, status 0xEC)."""
    body = bytes([NXT_DIRECT_REPLY, NXT_MESSAGEWRITE, PROBE_INBOX, 2]) + b"?\x00"
    return struct.pack("<H", len(body)) + body


def find_reply(received: bytes):
    """The status byte of the first MessageWrite reply in ``received``.

    Parameters
    ----------
    received : bytes
        Bytes read from the link (other bytes around the reply, such as an
        RN-42's status strings, are skipped).

    Returns
    -------
    int or None
        The status (0 = success), or None if no complete reply is there yet.
    """
    received = bytes(received)
    at = received.find(MESSAGEWRITE_REPLY)
    if at < 0 or at + len(MESSAGEWRITE_REPLY) >= len(received):
        return None
    return received[at + len(MESSAGEWRITE_REPLY)]


def status_text(status: int) -> str:
    """``"0xec (no active program)"`` for a reply's status byte."""
    return "{:#04x} ({})".format(status, NXT_STATUS.get(status, "unknown status"))


def hex_bytes(data: bytes) -> str:
    """``data`` as spaced hex (``bytes.hex(" ")`` needs Python 3.8)."""
    return " ".join("{:02x}".format(b) for b in bytes(data))
