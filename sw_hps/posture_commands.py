"""The hand's posture as the robot's clutch, brake and throttle: a trajectory
gesture commands only while the hand holds a command posture, a stop posture
held for a few frames stops the robot at once, and the command posture's
extended fingers set the motor power (thesis §10.1, future work: "the
configuration of the hand").

Runs on the board's ARM: Python 3 only.

The options are the model file's ``postures`` entry (:func:`check_posture_commands`;
null: none of this, every gesture commands as before)::

    "postures": {"command": ["asl2", ...],   # postures a gesture must be made in
                 "share": 0.5,               # of its frames, at least
                 "stop": "fist",             # null: no stop posture
                 "stop_frames": 3,           # records in a row that stop
                 "release_frames": 3,        # 0: no clutch (the share only)
                 "neutral": ["asl0"],        # postures that neither hold nor release it
                 "power": {"asl2": 50, ...}} # null: telegrams without a power

:class:`PostureCommands` applies them to each frame's posture (the posture
classifier's name of the frame's record, :mod:`sw_hps.posture`; None for no
hand or a refused record):

* **stop**: ``stop_frames`` records in a row named ``stop`` fire a stop once;
  the stop stays *latched*, and no gesture commands, until a record names
  another posture (the hand left the stop posture);
* **command**: a gesture over frames ``first`` .. ``last`` commands when at
  least ``share`` of those frames are in a posture of ``command`` (frames
  without a posture, no hand or refused, count against it; frames whose
  posture was never read, skipped by :meth:`PostureCommands.take` because the
  application popped several records between two reads of the posture
  slave, do not count);
* **clutch**: with ``release_frames`` > 0, that many records in a row in no
  command posture (another posture, or none; records in a ``neutral`` posture,
  one the classifier names a moving command posture by mistake, are skipped)
  release it: the trajectory
  spotter names what is pending and starts afresh, and takes no motion until
  a record names a command posture again (:attr:`PostureCommands.engaged`).
  So no gesture spans motion made in another posture: a scratch's way down
  from the face does not join the up-stroke of the ``forward`` after it;
* **power**: the power level held over most of the gesture's command-posture
  frames (a posture's level is ``power[posture]``; postures of one finger
  count share a level), sent in the telegram (:func:`sw_hps.telegram.telegram`).
"""
from __future__ import annotations

from typing import NamedTuple

from .telegram import POWER_RANGE

__all__ = ["POSTURE_COMMAND_DEFAULTS", "POWER_RANGE", "STOP_FRAMES_RANGE",
           "RELEASE_FRAMES_RANGE", "MIN_FRAME_WIDTH",
           "check_posture_commands", "check_posture_classes", "postures_for_frame",
           "read_names", "PostureCommands", "Verdict"]

#: Options of the ``postures`` entry and their defaults.
POSTURE_COMMAND_DEFAULTS = {"command": [], "share": 0.5, "stop": None, "stop_frames": 3,
                            "release_frames": 0, "neutral": [], "power": None}
#: Records in a row a stop needs.
STOP_FRAMES_RANGE = (1, 30)
#: Records in a row out of a command posture that release the clutch (0: never).
RELEASE_FRAMES_RANGE = (0, 30)
#: Frames of postures kept to judge a gesture (a longer one is judged on its last ones).
KEEP_FRAMES = 1024
#: Narrowest frame the posture commands apply to: in narrower frames the
#: fingers are 2-3 px wide and the posture mask's 3x3 opening removes them (at
#: 320x240 a rendered asl1 hand is named fist), so a model's ``postures`` entry
#: is set aside there and every gesture commands as without it.
MIN_FRAME_WIDTH = 640


def postures_for_frame(options, frame_width, log=None):
    """The ``postures`` options to apply at ``frame_width`` (None below
    :data:`MIN_FRAME_WIDTH`; ``log``, a logger, is then warned that they are
    set aside)."""
    if options is None or frame_width >= MIN_FRAME_WIDTH:
        return options
    if log is not None:
        log.warning("frames %d px wide are too narrow for the posture commands (at least "
                    "%d): every gesture commands, no stop by posture", frame_width,
                    MIN_FRAME_WIDTH)
    return None


