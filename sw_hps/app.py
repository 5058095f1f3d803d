"""The board application: read the hand trajectory from the FPGA, recognise the
gesture with the HMMs, command the robot (thesis §7.4.1 and §8.5).

Runs on the board's ARM: Python 3 and numpy only, nothing else from this project.

State machine (thesis §8.5)
---------------------------
S0 ``INIT``
    (Re)start: clear the FIFOs and set GO in one Control write, forget any partial
    gesture, and ignore a gesture that is already in progress (gesture bit 0 right
    after the clear: its beginning was missed): points are discarded until the
    gesture bit reads 1. The models are
    loaded once, before S0 (they never change while running).
S1 ``WAIT``
    Poll Control (one status read per poll, then sleep ``poll_interval``) until a
    gesture starts: gesture bit 0 or FIFO data 1. A new gesture starts a fresh
    :class:`~sw_hps.hmm.ForwardStream`. While nothing happens, one INFO line every
    ``heartbeat`` seconds says the application is alive and gives its counters
    (gestures recognised / rejected / dropped, errors, faults, points dropped).
S2 ``READ``
    Pop the pairs the FIFOs hold (at most ``max_pairs_per_poll`` per poll). The
    orientation symbol of each step between consecutive points
    (:func:`sw_hps.orientation.orientation_symbols` on the raw 10.8 values) is fed to
    the forward pass of every class model, one update per symbol; zero steps
    (``NO_SYMBOL``) are dropped. Gaussian models (the default model file) need the
    whole gesture, so the points are buffered instead (at most ``max_points``) and
    scored in S3; the symbols are still counted. Sleeps ``poll_interval`` only when nothing was
    available. The gesture has ended when a status read shows the gesture bit back
    at 1 and FIFO data 0 -> S3. A gesture still being read after ``heartbeat``
    seconds also gets the "alive" line.
S3 ``CLASSIFY``
    The class with the best log-likelihood. Rejected (logged reason, no telegram) if
    fewer than ``min_symbols`` symbols were seen, every model gives probability 0,
    or the model file's rejection rule refuses it: its log-likelihood per step is
    below the best class' threshold (not a gesture).
S4 ``SEND``
    Send the class' telegram (:func:`sw_hps.telegram.telegram`, chosen by class *name*;
    a class whose name is not one of the seven gestures sends nothing).
S5 ``CLEAR``
    Clear the FIFOs (GO stays set) and return to S1.

Postures
--------
With a posture tracker (``--posture-model``) each S1/S2 step reads the posture
slave's latest record. A model file with a ``postures`` entry
(:mod:`sw_hps.posture_commands`) then adds two rules: S3 refuses a gesture
whose records were not in a command posture often enough (the telegram of one
that was carries the power of its posture), and the stop posture held for
``stop_frames`` records sends the stop telegram at once, from S1 or S2: a
gesture in progress is dropped and ignored to its end, and S3 refuses every
gesture until a record shows another posture.

Faults
------
Each fault is logged as a WARNING that names the register values and the reason,
counted in ``GestureApp.faults`` (one per fault seen, reminders not counted), and
recovered from without a restart. A dropped
gesture gives a ``"dropped"`` :class:`GestureResult` with that reason and sends no
telegram; "ignore the rest of the gesture" means S1 discards (clears) whatever the
FIFOs receive until the gesture bit reads 1 ("no gesture").

* FIFO-FULL, or more than ``max_points`` valid points: drop the gesture, clear the
  FIFOs, ignore the rest of the gesture. FIFO-FULL in S1 while no gesture is flagged
  and the FIFOs hold no pair (impossible in the hardware: a stuck bit) is cleared like
  an idle length fault (below), without a result.
* Stuck gesture bit: in S2 the gesture bit reads 0 ("gesture in progress") but no
  pair arrives for more than ``gesture_timeout`` seconds (a gesture pushes one pair
  per video frame): drop the gesture, clear the FIFOs, ignore the bit until it reads
  1. Whenever S1 ignores a gesture (after a drop, or one already in progress at S0)
  and the bit reads 0 with no FIFO data for more than ``gesture_timeout``, one
  warning says the bit is stuck; while S1 keeps ignoring it, a reminder at most once
  per ``heartbeat`` (never once per poll; none if the heartbeat is off); one INFO
  line when the bit reads 1 again.
* Point outside the frame: a popped pair with x >= ``frame_width`` or y >=
  ``frame_height`` (pixels, 10.8 decoded; default :data:`~soc.hps_interface.FRAME_WIDTH` x
  :data:`~soc.hps_interface.FRAME_HEIGHT`), or with bits above the 18 data bits set in
  Dato_X / Dato_Y, is dropped with a warning giving the values and the allowed range
  (counted in ``bad_points``). The gesture goes on with its valid points (the step
  across the gap gives one symbol). More than ``max_bad_points`` such points in one
  gesture drop the gesture (garbage, not a hand).
* Longitud_X != Longitud_Y, or either above :data:`~soc.hps_interface.FIFO_DEPTH`: the FIFOs
  are pushed and popped together, so this is misalignment or a bus fault. A push
  between the two length reads makes them differ by one legitimately, so they are
  read once more first; if they still disagree, S2 drops the gesture and clears the
  FIFOs (FIFO-CLR empties both: they are aligned again). In S1 with no gesture
  flagged and no pair (e.g. one FIFO holds an entry the other lacks) the FIFOs are
  cleared without a result; one warning when the fault appears, then at most once
  per ``heartbeat`` while it lasts (each poll clears again).
* Bus fault: a read no working core gives (:mod:`sw_hps.busfault`): Control with a
  bit of [31:6] set (all ones, e.g. a bridge with no slave behind it), GO not reading
  back after S0 set it or reading 0 later (all zeros: the core in reset or not there;
  or another program cleared it), STREAM set although S0 wrote 0, or Longitud_X /
  Longitud_Y above :data:`~soc.hps_interface.FIFO_DEPTH` (read twice). The gesture
  in progress is dropped; one warning names the reads, the ID register and the
  likely cause (bridge disabled or in reset, FPGA not configured, core in reset)
  and points to ``python -m sw_hps --check``. Then the registers are only probed
  (Control, Longitud_X/Y, ID; no writes), the sleep between two probes doubling
  from ``poll_interval`` up to ``max_fault_interval``, with a reminder at most once
  per ``heartbeat``. When the reads look sane again and ID reads
  :data:`~soc.hps_interface.CORE_MAGIC`, S0 re-initialises the core (FIFO-CLR and
  GO); once GO reads back, one INFO line ends the fault. Counted in ``bus_faults``
  (also in the "alive" line). A bus fault that returns within a heartbeat of the
  last line keeps the back-off and logs nothing new until a reminder is due.
* Any exception inside one step (bus error, bad value) is logged, the partial gesture
  is dropped, and after a back-off (doubling from ``initial_backoff`` up to
  ``max_backoff``; back to the minimum after :data:`HEALTHY_STEPS` error-free steps)
  the machine restarts at S0. Once the back-off is at ``max_backoff``, the same
  error again is logged at most once per ``heartbeat`` (one minute if off), with
  the number of repeats left out.
* A bus error the CPU takes as a signal (SIGBUS) ends the process; ``python -m
  sw_hps`` runs the application in a supervised child process for the mapped buses
  (:mod:`sw_hps.guard`), which logs one line and exits with status 1.

The loop never spins: a step with nothing to do sleeps ``poll_interval``, a fault
sleeps its back-off, and after :data:`~sw_hps.busfault.MAX_BUSY_STEPS` steps in a
row without any sleep (each popped data or changed state) it sleeps one
``poll_interval`` anyway.

So the application is never silent for longer than about ``heartbeat`` seconds
(with the heartbeat on): idle or reading, it logs the "alive" line; ignoring a
gesture, its reminders; a lasting idle fault, its warnings; and a stuck gesture bit
ends a gesture ``gesture_timeout`` after the last pair. Timeouts and the heartbeat read
``clock`` (``time.monotonic``; injectable like ``sleep``, e.g. a
:class:`sw_hps.simulated.SimulatedClock`). :meth:`GestureApp.request_stop` (the CLI's SIGINT/SIGTERM
handlers) ends :meth:`GestureApp.run` cleanly.

Every finished gesture gives one :class:`GestureResult` (recognised, rejected or
dropped), passed to the ``on_result`` hook and returned by :meth:`GestureApp.run`.
:func:`sw_hps.simulated.run_on_trajectory` runs the unmodified application against a
simulated FIFO fed with a whole trajectory (the end-to-end demo and ``--bus sim``).
"""
from __future__ import annotations

