"""The board application's continuous spotting (issue 28; thesis §10.1's first
limitation): gestures one after another, with or without a rest between them,
and motion that is no gesture in between.

Runs on the board's ARM: Python 3 and numpy only.

The FIFO slave runs in its streaming mode (Control = GO | STREAM,
:mod:`sw_hps.fifo`): every video frame's record reaches this loop, with the
hardware's spotting flag and whether the frame saw a hand. The loop finds the
gesture boundaries itself:

* a frame with a hand gives the smoothed centroid; it becomes a symbol each
  time the hand has travelled ``step`` pixels (the model file's ``spotting``
  option, at a 640-pixel-wide frame, scaled to ``frame_width``) since the last
  one (:class:`~sw_hps.orientation.DistanceSymbols`: a still or jittering hand
  gives none);
* :class:`~sw_hps.continuous.ContinuousRecogniser` (the class models beside
  their threshold model) names a gesture ``end_delay`` frames after its last
  symbol (up to four times that while a longer gesture over the same symbols
  may still win), once, and refuses what no gesture explains;
* a frame without a hand flushes: what is pending is named and the paths start
  afresh (the hand left the view);
* with the model file's ``postures`` entry (:mod:`sw_hps.posture_commands`)
  and a posture per frame, a gesture is a command only if the hand held a
  command posture over enough of it (its telegram then carries the power of
  that posture), no gesture spans motion made out of a command posture
  (``release_frames``: the clutch), and the stop posture held for
  ``stop_frames`` records sends
  the stop telegram at once: what is pending is forgotten, and nothing is
  named until the hand leaves the stop posture;
* with the model file's ``verifier`` (:mod:`sw_hps.hmm`), a spotted gesture
  is a command only if the isolated recogniser names the points of its span
  (first to last symbol, or that span less up to a quarter of its start:
  :data:`VERIFY_TRIMS`) the same class and its thresholds do not refuse
  them: the threshold model judges symbols one step at a time, the isolated
  recogniser the whole shape, and a reach or a wave that the first takes for
  a gesture seldom passes the second;
* a named gesture's NXT telegram goes to the robot at once.

The hardware's flag is not used: it is the thesis' rest-gesture-rest
spotting, which this mode replaces. FIFO-FULL (the loop fell more than
:data:`~sw_hps.fifo.FIFO_DEPTH` frames behind) clears the FIFOs and flushes:
the lost frames cannot be named. Faults of the bus or the link never end the
loop: it logs one line and starts again after a back-off, as
:class:`~sw_hps.app.GestureApp` does (an error repeated at the capped back-off
is logged at most once per :data:`~sw_hps.busfault.FAULT_REMINDER`).

Bus faults (:mod:`sw_hps.busfault`) as in :mod:`sw_hps.app`: Control with a bit
of [31:6] set (all ones), GO or STREAM not reading what the loop wrote (all
zeros: core in reset or not there), Longitud_X / Longitud_Y above FIFO_DEPTH,
or FIFO-FULL set right after FIFO-CLR cleared it (a stuck bit: filling the FIFO
takes FIFO_DEPTH frames). What is pending is forgotten (its frames cannot be
trusted); one warning names the reads and the likely cause, the registers are
probed with a back-off doubling from ``poll_interval`` up to
``max_fault_interval`` (a reminder at most once per
:data:`~sw_hps.busfault.FAULT_REMINDER`), and once they look sane and ID reads
CORE_MAGIC the stream restarts (FIFO-CLR, GO, STREAM) and one line says so.
Counted in ``bus_faults``. The loop never spins: an empty poll sleeps
``poll_interval``, a fault its back-off, and
:data:`~sw_hps.busfault.MAX_BUSY_STEPS` busy steps in a row one
``poll_interval``.
"""
from __future__ import annotations

import logging
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .app import RESULTS_KEPT
from .busfault import (FAULT_REMINDER, MAX_BUSY_STEPS, MAX_FAULT_INTERVAL, BusFault,
                       BusFaultWatch, RepeatFilter, control_fault, describe_bus, lengths_fault,
                       read_id)