def _posture_name(key, value):
    if not isinstance(value, str) or not value:
        raise ValueError(f"postures {key} must be a posture name, got {value!r}")
    return value


def check_posture_commands(options):
    """The defaults updated by ``options`` (a dict, or None: no posture
    commands, returned as None); ``ValueError`` names the key and what it allows."""
    if options is None:
        return None
    if not isinstance(options, dict):
        raise ValueError("postures must be null or an object")
    unknown = sorted(set(options) - set(POSTURE_COMMAND_DEFAULTS))
    if unknown:
        raise ValueError(f"postures: unknown key(s) {', '.join(unknown)} (allowed: "
                         f"{', '.join(POSTURE_COMMAND_DEFAULTS)})")
    out = dict(POSTURE_COMMAND_DEFAULTS, **options)
    command = out["command"]
    if not isinstance(command, list) or len(set(map(str, command))) != len(command):
        raise ValueError(f"postures command must be a list of distinct posture names, "
                         f"got {command!r}")
    out["command"] = [_posture_name("command", name) for name in command]
    share = out["share"]
    if isinstance(share, bool) or not isinstance(share, (int, float)) \
            or not 0.0 <= share <= 1.0:
        raise ValueError(f"postures share must be a number in [0, 1], got {share!r}")
    out["share"] = float(share)
    if out["stop"] is not None:
        _posture_name("stop", out["stop"])
        if out["stop"] in out["command"]:
            raise ValueError(f"postures stop {out['stop']!r} must not be a command posture")
    frames = out["stop_frames"]
    lo, hi = STOP_FRAMES_RANGE
    if isinstance(frames, bool) or not isinstance(frames, int) or not lo <= frames <= hi:
        raise ValueError(f"postures stop_frames must be an integer in [{lo}, {hi}], "
                         f"got {frames!r}")
    frames = out["release_frames"]
    lo, hi = RELEASE_FRAMES_RANGE
    if isinstance(frames, bool) or not isinstance(frames, int) or not lo <= frames <= hi:
        raise ValueError(f"postures release_frames must be an integer in [{lo}, {hi}], "
                         f"got {frames!r}")
    if frames and not out["command"]:
        raise ValueError("postures release_frames needs command postures (command is empty)")
    neutral = out["neutral"]
    if not isinstance(neutral, list) or len(set(map(str, neutral))) != len(neutral):
        raise ValueError(f"postures neutral must be a list of distinct posture names, "
                         f"got {neutral!r}")
    out["neutral"] = [_posture_name("neutral", name) for name in neutral]
    both = [name for name in out["neutral"] if name in out["command"] or name == out["stop"]]
    if both:
        raise ValueError(f"postures neutral {', '.join(both)} must be neither a command nor "
                         "the stop posture")
    power = out["power"]
    if power is not None:
        if not isinstance(power, dict) or not power:
            raise ValueError(f"postures power must be null or an object of posture: power, "
                             f"got {power!r}")
        lo, hi = POWER_RANGE
        for name, level in power.items():
            if isinstance(level, bool) or not isinstance(level, int) or not lo <= level <= hi:
                raise ValueError(f"postures power {name!r} must be an integer in [{lo}, {hi}] "
                                 f"(NXT motor power), got {level!r}")
        missing = [name for name in out["command"] if name not in power]
        if missing:
            raise ValueError(f"postures power has no level for the command posture(s) "
                             f"{', '.join(missing)}")
        out["power"] = dict(power)
    return out


def check_posture_classes(options, class_names, where="postures"):
    """Refuse (``ValueError``) options naming a posture the posture model does
    not know (``class_names``: its classes)."""
    if options is None:
        return
    known = set(class_names)
    named = list(options["command"]) + ([options["stop"]] if options["stop"] else []) \
        + list(options["power"] or ()) + list(options.get("neutral") or ())
    unknown = [name for name in named if name not in known]
    if unknown:
        raise ValueError(f"{where}: {', '.join(sorted(set(unknown)))} not a class of the "
                         f"posture model ({', '.join(class_names)})")