import dataclasses
import enum
import logging
import numbers
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .fifo import (DATA_BITS, DATA_MASK, FIFO_DEPTH, FRAC_BITS, FRAME_HEIGHT, FRAME_WIDTH,
                   FifoPeripheral, FifoStatus, from_fixed)
from .busfault import (FAULT_REMINDER, MAX_BUSY_STEPS, MAX_FAULT_INTERVAL, BusFault,
                       BusFaultWatch, RepeatFilter, control_fault, describe_bus, lengths_fault,
                       read_id)
from .hmm import GestureModels
from .orientation import NO_SYMBOL, NUM_SYMBOLS, orientation_symbols
from .posture_commands import PostureCommands, postures_for_frame
from .robot import FAILED, NullLink, deliver_gesture
from .telegram import GESTURE_NAMES, hex_bytes

__all__ = ["State", "GestureResult", "GestureClassifier", "GestureApp", "DEFAULT_MIN_SYMBOLS",
           "DEFAULT_MAX_POINTS", "DEFAULT_GESTURE_TIMEOUT", "DEFAULT_HEARTBEAT",
           "DEFAULT_MAX_BAD_POINTS", "check_models"]

log = logging.getLogger(__name__)

#: Fewest symbols a gesture needs to be classified (a twitch gives a handful).
DEFAULT_MIN_SYMBOLS = 5
#: Error-free steps in a row after which the back-off starts again from its minimum.
HEALTHY_STEPS = 50
#: Finished gestures an application keeps in ``results`` (the latest; it runs for days).
RESULTS_KEPT = 1000
#: Most points one gesture may have (10 s at 30 frames/s; the thesis' last 1-3 s).
DEFAULT_MAX_POINTS = 300
#: Seconds S2 waits for the next pair while the gesture bit says "gesture in progress"
#: (pairs come every 33 ms during a gesture; 2 s is 60 frames without one).
DEFAULT_GESTURE_TIMEOUT = 2.0
#: Seconds between two "alive" lines while idle (and between reminders of a lasting fault).
DEFAULT_HEARTBEAT = 60.0
#: Points outside the frame one gesture may lose before it is dropped (a few glitches
#: in a 40-100 point gesture are survivable; more means garbage, not a hand).
DEFAULT_MAX_BAD_POINTS = 5
#: Frame widths / heights the 10.8 format can carry (10 integer bits).
_MAX_FRAME_SIZE = 1 << (DATA_BITS - FRAC_BITS)