from .continuous import ContinuousRecogniser, Detection, step_pixels
from .fifo import FRAC_BITS, FRAME_WIDTH
from .orientation import DistanceSymbols
from .posture_commands import PostureCommands, postures_for_frame
from .robot import FAILED, deliver_gesture
from .telegram import hex_bytes

__all__ = ["StreamingApp", "StreamSpotter", "SpottedGesture", "Command",
           "check_streaming_models"]

log = logging.getLogger(__name__)

#: Seconds between polls of an empty FIFO (the thesis application's default).
DEFAULT_POLL_INTERVAL = 0.005
#: Back-off after a fault (doubling up to the maximum), seconds.
INITIAL_BACKOFF, MAX_BACKOFF = 0.1, 5.0
#: Frames of hand positions kept for the verifier (34 s at 30 fps: longer than
#: any gesture the continuous recogniser names).
VERIFY_FRAMES = 1024
#: Shares of a spotted span's points the verifier may leave out at its start:
#: where the threshold model lets a gesture begin is less sure than where it
#: ends, and motion just before a gesture often joins it. Chosen on the
#: development sessions (scene seeds 300-309, benchmarks/spotting_dev.py;
#: the figures are in CHANGELOG.md).
VERIFY_TRIMS = (0.0, 0.125, 0.25)


def check_streaming_models(models):
    """Refuse (``ValueError``, one line) models the continuous spotting cannot
    run: it needs discrete class models with a ``spotting`` entry (written by
    ``stereogest train --continuous``)."""
    spotting = getattr(models, "spotting", None)
    if models.emission != "discrete" or spotting is None:
        raise ValueError("continuous spotting needs a discrete model file with a 'spotting' "
                         f"entry ('stereogest train --continuous'), got {models.emission} "
                         "models without one")
    return models


@dataclass(frozen=True)
class Command(Detection):
    """What :class:`StreamSpotter` names: a gesture (a
    :class:`~sw_hps.continuous.Detection`) that commands, or a stop by posture
    (``by_posture``: ``first`` is the first frame of the stop posture,
    ``last`` and ``named_at`` the frame it fired at, ``score`` 0)."""
    #: the command posture held over it and the share of its frames in a
    #: command posture (None without posture commands)
    posture: str | None = None
    posture_share: float | None = None
    #: motor power for the telegram (None: none)
    power: int | None = None
    by_posture: bool = False


@dataclass(frozen=True)
class SpottedGesture:
    """A gesture named in the stream: class, the frames of its first and last
    symbol and the frame it was named at (frames counted from the stream's
    start), its score (log-likelihood above the threshold model), the telegram
    (None if its class has none), whether the link took its bytes and what
    became of it (``delivery``: see :class:`sw_hps.robot.Delivery`; None when
    nothing was sent)."""
    class_index: int
    class_name: str
    first: int
    last: int
    named_at: int
    score: float
    telegram: bytes | None
    sent: bool
    delivery: str | None = None
    #: the posture held over most of its frames and their share in it (None
    #: without a posture model)
    posture: str | None = None
    posture_share: float | None = None
    #: the telegram's motor power (None: none); named by the stop posture
    power: int | None = None
    by_posture: bool = False

    def to_dict(self) -> dict:
        return {"name": self.class_name, "first": self.first, "last": self.last,
                "named_at": self.named_at, "score": round(self.score, 3),
                "telegram": hex_bytes(self.telegram) if self.telegram is not None else None,
                "sent": self.sent, "delivery": self.delivery, "posture": self.posture,
                "posture_share": self.posture_share, "power": self.power,
                "by_posture": self.by_posture}


