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
  their threshold model) names a gesture within ``end_delay`` frames of its
  end, once, and refuses what no gesture explains;
* a frame without a hand flushes: what is pending is named and the paths start
  afresh (the hand left the view);
* a named gesture's NXT telegram goes to the robot at once.

The hardware's flag is not used: it is the thesis' rest-gesture-rest
spotting, which this mode replaces. FIFO-FULL (the loop fell more than
:data:`~sw_hps.fifo.FIFO_DEPTH` frames behind) clears the FIFOs and flushes:
the lost frames cannot be named. Faults of the bus or the link never end the
loop: it logs one line and starts again after a back-off, as
:class:`~sw_hps.app.GestureApp` does.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Callable

from .continuous import ContinuousRecogniser, Detection, step_pixels
from .fifo import FRAC_BITS, FRAME_WIDTH
from .orientation import DistanceSymbols
from .telegram import GESTURE_NAMES, hex_bytes, telegram

__all__ = ["StreamingApp", "StreamSpotter", "SpottedGesture", "check_streaming_models"]

log = logging.getLogger(__name__)

#: Seconds between polls of an empty FIFO (the thesis application's default).
DEFAULT_POLL_INTERVAL = 0.005
#: Back-off after a fault (doubling up to the maximum), seconds.
INITIAL_BACKOFF, MAX_BACKOFF = 0.1, 5.0


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
class SpottedGesture:
    """A gesture named in the stream: class, the frames of its first and last
    symbol and the frame it was named at (frames counted from the stream's
    start), its score (log-likelihood above the threshold model), the telegram
    (None if its class has none) and whether the link took it."""
    class_index: int
    class_name: str
    first: int
    last: int
    named_at: int
    score: float
    telegram: bytes | None
    sent: bool

    def to_dict(self) -> dict:
        return {"name": self.class_name, "first": self.first, "last": self.last,
                "named_at": self.named_at, "score": round(self.score, 3),
                "telegram": hex_bytes(self.telegram) if self.telegram is not None else None,
                "sent": self.sent}