def check_models(models: GestureModels) -> GestureModels:
    """Refuse (``ValueError``) models this application cannot run: discrete
    models must emit the 8 orientation symbols the FIFO's points give. The
    command line and the bundle check it before anything runs or ships."""
    if models.emission == "discrete" and models.num_symbols != NUM_SYMBOLS:
        raise ValueError(f"models must use the {NUM_SYMBOLS} orientation symbols, "
                         f"got num_symbols={models.num_symbols}")
    return models


class State(enum.Enum):
    """States of thesis §8.5 (see the module docstring)."""
    INIT = "S0"
    WAIT = "S1"
    READ = "S2"
    CLASSIFY = "S3"
    SEND = "S4"
    CLEAR = "S5"


@dataclass(frozen=True)
class GestureResult:
    """Outcome of one gesture.

    Attributes
    ----------
    outcome : str
        ``"recognised"``, ``"rejected"`` (classifier said no) or ``"dropped"`` (fault).
    class_index : int
        Index into the model file's classes, -1 unless recognised.
    class_name : str or None
        Its name.
    scores : tuple of float
        Log-likelihood per class (empty when dropped).
    num_points, num_symbols : int
        Points read and symbols fed to the models.
    symbols : tuple of int
        The symbols fed.
    reason : str or None
        Why it was rejected or dropped.
    telegram : bytes or None
        Telegram sent for a recognised gesture (None if its class has none).
    sent : bool
        Whether the link accepted the telegram's bytes.
    delivery : str or None
        What became of the telegram (:class:`sw_hps.robot.Delivery`):
        ``"acknowledged"`` by the brick, ``"unconfirmed"`` or ``"failed"``;
        None when nothing was sent.
    posture, posture_share : str or None, float or None
        The posture held over most of the gesture's frames and their share in
        it (None without a posture tracker, or for a dropped gesture); with
        posture commands, the command posture held and the share of the
        frames in a command posture.
    power : int or None
        The telegram's motor power (posture commands with a power table).
    by_posture : bool
        A stop sent because the stop posture was held (no trajectory).
    """
    outcome: str
    class_index: int = -1
    class_name: str | None = None
    scores: tuple[float, ...] = ()
    num_points: int = 0
    num_symbols: int = 0
    symbols: tuple[int, ...] = field(default=(), repr=False)
    reason: str | None = None
    telegram: bytes | None = None
    sent: bool = False
    delivery: str | None = None
    posture: str | None = None
    posture_share: float | None = None
    power: int | None = None
    by_posture: bool = False

    @property
    def recognised(self) -> bool:
        return self.outcome == "recognised"

    def to_dict(self) -> dict:
        """JSON-friendly form (telegram as hex, -inf scores as None)."""
        return {"outcome": self.outcome, "class_index": self.class_index,
                "class_name": self.class_name,
                "scores": [s if np.isfinite(s) else None for s in self.scores],
                "num_points": self.num_points, "num_symbols": self.num_symbols,
                "reason": self.reason,
                "telegram": hex_bytes(self.telegram) if self.telegram is not None else None,
                "sent": self.sent, "delivery": self.delivery, "posture": self.posture,
                "posture_share": self.posture_share, "power": self.power,
                "by_posture": self.by_posture}


class GestureClassifier:
    """Classifier stage (S2-S3): points -> forward pass of every class model
    (thesis §7.4, §8.5) -> the model file's decision rule.

    Discrete models are scored as the points arrive: each non-zero step's
    orientation symbol updates the forward pass at once. Gaussian models
    (:mod:`sw_hps.gaussian_hmm`) need the whole gesture (its length and end
    normalise the features), so the points are buffered (at most the app's
    ``max_points``) and scored when the gesture ends. Either way the
    orientation symbols are counted: fewer than ``min_symbols`` is "too short".

    Parameters
    ----------
    models : GestureModels or GaussianGestureModels
        One HMM per class (discrete ones use the 8 orientation symbols).
    min_symbols : int >= 1
        Fewer non-zero steps than this is a rejection.
    """

    def __init__(self, models, min_symbols: int = DEFAULT_MIN_SYMBOLS):
        if isinstance(min_symbols, bool) or not isinstance(min_symbols, int) or min_symbols < 1:
            raise ValueError(f"min_symbols must be an int >= 1, got {min_symbols!r}")
        self.models = models
        self.min_symbols = min_symbols
        self.streaming = models.emission == "discrete"
        self._stream = models.stream() if self.streaming else None
        self.reset()

    def reset(self) -> None:
        """Start a new gesture."""
        if self._stream is not None:
            self._stream.reset()
        self._last_point: tuple[int, int] | None = None
        self._points: list[np.ndarray] = []
        self._scores: np.ndarray | None = None
        self.num_points = 0
        self.symbols: list[int] = []

    def add_points(self, points) -> int:
        """Take raw points ``(n, 2)`` (10.8 fixed point, any integers); count
        (and for discrete models feed) the symbol of every non-zero step,
        including the one from the previous call's last point. Returns the
        number of symbols."""
        points = np.asarray(points, dtype=np.int64).reshape(-1, 2)
        if not len(points):
            return 0
        self.num_points += len(points)
        if not self.streaming:
            self._points.append(points)
            self._scores = None
        if self._last_point is not None:
            points = np.concatenate([np.array([self._last_point], dtype=np.int64), points])
        self._last_point = (int(points[-1, 0]), int(points[-1, 1]))
        if len(points) < 2:
            return 0
        fed = 0
        for symbol in orientation_symbols(points):
            if symbol != NO_SYMBOL:
                self.feed_symbol(int(symbol))
                fed += 1
        return fed

    def feed_symbol(self, symbol: int) -> None:
        """One symbol (0..7): a forward-pass update of discrete models."""
        if self._stream is not None:
            self._stream.update(symbol)
        self.symbols.append(int(symbol))

    @property
    def num_symbols(self) -> int:
        return len(self.symbols)

    def scores(self) -> np.ndarray:
        """Log-likelihood per class of the gesture so far (Gaussian models:
        of the buffered points, computed once per gesture end)."""
        if self.streaming:
            return self._stream.log_likelihoods()
        if self._scores is None:
            points = np.concatenate(self._points) if self._points else np.zeros((0, 2))
            scores = self.models.scores_of_points(points) if len(points) else None
            self._scores = np.full(len(self.models.class_names), -np.inf) \
                if scores is None else scores
        return self._scores

    def decide(self) -> tuple[int, str | None]:
        """``(class_index, None)`` or ``(-1, reason)`` for the gesture so far (S3):
        too short, no finite likelihood, or refused by the model file's
        rejection thresholds (not a gesture)."""
        if self.num_symbols < self.min_symbols:
            return -1, (f"too short: {self.num_symbols} symbols from {self.num_points} "
                        f"points (min_symbols={self.min_symbols})")
        return self.models.decide(self.scores(), self.num_symbols)


