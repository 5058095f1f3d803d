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

__all__ = ["GESTURE_NAMES", "ROBOT_ACTIONS", "NXT_DIRECT_NO_REPLY", "NXT_MESSAGEWRITE",
           "NXT_INBOX", "telegram", "gesture_index", "hex_bytes"]

#: Action the NXT program performs for each gesture (our Table 15).
ROBOT_ACTIONS = ("drive forward", "drive backward", "turn right (pivot), then forward",
                 "turn left (pivot), then forward", "spin clockwise in place",
                 "spin counter-clockwise in place", "stop both motors")

NXT_DIRECT_NO_REPLY = 0x80
NXT_MESSAGEWRITE = 0x09
NXT_INBOX = 0



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


def telegram(gesture) -> bytes:
    """Bluetooth-framed NXT MessageWrite telegram for a gesture (see the table above).

    Parameters
    ----------
    gesture : str or int
        A name of :data:`GESTURE_NAMES` or its index.

    Returns
    -------
    bytes
        E.g. ``06 00 80 09 00 02 31 00`` for ``"forward"``.
    """
    message = str(gesture_index(gesture) + 1).encode("ascii")
    body = bytes([NXT_DIRECT_NO_REPLY, NXT_MESSAGEWRITE, NXT_INBOX, len(message) + 1]) \
        + message + b"\x00"
    return struct.pack("<H", len(body)) + body


def hex_bytes(data: bytes) -> str:
    """``data`` as spaced hex (``bytes.hex(" ")`` needs Python 3.8)."""
    return " ".join("{:02x}".format(b) for b in bytes(data))