class StreamSpotter:
    """Records to commands, one record (frame) at a time: the part of
    :class:`StreamingApp` that does not touch the bus (the live view and the
    batch commands run it on the golden model's records).

    Parameters
    ----------
    models : discrete models with a ``spotting`` entry
        With a ``postures`` entry, each record's posture (:meth:`take`) gates,
        stops and scales the commands (module docstring).
    frame_width : int
        Width of the frames (scales ``step``).

    Attributes
    ----------
    commands : sw_hps.posture_commands.PostureCommands or None
    refused : int
        Gestures spotted that were no command (not in a command posture).
    unconfirmed : int
        Gestures spotted that the model file's verifier did not confirm.
    """

    def __init__(self, models, frame_width: int = FRAME_WIDTH):
        check_streaming_models(models)
        if isinstance(frame_width, bool) or not isinstance(frame_width, int) \
                or not 8 <= frame_width <= 4096:
            raise ValueError(f"frame_width must be an integer in [8, 4096], got {frame_width!r}")
        self.verifier = getattr(models, "verifier", None)
        self.recogniser = ContinuousRecogniser(
            models, confirm=self._confirmed if self.verifier is not None else None,
            **models.spotting)
        self.symbols = DistanceSymbols(step_pixels(models.spotting["step"], frame_width))
        postures = postures_for_frame(getattr(models, "postures", None), frame_width, log)
        self.commands = PostureCommands(postures) if postures is not None else None
        self._stop_index = list(models.class_names).index("stop") \
            if "stop" in models.class_names else -1
        self._path = deque(maxlen=VERIFY_FRAMES)    # (frame, x, y) of the frames that count
        self.refused = 0
        self.unconfirmed = 0
        self.frames = 0              # records taken since the last reset

    @property
    def pending(self) -> bool:
        return self.recogniser.pending

    def reset(self) -> None:
        """A new stream (frames count from 0 again)."""
        self.recogniser.reset()
        self.symbols.reset()
        if self.commands is not None:
            self.commands.reset()
        self._path.clear()
        self.frames = 0

    def take(self, x_fixed: int, y_fixed: int, present: bool, posture=None,
             posture_read: bool = True) -> list[Command]:
        """One frame's record (10.8 smoothed position, hand present) and its
        posture (None: no hand or refused; ``posture_read`` False: the
        posture slave was not read for this frame, which then counts neither
        for nor against a command); the commands named at it."""
        frame = self.frames
        self.frames += 1
        if self.commands is not None:
            if posture_read and self.commands.take(frame, posture):
                self.recogniser.reset()       # the stop overrides what is in progress
                self.symbols.reset()
                return [Command(self._stop_index, "stop", self.commands.stop_started, frame,
                                0.0, frame, posture, None, None, True)]
            if self.commands.latched:         # nothing until the hand leaves the stop
                self.recogniser.reset()
                self.symbols.reset()
                return []
        # with the clutch released motion counts as little as a hand out of view
        if present and (self.commands is None or self.commands.engaged):
            point = (int(x_fixed) >> FRAC_BITS, int(y_fixed) >> FRAC_BITS)
            if self.verifier is not None:
                self._path.append((frame,) + point)
            symbol = self.symbols.push(point)
            return self._judged(self.recogniser.step(frame, symbol))
        self.symbols.reset()          # the hand left (or let go): name what is pending
        return self._judged(self.recogniser.flush(frame))

    def flush(self) -> list[Command]:
        """The stream ends or breaks: name what is pending; paths start afresh."""
        self.symbols.reset()
        return self._judged(self.recogniser.flush(self.frames - 1))

    def _judged(self, detections: list[Detection]) -> list[Command]:
        out = []
        for d in detections:
            if self.commands is None:
                out.append(Command(d.class_index, d.name, d.first, d.last, d.score, d.named_at))
                continue
            verdict = self.commands.judge(d.first, d.last)
            if not verdict.commands:
                self.refused += 1
                log.info("spotted %s (frames %d-%d) is no command: %.0f %% of its frames in a "
                         "command posture (%s held)", d.name, d.first, d.last,
                         100 * verdict.share, verdict.posture or "none")
                continue
            out.append(Command(d.class_index, d.name, d.first, d.last, d.score, d.named_at,
                               verdict.posture, verdict.share, verdict.power))
        return out

    def _confirmed(self, class_index: int, first: int, last: int) -> bool:
        """Whether the verifier names the points of frames ``first``..``last``
        the spotted class without refusing them (the recogniser's ``confirm``);
        logs why not."""
        spotted = self.recogniser.class_names[class_index]
        points = np.array([(x, y) for f, x, y in self._path if first <= f <= last],
                          dtype=np.float64).reshape(-1, 2)
        why = None
        for trim in VERIFY_TRIMS:
            path = points[round(trim * len(points)):]
            scores = self.verifier.scores_of_points(path) if len(path) >= 2 else None
            if scores is None:
                index, reason = -1, "no motion"
            else:
                index, reason = self.verifier.decide(scores)
            name = self.verifier.class_names[index] if index >= 0 else None
            if name == spotted:
                return True
            if why is None:
                why = reason if name is None else f"it names the path {name}"
        self.unconfirmed += 1
        log.info("spotted %s (frames %d-%d) is not confirmed by the verifier: %s",
                 spotted, first, last, why)
        return False