class StreamSpotter:
    """Records to named gestures, one record (frame) at a time: the part of
    :class:`StreamingApp` that does not touch the bus (the live view and the
    batch commands run it on the golden model's records).

    Parameters
    ----------
    models : discrete models with a ``spotting`` entry
    frame_width : int
        Width of the frames (scales ``step``).
    """

    def __init__(self, models, frame_width: int = FRAME_WIDTH):
        check_streaming_models(models)
        if isinstance(frame_width, bool) or not isinstance(frame_width, int) \
                or not 8 <= frame_width <= 4096:
            raise ValueError(f"frame_width must be an integer in [8, 4096], got {frame_width!r}")
        self.recogniser = ContinuousRecogniser(models, **models.spotting)
        self.symbols = DistanceSymbols(step_pixels(models.spotting["step"], frame_width))
        self.frames = 0              # records taken since the last reset

    @property
    def pending(self) -> bool:
        return self.recogniser.pending

    def reset(self) -> None:
        """A new stream (frames count from 0 again)."""
        self.recogniser.reset()
        self.symbols.reset()
        self.frames = 0

    def take(self, x_fixed: int, y_fixed: int, present: bool) -> list[Detection]:
        """One frame's record (10.8 smoothed position, hand present); the
        gestures named at it."""
        frame = self.frames
        self.frames += 1
        if present:
            symbol = self.symbols.push((int(x_fixed) >> FRAC_BITS, int(y_fixed) >> FRAC_BITS))
            return self.recogniser.step(frame, symbol)
        self.symbols.reset()          # the hand left: name what is pending
        return self.recogniser.flush(frame)

    def flush(self) -> list[Detection]:
        """The stream ends or breaks: name what is pending; paths start afresh."""
        self.symbols.reset()
        return self.recogniser.flush(self.frames - 1)


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
    """

    def __init__(self, models, fifo, link, *, sleep: Callable[[float], None] = time.sleep,
                 poll_interval: float = DEFAULT_POLL_INTERVAL, frame_width: int = FRAME_WIDTH,
                 on_result: Callable[[SpottedGesture], None] | None = None):
        self.spotter = StreamSpotter(models, frame_width)
        if not (isinstance(poll_interval, (int, float)) and 0 < poll_interval <= 1):
            raise ValueError(f"poll_interval must be in (0, 1] seconds, got {poll_interval!r}")
        self.models, self.fifo, self.link = models, fifo, link
        self._sleep = sleep
        self.poll_interval = float(poll_interval)
        self.on_result = on_result
        self.results: list[SpottedGesture] = []
        self.lost = 0                # FIFO-FULL events
        self.errors = 0
        self._started = False
        self._stop = False
        self._backoff = INITIAL_BACKOFF

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

    def run(self, max_iterations: int | None = None,
            until: Callable[[], bool] | None = None) -> list[SpottedGesture]:
        """Poll and spot until stopped (or ``until()`` is true, or after
        ``max_iterations`` steps); returns the gestures named meanwhile. Never
        raises for faults of the bus, the link or the data."""
        named: list[SpottedGesture] = []
        iterations = 0
        try:
            while not self._stop and (max_iterations is None or iterations < max_iterations):
                if until is not None and until():
                    break
                iterations += 1
                before = len(self.results)
                try:
                    self.step()
                    self._backoff = INITIAL_BACKOFF
                except KeyboardInterrupt:
                    raise
                except Exception as exc:  # the loop must survive any fault
                    self.errors += 1
                    delay, self._backoff = self._backoff, min(2 * self._backoff, MAX_BACKOFF)
                    log.error("streaming: %s: %s; restarting the stream in %.2f s",
                              type(exc).__name__, exc, delay)
                    self._started = False
                    self._sleep(delay)
                named += self.results[before:]
        except KeyboardInterrupt:
            log.info("interrupted; stopping")
        finally:
            self._stop = False
        return named

    def end_of_stream(self) -> list[SpottedGesture]:
        """The source ended (no more frames will come): name what is pending."""
        before = len(self.results)
        for detection in self.spotter.flush():
            self._send(detection)
        return self.results[before:]

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

    # ---- the loop ---------------------------------------------------------------
    def _start(self) -> None:
        """Streaming mode from an empty FIFO; the recogniser starts afresh."""
        self.fifo.clear(keep_running=True, streaming=True)
        self.spotter.reset()
        self._started = True
        log.info("streaming: GO and STREAM set, FIFOs cleared")

    def step(self) -> None:
        """One poll: take every record the FIFOs hold, or sleep."""
        if not self._started:
            self._start()
        status = self.fifo.status()
        if not (status.go and status.streaming):
            log.warning("streaming: Control reads %#x (GO and STREAM expected); setting "
                        "them again", status.control)
            self._start()
            return
        if status.full:
            self.lost += 1
            log.warning("streaming: FIFO-FULL (the loop fell %d frames behind); the lost "
                        "frames cannot be named", status.length_x)
            for detection in self.spotter.flush():
                self._send(detection)
            self._start()
            return
        available = status.pairs_available
        if not available:
            self._sleep(self.poll_interval)
            return
        for _ in range(available):
            x, y, _flag, present = self.fifo.pop_record()
            for detection in self.spotter.take(x, y, present):
                self._send(detection)

    def _send(self, detection: Detection) -> None:
        name = detection.name
        data, sent = None, False
        if name in GESTURE_NAMES:
            data = telegram(name)
            try:
                sent = bool(self.link.send(data))
            except Exception as exc:  # a link must not raise; keep the result if it does
                log.error("robot link raised %s: %s", type(exc).__name__, exc)
            if not sent:
                log.warning("telegram %s for %r not delivered", hex_bytes(data), name)
        else:
            log.warning("class %r is not one of the robot's gestures; nothing sent", name)
        result = SpottedGesture(detection.class_index, name, detection.first, detection.last,
                                detection.named_at, detection.score, data, sent)
        self.results.append(result)
        log.info("spotted %s (frames %d-%d, named at %d, score %.2f)%s", name,
                 result.first, result.last, result.named_at, result.score,
                 f", telegram {hex_bytes(data)}" if sent else "")
        if self.on_result is not None:
            try:
                self.on_result(result)
            except Exception as exc:
                log.error("on_result hook raised %s: %s", type(exc).__name__, exc)