def read_names(names, first, last, keep):
    """The postures in ``names`` (frame: posture) of the frames ``first`` ..
    ``last`` that have one (at most the last ``keep``): a frame whose record
    was never read counts neither way."""
    first = max(int(first), int(last) - keep + 1)
    return [names[f] for f in range(first, int(last) + 1) if f in names]


class Verdict(NamedTuple):
    """What the postures say of one gesture."""
    #: it may command (always True without a command posture)
    commands: bool
    #: the command posture held over most of its command-posture frames (None: none)
    posture: str | None
    #: share of its frames in a command posture
    share: float
    #: motor power for its telegram (None: no power table, or no command posture)
    power: int | None


class PostureCommands:
    """Each frame's posture against the ``postures`` options (module docstring).

    Call :meth:`take` once per frame with its posture (frames rising; a frame
    may be skipped: it has no posture); it returns True on the frame a stop
    fires. :meth:`judge` gives a gesture's :class:`Verdict`.

    Attributes
    ----------
    latched : bool
        A stop has fired and the hand has not left the stop posture.
    stop_started : int or None
        First frame of the run of stop-posture records (while one runs).
    stops : int
        Stops fired.
    """

    def __init__(self, options, keep=KEEP_FRAMES):
        options = check_posture_commands(options)
        if options is None:
            raise ValueError("PostureCommands needs a postures entry")
        self.options = options
        self.command = frozenset(options["command"])
        self.neutral = frozenset(options["neutral"])
        self.keep = int(keep)
        self.stops = 0
        self.reset()

    def reset(self):
        """A new stream: frames count afresh, nothing latched."""
        self.names = {}
        self.latched = False
        self.stop_started = None
        self._run = 0
        self._out = 0                   # records in a row out of the command postures

    def take(self, frame, posture):
        """Frame ``frame``'s posture (None: no hand, refused or unknown)."""
        frame = int(frame)
        self.names[frame] = posture
        if len(self.names) > self.keep:
            for old in [f for f in self.names if f <= frame - self.keep]:
                del self.names[old]
        if posture in self.command:
            self._out = 0
        elif posture not in self.neutral:
            self._out += 1
        stop = self.options["stop"]
        if stop is None:
            return False
        if posture == stop:
            if self._run == 0:
                self.stop_started = frame
            self._run += 1
            if not self.latched and self._run >= self.options["stop_frames"]:
                self.latched = True
                self.stops += 1
                return True
            return False
        self._run = 0
        self.stop_started = None
        if posture is not None:
            self.latched = False        # the hand left the stop posture
        return False

    @property
    def engaged(self):
        """The clutch holds: motion may make a gesture (always with
        ``release_frames`` 0)."""
        release = self.options["release_frames"]
        return not release or self._out < release

    def judge(self, first, last):
        """The :class:`Verdict` of a gesture over frames ``first`` .. ``last``
        (the frames taken among them)."""
        return self.judge_names(read_names(self.names, first, last, self.keep))

    def judge_names(self, names):
        """The :class:`Verdict` of a gesture whose read frames had postures
        ``names`` (None: no hand or refused)."""
        names = list(names)
        held = [n for n in names if n in self.command]
        share = len(held) / len(names) if names else 0.0
        if not self.command:
            return Verdict(not self.latched, None, share, None)
        commands = not self.latched and bool(held) and share >= self.options["share"]
        power_of = self.options["power"]
        counts = {}
        for name in held:
            key = power_of[name] if power_of else name
            counts[key] = counts.get(key, 0) + 1
        if not counts:
            return Verdict(commands, None, round(share, 3), None)
        best = max(counts, key=lambda k: (counts[k], -k if power_of else 0))
        if power_of:
            posture = max((n for n in set(held) if power_of[n] == best),
                          key=held.count)
            return Verdict(commands, posture, round(share, 3), best)
        return Verdict(commands, best, round(share, 3), None)