def _is_real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


class GestureApp:
    """The §8.5 state machine over a FIFO driver and a robot link.

    Parameters
    ----------
    models : GestureModels
        The class models (from :func:`sw_hps.hmm.load_models`).
    fifo : FifoPeripheral
        Driver of the FIFO slave.
    link : object with ``send(bytes) -> bool``, optional
        Robot link (:mod:`sw_hps.robot`); :class:`~sw_hps.robot.NullLink` if None.
    min_symbols, max_points : int
        Rejection and fault thresholds (module docstring).
    poll_interval : float
        Seconds slept when a poll finds nothing to do.
    max_pairs_per_poll : int
        Pairs popped per poll at most (bounds a step even on garbage lengths).
    initial_backoff, max_backoff : float
        Delays before re-initialising after an exception (doubling, capped).
    sleep : callable
        ``sleep(seconds)``; injectable (tests, simulated time).
    on_result : callable, optional
        Called with each :class:`GestureResult`; its exceptions are logged.
    gesture_timeout : float > 0
        Seconds without a pair, gesture bit 0, after which the gesture bit counts as
        stuck (module docstring, Faults).
    heartbeat : float >= 0 or None
        Seconds between two "alive" lines (while idle, or reading a gesture that has
        not ended), and between reminders of a lasting fault; 0 or None turns both
        off (a lasting fault is then logged once).
    max_bad_points : int >= 0
        Points outside the frame one gesture may lose; one more drops the gesture.
    frame_width, frame_height : int in [1, 1024]
        Frame size in pixels; valid points lie in [0, frame_width) x [0, frame_height).
    clock : callable
        ``clock() -> seconds`` (monotonic) for the timeout and the heartbeat;
        injectable like ``sleep``.
    max_fault_interval : float in (0, 60]
        Longest sleep between two probes of the registers during a bus fault
        (module docstring, Faults).
    posture : sw_hps.posture.PostureTracker, optional
        Polled at every step (the posture slave's latest record, counted by its
        own sequence number); each classified gesture then names the posture
        held over the frames from its start to its end. Needed by a model file
        with a ``postures`` entry (:mod:`sw_hps.posture_commands`): a gesture
        is then refused unless made in a command posture, and the stop
        posture sends the stop telegram at once (module docstring).

    Attributes
    ----------
    outcomes : dict
        Gestures finished per outcome (``"recognised"``, ``"rejected"``, ``"dropped"``).
    errors, faults, bad_points : int
        Exceptions recovered from, faults seen (module docstring; reminders not
        counted), points dropped for lying outside the frame.
    bus_watch : sw_hps.busfault.BusFaultWatch
        The bus faults: ``bus_faults`` of them so far.
    """

    def __init__(self, models: GestureModels, fifo: FifoPeripheral, link=None, *,
                 min_symbols: int = DEFAULT_MIN_SYMBOLS, max_points: int = DEFAULT_MAX_POINTS,
                 poll_interval: float = 0.005, max_pairs_per_poll: int = FIFO_DEPTH,
                 initial_backoff: float = 0.1, max_backoff: float = 5.0,
                 sleep: Callable[[float], None] = time.sleep,
                 on_result: Callable[[GestureResult], None] | None = None,
                 gesture_timeout: float = DEFAULT_GESTURE_TIMEOUT,
                 heartbeat: float | None = DEFAULT_HEARTBEAT,
                 max_bad_points: int = DEFAULT_MAX_BAD_POINTS,
                 frame_width: int = FRAME_WIDTH, frame_height: int = FRAME_HEIGHT,
                 clock: Callable[[], float] = time.monotonic,
                 max_fault_interval: float = MAX_FAULT_INTERVAL, posture=None):
        check_models(models)
        for name, value in (("max_points", max_points), ("max_pairs_per_poll", max_pairs_per_poll)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an int >= 1, got {value!r}")
        if not poll_interval >= 0:
            raise ValueError(f"poll_interval must be >= 0, got {poll_interval!r}")
        if not 0 < initial_backoff <= max_backoff:
            raise ValueError("need 0 < initial_backoff <= max_backoff, got "
                             f"{initial_backoff!r}, {max_backoff!r}")
        if not (_is_real(gesture_timeout) and 0 < gesture_timeout < float("inf")):
            raise ValueError(f"gesture_timeout must be a finite number of seconds > 0, "
                             f"got {gesture_timeout!r}")
        if heartbeat is not None and not (_is_real(heartbeat)
                                          and 0 <= heartbeat < float("inf")):
            raise ValueError(f"heartbeat must be None or a finite number of seconds >= 0 "
                             f"(0 = off), got {heartbeat!r}")
        if isinstance(max_bad_points, bool) or not isinstance(max_bad_points, int) \
                or max_bad_points < 0:
            raise ValueError(f"max_bad_points must be an int >= 0, got {max_bad_points!r}")
        for name, value in (("frame_width", frame_width), ("frame_height", frame_height)):
            if isinstance(value, bool) or not isinstance(value, int) \
                    or not 1 <= value <= _MAX_FRAME_SIZE:
                raise ValueError(f"{name} must be an int in [1, {_MAX_FRAME_SIZE}] (10.8 "
                                 f"fixed point), got {value!r}")
        self.models = models
        self.fifo = fifo
        self.link = link if link is not None else NullLink()
        self.classifier = GestureClassifier(models, min_symbols)
        self.max_points = max_points
        self.poll_interval = float(poll_interval)
        self.max_pairs_per_poll = max_pairs_per_poll
        self.initial_backoff = float(initial_backoff)
        self.max_backoff = float(max_backoff)
        self._sleep = sleep
        self.on_result = on_result
        self.state = State.INIT
        #: True while the rest of a dropped / already-running gesture is ignored.
        self.discarding = False
        self.backoff = self.initial_backoff
        self.errors = 0
        self._healthy_steps = 0
        self.results: deque[GestureResult] = deque(maxlen=RESULTS_KEPT)
        self._pending: GestureResult | None = None
        self._stop = False
        self._run_results: list[GestureResult] | None = None
        self.gesture_timeout = float(gesture_timeout)
        self.heartbeat = float(heartbeat) if heartbeat else None
        self.max_bad_points = max_bad_points
        self.frame_width, self.frame_height = frame_width, frame_height
        self._clock = clock
        self.outcomes = {"recognised": 0, "rejected": 0, "dropped": 0}
        self.faults = 0
        self.bad_points = 0
        self._gesture_bad_points = 0
        # S2: clock of the last pair popped (or of the gesture's start).
        self._last_pair_at = 0.0
        # Clock of the last heartbeat (None: S0 has not run yet).
        self._last_heartbeat: float | None = None
        # While discarding: since when, FIFO data last seen, stuck bit reported, last line.
        self._discard_since = self._discard_data_at = self._discard_logged_at = 0.0
        self._stuck_reported = False
        # S1: clock of the last warning about a lasting idle fault (None: no fault).
        self._idle_fault_at: float | None = None
        self.bus_watch = BusFaultWatch(
            label="gesture loop", where=describe_bus(fifo.bus, fifo.base),
            read_id=lambda: read_id(fifo), poll_interval=self.poll_interval,
            max_interval=max_fault_interval, reminder=self.heartbeat, clock=clock, logger=log)
        # Repeats of the same error at the capped back-off are logged once per reminder.
        self._error_lines = RepeatFilter(self.heartbeat or FAULT_REMINDER, clock)
        self._slept = False          # the current step slept
        self._busy_steps = 0         # steps in a row without any sleep
        self.posture = posture
        self._posture_first = None   # the posture record the gesture began at
        postures = getattr(models, "postures", None)
        if postures is not None and posture is None:
            raise ValueError("the model file's postures entry needs a posture tracker "
                             "(--posture-model)")
        postures = postures_for_frame(postures, frame_width, log)
        self.commands = PostureCommands(postures) if postures is not None else None

    # ---- control ----------------------------------------------------------------
    def request_stop(self) -> None:
        """Make :meth:`run` return after the current step, or at once if it has not
        started yet (signal-handler safe)."""
        self._stop = True

    @property
    def stopping(self) -> bool:
        return self._stop

    @property
    def bus_faults(self) -> int:
        """Bus faults seen (module docstring, Faults)."""
        return self.bus_watch.episodes

    def _pause(self, seconds: float) -> None:
        # Short slices so that a stop request ends a long back-off promptly.
        remaining = seconds
        while remaining > 0 and not self._stop:
            chunk = min(remaining, 0.1)
            self._slept = True
            self._sleep(chunk)
            remaining -= chunk

    def run(self, max_iterations: int | None = None,
            until: Callable[[], bool] | None = None) -> list[GestureResult]:
        """Run the state machine.

        Parameters
        ----------
        max_iterations : int, optional
            Steps (state actions) at most; forever if None.
        until : callable, optional
            Checked before each step; the loop ends when it returns True.

        Returns
        -------
        list of GestureResult
            The gestures finished during this call. Never raises for faults of
            the bus, the link or the data; KeyboardInterrupt ends it cleanly.
        """
        results: list[GestureResult] = []
        self._run_results = results
        iterations = 0
        try:
            while not self._stop and (max_iterations is None or iterations < max_iterations):
                if until is not None and until():
                    break
                iterations += 1
                self._slept = False
                try:
                    self.step()
                except KeyboardInterrupt:
                    raise
                except BusFault as fault:
                    self._healthy_steps = 0
                    self._bus_fault(fault)
                except Exception as exc:  # the loop must survive any fault
                    self._healthy_steps = 0
                    self._recover(exc)
                else:
                    self._healthy_steps += 1
                    if self._healthy_steps == HEALTHY_STEPS:
                        self.backoff = self.initial_backoff
                # Never spin: a step that popped data or changed state needs no sleep,
                # but a long run of them (a stuck FIFO data bit) still yields the CPU.
                self._busy_steps = 0 if self._slept else self._busy_steps + 1
                if self._busy_steps >= MAX_BUSY_STEPS:
                    self._busy_steps = 0
                    self._pause(self.poll_interval)
        except KeyboardInterrupt:
            log.info("interrupted; stopping")
        finally:
            self._run_results = None
            self._stop = False  # a stop request ends one run
        return results

    def _recover(self, exc: Exception) -> None:
        self.errors += 1
        delay = self.backoff
        self.backoff = min(self.backoff * 2, self.max_backoff)
        line = (f"error in state {self.state.value}: {type(exc).__name__}: {exc}; "
                f"re-initialising in {delay:.2f} s")
        left_out = self._error_lines.admit(line)
        if left_out is not None:
            log.error("%s%s", line, f" ({left_out} more like it not logged)" if left_out else "")
        log.debug("traceback of the error", exc_info=True)
        self._abandon(f"{type(exc).__name__}: {exc}")
        self._pause(delay)

    def _abandon(self, reason: str) -> None:
        """After an error or a bus fault: keep a gesture decided before it, drop
        one under way (``reason``), and start again at S0."""
        if self._pending is not None:
            self._finish(self._pending)  # decided before the fault: keep it
        elif self.state in (State.READ, State.CLASSIFY):
            self._finish(GestureResult("dropped", num_points=self.classifier.num_points,
                                       num_symbols=self.classifier.num_symbols,
                                       reason=reason))
        self._pending = None
        self.classifier.reset()
        self.state = State.INIT

    def _bus_fault(self, fault: BusFault) -> None:
        """A step read what no working core gives: drop the gesture, back off, and
        probe the registers until they look sane (module docstring, Faults)."""
        self._abandon(f"bus fault: {fault}")
        self._pause(self.bus_watch.fault(str(fault)))

    def shutdown(self) -> None:
        """Clear GO and close the link (errors logged, never raised)."""
        try:
            self.fifo.stop()
        except Exception as exc:
            log.warning("could not clear GO: %s", exc)
        try:
            self.link.close()
        except Exception as exc:
            log.warning("could not close the robot link: %s", exc)

    # ---- the state machine --------------------------------------------------------
    def step(self) -> None:
        """Execute the action of the current state once (may raise; :meth:`run`
        recovers)."""
        if self.bus_watch.active and not self.bus_watch.recovering:
            # A bus fault: only probe (no writes) until the reads look sane; S0 then
            # re-initialises the core.
            delay = self.bus_watch.probe(self.fifo)
            if delay is not None:
                self._pause(delay)
            return
        action = {State.INIT: self._init, State.WAIT: self._wait, State.READ: self._read,
                  State.CLASSIFY: self._classify, State.SEND: self._send,
                  State.CLEAR: self._clear}[self.state]
        if self.posture is not None and action in (self._wait, self._read):
            frame = self.posture.poll()   # never raises: a fault costs that frame's posture
            if frame is not None and self.commands is not None \
                    and self.commands.take(frame, self.posture.last):
                self._stop_by_posture(frame)
                return
        action()

    def _stop_by_posture(self, frame: int) -> None:
        """The stop posture was held: the stop telegram now; a gesture in
        progress is dropped, and the rest of it ignored."""
        stop = self.commands.options["stop"]
        delivery = deliver_gesture(self.link, "stop")       # never raises
        log.log(logging.WARNING if delivery.status == FAILED else logging.INFO,
                "stop posture %s held since record %d: telegram %s %s", stop,
                self.commands.stop_started, hex_bytes(delivery.telegram), delivery.describe())
        index = list(self.models.class_names).index("stop") \
            if "stop" in self.models.class_names else -1
        self._finish(GestureResult("recognised", class_index=index, class_name="stop",
                                   telegram=delivery.telegram, sent=delivery.written,
                                   delivery=delivery.status, posture=stop, by_posture=True))
        if self.state in (State.READ, State.CLASSIFY, State.SEND):
            self._pending = GestureResult("dropped", num_points=self.classifier.num_points,
                                          num_symbols=self.classifier.num_symbols,
                                          reason="the stop posture was held")
            self._start_discarding()
            self.state = State.CLEAR

    def _status(self, *, just_set: bool = False) -> FifoStatus:
        """Read the status; :class:`BusFault` if Control reads what no working core
        gives while GO is set (``just_set``: S0 wrote it right before)."""
        status = self.fifo.status()
        problem = control_fault(status.control, stream=False, just_set=just_set)
        if problem is not None:
            raise BusFault(problem)
        return status

    def _init(self) -> None:  # S0
        self.classifier.reset()
        self._pending = None
        self.fifo.clear(keep_running=True)
        status = self._status(just_set=True)
        recovered = self.bus_watch.active
        self.bus_watch.confirm("FIFO-CLR, GO")
        # A gesture already flagged began before the clear: its start is lost.
        self.discarding = status.gesture_active
        if self.discarding:
            self._start_discarding()
        if self._last_heartbeat is None:
            self._last_heartbeat = self._clock()  # the heartbeat counts from this line
        # After a bus fault the watch's line says it (a flapping bus must not flood).
        log.log(logging.DEBUG if recovered else logging.INFO, "S0: FIFO cleared, capture "
                "running%s", "; ignoring the gesture in progress" if self.discarding else "")
        self.state = State.WAIT

    def _wait(self) -> None:  # S1
        status = self._status()
        if self.discarding:
            if status.gesture_active:
                self._watch_discarded(status)
                if status.data or status.full:
                    self.fifo.clear(keep_running=True)
                self._pause(self.poll_interval)
                return
            self._stop_discarding()
            if status.data or status.full:
                # The discarded gesture's tail: nothing to read until the next poll.
                self.fifo.clear(keep_running=True)
                self._pause(self.poll_interval)
                return
        if status.data or status.gesture_active:
            log.debug("S1: gesture started")
            if self.posture is not None:
                self._posture_first = self.posture.reader.frame
            self.classifier.reset()
            self._gesture_bad_points = 0
            self._last_pair_at = self._clock()
            self.state = State.READ
            self._consume(status)  # FIFO-FULL and the lengths are checked there
            return
        # No gesture and no pair: FIFO-FULL or misaligned FIFOs are cleared before the
        # next gesture starts in them.
        if status.full:
            problem = "FIFO-FULL set while no gesture is flagged and the FIFOs hold no pair"
        else:
            status, problem = self._check_lengths(status)
        if problem is not None:
            self._idle_fault(problem)
            return
        self._idle_fault_at = None
        maintain = getattr(self.link, "maintain", None)
        if maintain is not None:
            maintain()           # a due RN-42 set-up now, not after the next gesture
        self._beat("waiting for a gesture (S1)")
        self._pause(self.poll_interval)

    def _beat(self, activity: str) -> None:
        """The "alive" line with the counters, at most once per ``heartbeat``."""
        if self.heartbeat is None:
            return
        now = self._clock()
        if self._last_heartbeat is None:
            self._last_heartbeat = now
        elif now - self._last_heartbeat >= self.heartbeat:
            self._last_heartbeat = now
            log.info("alive: %s; %s", activity, self._counters())

    def _counters(self) -> str:
        done = self.outcomes
        return (f"gestures {done['recognised']} recognised, {done['rejected']} rejected, "
                f"{done['dropped']} dropped; {self.errors} errors; {self.faults} faults "
                f"({self.bad_points} points outside the frame); {self.bus_watch.counters()}")

    def _start_discarding(self, *, stuck: bool = False) -> None:
        """Ignore the rest of the gesture in progress (until the gesture bit reads 1)."""
        now = self._clock()
        self.discarding = True
        self._discard_since = self._discard_logged_at = now
        # A stuck bit was reported by S2 already; its silence began with the last pair.
        self._discard_data_at = self._last_pair_at if stuck else now
        self._stuck_reported = stuck

    def _watch_discarded(self, status: FifoStatus) -> None:
        """S1 ignoring a gesture whose bit still reads 0: one warning once no FIFO data
        came for ``gesture_timeout`` (the bit looks stuck), then a reminder at most
        once per ``heartbeat``, not once per poll."""
        now = self._clock()
        if status.data:
            self._discard_data_at = now
        quiet = now - self._discard_data_at
        if not self._stuck_reported and quiet > self.gesture_timeout:
            self._stuck_reported = True
            self._discard_logged_at = now
            self.faults += 1
            log.warning("S1: gesture bit stuck at 0 (gesture in progress) with no FIFO data "
                        "for %.1f s (gesture_timeout=%g s); ignoring it until it reads 1",
                        quiet, self.gesture_timeout)
        elif self.heartbeat is not None and now - self._discard_logged_at >= self.heartbeat:
            self._discard_logged_at = now
            what = (f"stuck: no FIFO data for {quiet:.1f} s" if quiet > self.gesture_timeout
                    else "pairs still arrive and are discarded")
            log.warning("S1: gesture bit still 0 after %.1f s (%s); ignoring it until it "
                        "reads 1; %s", now - self._discard_since, what, self._counters())

    def _stop_discarding(self) -> None:
        self.discarding = False
        if self._stuck_reported:
            log.info("S1: gesture bit reads 1 again after %.1f s; back to normal",
                     self._clock() - self._discard_since)
        self._stuck_reported = False

    @staticmethod
    def _lengths_agree(length_x: int, length_y: int) -> bool:
        return length_x == length_y <= FIFO_DEPTH

    def _check_lengths(self, status: FifoStatus) -> tuple[FifoStatus, str | None]:
        """``(status, None)`` if Longitud_X/Y are plausible (the status with lengths read
        again if needed), else ``(status, reason)``; :class:`BusFault` if either
        exceeds FIFO_DEPTH in both reads."""
        if self._lengths_agree(status.length_x, status.length_y):
            return status, None
        # A push between the two length reads makes them differ by one: read again.
        length_x, length_y = self.fifo.lengths()
        if self._lengths_agree(length_x, length_y):
            return dataclasses.replace(status, length_x=length_x, length_y=length_y), None
        reads = f"read twice: {status.length_x}/{status.length_y}, then {length_x}/{length_y}"
        problem = lengths_fault(length_x, length_y)
        if problem is not None:
            raise BusFault(f"{problem} ({reads})")
        return status, (f"Longitud_X={length_x} and Longitud_Y={length_y} differ ({reads}; "
                        "the FIFOs are pushed and popped together: misaligned or a bus fault)")

    def _idle_fault(self, problem: str) -> None:
        """S1, no gesture, no pair: clear the FIFOs (FIFO-CLR also realigns them); warn
        when the fault appears, then at most once per ``heartbeat`` while it lasts."""
        now = self._clock()
        first = self._idle_fault_at is None
        if first or (self.heartbeat is not None
                     and now - self._idle_fault_at >= self.heartbeat):
            if first:
                self.faults += 1
            self._idle_fault_at = now
            log.warning("S1: %s; FIFOs cleared%s", problem,
                        "" if first else " (the fault persists)")
        self.fifo.clear(keep_running=True)
        self._pause(self.poll_interval)

    def _read(self) -> None:  # S2
        status = self._status()
        # A gesture lasts seconds; the heartbeat only shows if this one does not end.
        self._beat(f"reading a gesture (S2), {self.classifier.num_points} points so far")
        self._consume(status)

    def _consume(self, status: FifoStatus) -> None:
        if status.full:
            self._drop("FIFO-FULL set (the FIFO overflowed)")
            return
        status, problem = self._check_lengths(status)
        if problem is not None:
            self._drop(problem)
            return
        count = min(status.pairs_available, self.max_pairs_per_poll)
        if status.data and count == 0:
            count = 1  # FIFO data says there is a pair even if the lengths read 0
        if count:
            self._last_pair_at = self._clock()
            self._take([self.fifo.pop_words() for _ in range(count)])
            return
        if not status.gesture_active:
            self.state = State.CLASSIFY
            return
        quiet = self._clock() - self._last_pair_at
        if quiet > self.gesture_timeout:
            self._drop(f"gesture bit stuck at 0 (gesture in progress) but no pair for "
                       f"{quiet:.1f} s (gesture_timeout={self.gesture_timeout:g} s)", stuck=True)
            return
        self._pause(self.poll_interval)

    def _take(self, words) -> None:
        """Feed the popped ``(Dato_X, Dato_Y)`` words inside the frame to the
        classifier; drop the others (module docstring, Faults)."""
        good = []
        for x, y in words:
            problem = self._point_problem(x, y)
            if problem is None:
                good.append((x, y))
                continue
            self.faults += 1
            self.bad_points += 1
            self._gesture_bad_points += 1
            log.warning("S2: point dropped: %s (%d in this gesture, max_bad_points=%d)",
                        problem, self._gesture_bad_points, self.max_bad_points)
            if self._gesture_bad_points > self.max_bad_points:
                break
        self.classifier.add_points(np.array(good, dtype=np.int64).reshape(-1, 2))
        if self._gesture_bad_points > self.max_bad_points:
            self._drop(f"{self._gesture_bad_points} points outside the frame (more than "
                       f"max_bad_points={self.max_bad_points})")
        elif self.classifier.num_points > self.max_points:
            self._drop(f"gesture longer than max_points={self.max_points}")

    def _point_problem(self, x: int, y: int) -> str | None:
        """Why a popped pair is not a point of the frame, or None."""
        if x > DATA_MASK or y > DATA_MASK:
            return (f"Dato_X={x:#010x}, Dato_Y={y:#010x} have bits above the {DATA_BITS} "
                    f"data bits set (allowed 0..{DATA_MASK:#x})")
        if x >= self.frame_width << FRAC_BITS or y >= self.frame_height << FRAC_BITS:
            return (f"(x, y) = ({from_fixed(x):.2f}, {from_fixed(y):.2f}) px lies outside the "
                    f"frame (x in [0, {self.frame_width}), y in [0, {self.frame_height}))")
        return None

    def _drop(self, reason: str, *, stuck: bool = False) -> None:
        self.faults += 1
        log.warning("gesture dropped: %s", reason)
        self._pending = GestureResult("dropped", num_points=self.classifier.num_points,
                                      num_symbols=self.classifier.num_symbols, reason=reason)
        self._start_discarding(stuck=stuck)
        self.state = State.CLEAR

    def _classify(self) -> None:  # S3
        index, reason = self.classifier.decide()
        scores = tuple(float(s) for s in self.classifier.scores())
        common = dict(scores=scores, num_points=self.classifier.num_points,
                      num_symbols=self.classifier.num_symbols,
                      symbols=tuple(self.classifier.symbols))
        verdict = None
        if self.posture is not None:
            common["posture"], common["posture_share"] = self.posture.held(
                self._posture_first, self.posture.reader.frame)
            if self.commands is not None and index >= 0:
                first, last = self._posture_first, self.posture.reader.frame
                verdict = self.commands.judge_names(self.posture.read_names(first, last))
                common["posture"], common["posture_share"] = verdict.posture, verdict.share
                if not verdict.commands:
                    index, reason = -1, (
                        "the stop posture is held" if self.commands.latched else
                        f"not made in a command posture ({100 * verdict.share:.0f} % of its "
                        f"frames in one, {100 * self.commands.options['share']:.0f} % needed)")
        if index < 0:
            log.info("S3: gesture rejected: %s", reason)
            self._pending = GestureResult("rejected", reason=reason, **common)
            self.state = State.CLEAR
            return
        name = self.models.class_names[index]
        log.info("S3: recognised %r (class %d, log-likelihood %.2f, %d symbols%s)", name, index,
                 scores[index], self.classifier.num_symbols,
                 "" if self.posture is None else f", posture {common['posture']}")
        self._pending = GestureResult("recognised", class_index=index, class_name=name,
                                      power=None if verdict is None else verdict.power, **common)
        self.state = State.SEND

    def _send(self) -> None:  # S4
        result = self._pending
        self.state = State.CLEAR
        command = self.models.command_of(result.class_name)
        if command is None:
            log.warning("S4: class %r maps to none of the robot's commands %s; nothing sent",
                        result.class_name, list(GESTURE_NAMES))
            return
        delivery = deliver_gesture(self.link, command, result.power)  # never raises
        log.log(logging.WARNING if delivery.status == FAILED else logging.INFO,
                "S4: telegram %s for %r%s %s", hex_bytes(delivery.telegram), result.class_name,
                "" if command == result.class_name else f" ({command})", delivery.describe())
        self._pending = dataclasses.replace(result, telegram=delivery.telegram,
                                            sent=delivery.written, delivery=delivery.status)

    def _clear(self) -> None:  # S5
        result, self._pending = self._pending, None
        self.classifier.reset()
        self.state = State.WAIT
        if result is not None:
            self._finish(result)
        self.fifo.clear(keep_running=True)

    def _finish(self, result: GestureResult) -> None:
        self.outcomes[result.outcome] = self.outcomes.get(result.outcome, 0) + 1
        self.results.append(result)
        if self._run_results is not None:
            self._run_results.append(result)
        if self.on_result is not None:
            try:
                self.on_result(result)
            except Exception as exc:
                log.error("on_result hook raised %s: %s", type(exc).__name__, exc)