class StreamingApp:
    """The continuous spotting loop (module docstring).

    Parameters
    ----------
    models : sw_hps.hmm.GestureModels
        Discrete models with a ``spotting`` entry (:func:`check_streaming_models`).
    fifo : sw_hps.fifo.FifoPeripheral
    link : robot link (``send(bytes) -> bool``, ``close()``)
    sleep : callable
        ``sleep(seconds)``.
    poll_interval : float
        Seconds between polls of an empty FIFO.
    frame_width : int
        Width of the frames (scales ``step``).
    on_result : callable, optional
        Called with each :class:`SpottedGesture`.
    clock : callable
        ``clock() -> seconds`` (monotonic), for the bus faults' reminders and the
        repeated errors.
    max_fault_interval : float in (0, 60]
        Longest sleep between two probes of the registers during a bus fault.
    posture : sw_hps.posture.PostureTracker, optional
        Each frame's posture from the posture slave; each gesture then names
        the posture held over most of it.

    Attributes
    ----------
    lost, errors, bus_faults : int
        FIFO-FULL events, exceptions recovered from, bus faults seen.
    """

    def __init__(self, models, fifo, link, *, sleep: Callable[[float], None] = time.sleep,
                 poll_interval: float = DEFAULT_POLL_INTERVAL, frame_width: int = FRAME_WIDTH,
                 on_result: Callable[[SpottedGesture], None] | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 max_fault_interval: float = MAX_FAULT_INTERVAL, posture=None):
        self.spotter = StreamSpotter(models, frame_width)
        self.posture = posture
        if self.spotter.commands is not None and posture is None:
            raise ValueError("the model file's postures entry needs a posture tracker "
                             "(--posture-model)")
        if not (isinstance(poll_interval, (int, float)) and 0 < poll_interval <= 1):
            raise ValueError(f"poll_interval must be in (0, 1] seconds, got {poll_interval!r}")
        self.models, self.fifo, self.link = models, fifo, link
        self._sleep = sleep
        self.poll_interval = float(poll_interval)
        self.on_result = on_result
        #: The latest :data:`RESULTS_KEPT` gestures (a service runs for days).
        self.results: deque[SpottedGesture] = deque(maxlen=RESULTS_KEPT)
        self._named = None           # the list run() / end_of_stream() return, meanwhile
        self._deferred: deque[Command] = deque()   # named while a send waited
        self._keeping_up = False
        if hasattr(link, "while_waiting"):
            link.while_waiting = self._keep_up
        self.lost = 0                # FIFO-FULL events
        self.errors = 0
        self._started = False
        self._stop = False
        self._backoff = INITIAL_BACKOFF
        self.bus_watch = BusFaultWatch(
            label="streaming", where=describe_bus(fifo.bus, fifo.base),
            read_id=lambda: read_id(fifo), poll_interval=self.poll_interval,
            max_interval=max_fault_interval, reminder=FAULT_REMINDER, clock=clock, logger=log)
        self._error_lines = RepeatFilter(FAULT_REMINDER, clock)
        self._just_started = False   # the next status is the first after FIFO-CLR
        self._slept = False          # the current step slept
        self._busy_steps = 0         # steps in a row without any sleep

    # ---- control ----------------------------------------------------------------
    def request_stop(self) -> None:
        """Make :meth:`run` return after the current step (signal-handler safe)."""
        self._stop = True

    @property
    def idle(self) -> bool:
        """Nothing pending in the recogniser."""
        return not self.spotter.pending

    @property
    def frames(self) -> int:
        """Records taken since the stream (re)started."""
        return self.spotter.frames

    @property
    def bus_faults(self) -> int:
        """Bus faults seen (module docstring)."""
        return self.bus_watch.episodes

    def _nap(self, seconds: float) -> None:
        self._slept = True
        self._sleep(seconds)

    def run(self, max_iterations: int | None = None,
            until: Callable[[], bool] | None = None) -> list[SpottedGesture]:
        """Poll and spot until stopped (or ``until()`` is true, or after
        ``max_iterations`` steps); returns the gestures named meanwhile. Never
        raises for faults of the bus, the link or the data."""
        named: list[SpottedGesture] = []
        self._named = named
        iterations = 0
        try:
            while not self._stop and (max_iterations is None or iterations < max_iterations):
                if until is not None and until():
                    break
                iterations += 1
                self._slept = False
                try:
                    self.step()
                    self._backoff = INITIAL_BACKOFF
                except KeyboardInterrupt:
                    raise
                except BusFault as fault:
                    # Pending frames came from a bus now known to lie: forget them.
                    self._started = False
                    self._nap(self.bus_watch.fault(str(fault)))
                except Exception as exc:  # the loop must survive any fault
                    self.errors += 1
                    delay, self._backoff = self._backoff, min(2 * self._backoff, MAX_BACKOFF)
                    line = (f"streaming: {type(exc).__name__}: {exc}; restarting the stream "
                            f"in {delay:.2f} s")
                    left_out = self._error_lines.admit(line)
                    if left_out is not None:
                        log.error("%s%s", line,
                                  f" ({left_out} more like it not logged)" if left_out else "")
                    self._started = False
                    self._nap(delay)
                # Never spin: popping records needs no sleep, a long run of it does.
                self._busy_steps = 0 if self._slept else self._busy_steps + 1
                if self._busy_steps >= MAX_BUSY_STEPS:
                    self._busy_steps = 0
                    self._nap(self.poll_interval)
        except KeyboardInterrupt:
            log.info("interrupted; stopping")
        finally:
            self._stop = False
            self._named = None
        return named

    def end_of_stream(self) -> list[SpottedGesture]:
        """The source ended (no more frames will come): name what is pending."""
        named = self._named = []
        try:
            for detection in self.spotter.flush():
                self._send(detection)
        finally:
            self._named = None
        return named

    def shutdown(self) -> None:
        """Name what is pending, clear GO and close the link (errors logged)."""
        self.end_of_stream()
        try:
            self.fifo.stop()
        except Exception as exc:
            log.warning("could not clear GO: %s", exc)
        try:
            self.link.close()
        except Exception as exc:
            log.warning("could not close the robot link: %s", exc)
        if getattr(self.link, "while_waiting", None) == self._keep_up:
            self.link.while_waiting = None      # no cycle keeps this loop alive

    # ---- the loop ---------------------------------------------------------------
    def _start(self) -> None:
        """Streaming mode from an empty FIFO; the recogniser starts afresh."""
        self.fifo.clear(keep_running=True, streaming=True)
        self.spotter.reset()
        if self.posture is not None:
            self.posture.reset()
        self._started = True
        self._just_started = True
        # After a bus fault the watch's line says it (a flapping bus must not flood).
        log.log(logging.DEBUG if self.bus_watch.active else logging.INFO,
                "streaming: GO and STREAM set, FIFOs cleared")

    def _checked_status(self):
        """The status, or :class:`BusFault` if it is what no working core gives."""
        just_set, self._just_started = self._just_started, False
        status = self.fifo.status()
        problem = (control_fault(status.control, stream=True, just_set=just_set)
                   or lengths_fault(status.length_x, status.length_y))
        if problem is None and just_set and status.full:
            problem = (f"Control reads {status.control:#010x}: FIFO-FULL set right after "
                       "FIFO-CLR cleared it (filling a FIFO takes FIFO_DEPTH frames)")
        if problem is not None:
            raise BusFault(problem)
        if just_set:
            self.bus_watch.confirm("FIFO-CLR, GO, STREAM")
        return status

    def step(self) -> None:
        """One poll: take every record the FIFOs hold, or sleep."""
        if self.bus_watch.active and not self.bus_watch.recovering:
            # A bus fault: only probe (no writes) until the reads look sane.
            delay = self.bus_watch.probe(self.fifo)
            if delay is not None:
                self._nap(delay)
            else:
                self._started = False       # restart the stream on the next step
            return
        if not self._started:
            self._start()
        status = self._checked_status()
        if status.full:
            self.lost += 1
            log.warning("streaming: FIFO-FULL (the loop fell %d frames behind); the lost "
                        "frames cannot be named", status.length_x)
            for detection in self.spotter.flush():
                self._send(detection)
            self._start()
            return
        available = status.pairs_available
        if available:
            self._deferred += self._take(available)
        else:
            maintain = getattr(self.link, "maintain", None)
            if maintain is not None:
                maintain()      # a due RN-42 set-up now, not right after the next command
            if not self._deferred:
                self._nap(self.poll_interval)
                return
        while self._deferred:           # what is named while a send waits comes after it
            self._send(self._deferred.popleft())

    def _take(self, available: int) -> list[Command]:
        """Pop ``available`` records with the posture of the latest, and spot."""
        records = [self.fifo.pop_record() for _ in range(available)]
        first = self.spotter.frames
        if self.posture is not None:      # the latest record: the last frame popped
            self.posture.poll(first + len(records) - 1)
        named = []
        for k, (x, y, _flag, present) in enumerate(records):
            read = self.posture is not None and first + k in self.posture.names
            posture = self.posture.names[first + k] if read else None
            named += self.spotter.take(x, y, present, posture, posture_read=read)
        return named

    def _keep_up(self) -> None:
        """While the robot link waits (a reply, an RN-42 set-up): take what the
        FIFO holds, so that each frame's posture is read before the slave's next
        record replaces it; the commands named meanwhile wait for the send under
        way. Anything amiss is left to the next step."""
        if self._keeping_up or not self._started or self.bus_watch.active:
            return
        self._keeping_up = True
        try:
            status = self._checked_status()
            if not status.full and status.pairs_available:
                self._deferred += self._take(status.pairs_available)
        except Exception as exc:        # the next step meets it again and recovers
            log.debug("while the link waits: %s: %s", type(exc).__name__, exc)
        finally:
            self._keeping_up = False

    def _send(self, command: Command) -> None:
        name = command.name
        robot = self.models.command_of(name) if not command.by_posture else name
        data, sent, delivery = None, False, None
        if robot is not None:
            outcome = deliver_gesture(self.link, robot, command.power)     # never raises
            data, sent, delivery = outcome.telegram, outcome.written, outcome.status
            if outcome.status == FAILED:
                log.warning("telegram %s for %r %s", hex_bytes(data), name, outcome.describe())
        else:
            log.warning("class %r maps to none of the robot's commands; nothing sent", name)
        if command.posture_share is not None or command.by_posture:
            posture, share = command.posture, command.posture_share
        elif self.posture is not None:
            posture, share = self.posture.held(command.first, command.last)
        else:
            posture, share = None, None
        result = SpottedGesture(command.class_index, name, command.first, command.last,
                                command.named_at, command.score, data, sent, delivery,
                                posture, share, command.power, command.by_posture)
        self.results.append(result)
        if self._named is not None:
            self._named.append(result)
        what = "stop posture held" if command.by_posture else "spotted"
        log.info("%s %s (frames %d-%d, named at %d, score %.2f%s)%s", what, name,
                 result.first, result.last, result.named_at, result.score,
                 "" if command.power is None else f", power {command.power}",
                 f", telegram {hex_bytes(data)} {outcome.describe()}" if sent else "")
        if self.on_result is not None:
            try:
                self.on_result(result)
            except Exception as exc:
                log.error("on_result hook raised %s: %s", type(exc).__name__, exc)
