"""Supervision of the board application against bus errors the CPU raises as
signals (issue 30).

Runs on the board's ARM: Python 3.7 and the standard library, nothing else.

A load or store on the lightweight HPS-to-FPGA bridge that nothing answers
(the bridge disabled or held in reset, no FPGA image, no slave decoding the
address) ends in a bus error the kernel delivers as a synchronous SIGBUS
(SIGSEGV for some mappings). Python cannot return to the faulting instruction,
so the process dies there without a line in the log. :func:`supervise`
therefore runs the application in a forked child process and stays in the
parent, which touches neither the bridge nor the robot:

* the child's exit status is passed through (0 after SIGINT/SIGTERM, 1 after a
  fatal error, as :mod:`sw_hps.__main__` returns them);
* when the child dies of SIGBUS or SIGSEGV, the parent logs exactly one error
  line naming the device and the address window, the likely cause
  (:data:`sw_hps.busfault.LIKELY_CAUSE`) and ``python3 -m sw_hps --check``,
  then exits with status 1 (systemd's ``Restart=on-failure`` retries), or, if
  ``fault_retries`` allows, starts a new child after a back-off (doubling from
  :data:`RETRY_INITIAL` up to :data:`RETRY_MAX` seconds; a child that ran for
  :data:`HEALTHY_RUN` seconds resets the count);
* SIGINT and SIGTERM are forwarded to the child (which stops cleanly); a child
  that has not ended :data:`STOP_TIMEOUT` seconds later is killed;
* SIGHUP reloads: the parent calls ``reload()`` (:mod:`sw_hps.__main__` loads
  and checks the model file as at start); if it raises, one error line says why
  and the running child goes on; otherwise the child is stopped (SIGTERM) and a
  new one started with what ``reload()`` returned. The child ignores SIGHUP.

The parent waits with :func:`signal.sigwaitinfo` on the blocked signals, so it
sleeps until something happens and never polls.
"""
from __future__ import annotations

import logging
import os
import signal
import sys
import time
from typing import Callable

from .busfault import CHECK_HINT, LIKELY_CAUSE

__all__ = ["supervise", "FAULT_SIGNALS", "STOP_TIMEOUT", "RETRY_INITIAL", "RETRY_MAX",
           "HEALTHY_RUN", "MAX_FAULT_RETRIES"]

log = logging.getLogger(__name__)

#: Signals by which a bus error on the mapped bridge kills the process.
FAULT_SIGNALS = (signal.SIGBUS, signal.SIGSEGV)
#: Seconds a child gets to stop after SIGTERM before it is killed.
STOP_TIMEOUT = 10.0
#: First and longest wait before a new child after a fault, seconds.
RETRY_INITIAL, RETRY_MAX = 1.0, 60.0
#: A child that ran this many seconds before its fault resets the retry count.
HEALTHY_RUN = 60.0
#: Most fault retries ``--fault-retries`` accepts.
MAX_FAULT_RETRIES = 1000

_WATCHED = (signal.SIGCHLD, signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def _name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def _restore(previous: dict) -> None:
    for signum, handler in previous.items():
        if handler is not None:          # None: not installed from Python, left alone
            signal.signal(signum, handler)


def _ignore(signum, frame):
    """Installed while the parent waits: the blocked signals stay pending for
    sigwaitinfo and never reach a default action."""


class _Child:
    """One forked run of the application."""

    def __init__(self, serve: Callable[[object], int], payload, previous: dict, mask):
        sys.stdout.flush()
        sys.stderr.flush()
        self.started = time.monotonic()
        pid = os.fork()
        if pid == 0:                     # the child: never returns
            status = 1
            try:
                _restore(previous)
                signal.signal(signal.SIGHUP, signal.SIG_IGN)   # reloads are the parent's
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)
                status = serve(payload)
            except KeyboardInterrupt:    # a SIGINT before the application's handler
                status = 0
            except SystemExit as exc:
                status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None
                                                                     else 1)
            except BaseException as exc:  # one line, as main() gives, never a traceback
                log.error("fatal: %s: %s", type(exc).__name__, exc)
            finally:
                try:
                    logging.shutdown()
                    sys.stdout.flush()
                    sys.stderr.flush()
                finally:
                    os._exit(status if isinstance(status, int) and 0 <= status <= 255 else 1)
        self.pid = pid
        log.info("application started (process %d)", pid)

    def signal(self, signum: int) -> None:
        try:
            os.kill(self.pid, signum)
        except ProcessLookupError:
            pass                         # it has ended; SIGCHLD tells


def supervise(serve: Callable[[object], int], *, where: str,
              reload: Callable[[], object] | None = None, fault_retries: int = 0) -> int:
    """Run ``serve(payload)`` in a forked child and watch it (module docstring).

    Parameters
    ----------
    serve : callable
        The application: ``serve(payload) -> exit status``; ``payload`` is None
        for the first child and then what the last successful ``reload()``
        returned. Runs in the child only.
    where : str
        The bus and its address window, for the fault line
        (:func:`sw_hps.busfault.describe_bus`).
    reload : callable, optional
        Called in the parent on SIGHUP; raises (one-line message) if the new
        configuration is refused. None: SIGHUP only logs that it is ignored.
    fault_retries : int in [0, MAX_FAULT_RETRIES]
        New children started after faults in a row before giving up.

    Returns
    -------
    int
        The exit status for the parent: the child's own, 1 after a fault (or a
        child killed by another signal), 0 after a stop request.
    """
    if isinstance(fault_retries, bool) or not isinstance(fault_retries, int) \
            or not 0 <= fault_retries <= MAX_FAULT_RETRIES:
        raise ValueError(f"fault_retries must be an int in [0, {MAX_FAULT_RETRIES}], "
                         f"got {fault_retries!r}")
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, _WATCHED)
    previous = {signum: signal.signal(signum, _ignore) for signum in _WATCHED}
    try:
        return _Supervisor(serve, where, reload, fault_retries, previous, mask).run()
    finally:
        _restore(previous)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


class _Supervisor:
    def __init__(self, serve, where, reload, fault_retries, previous, mask):
        self.serve, self.where, self.reload = serve, where, reload
        self.fault_retries = fault_retries
        self.previous, self.mask = previous, mask
        self.payload = None
        self.retries = 0                 # faults in a row so far
        self.stopping = False            # SIGINT/SIGTERM forwarded: do not restart
        self.restart = False             # SIGHUP accepted: start a new child once this ends
        self.deadline = None             # monotonic time by which the child must have ended

    def _start(self) -> _Child:
        return _Child(self.serve, self.payload, self.previous, self.mask)

    def _wait(self, timeout=None):
        """The next watched signal's number, or None once ``timeout`` passed."""
        if timeout is None:
            return signal.sigwaitinfo(_WATCHED).si_signo
        info = signal.sigtimedwait(_WATCHED, max(0.0, timeout))
        return None if info is None else info.si_signo

    def _stop_child(self, child: _Child, signum: int) -> None:
        child.signal(signum)
        if self.deadline is None:
            self.deadline = time.monotonic() + STOP_TIMEOUT

    def _reload(self) -> bool:
        """SIGHUP: True if the new configuration was accepted."""
        if self.reload is None:
            log.warning("SIGHUP: nothing to reload")
            return False
        try:
            payload = self.reload()
        except Exception as exc:     # the reload's one-line message
            log.error("SIGHUP: not reloaded, the running application keeps its model: %s",
                      exc)
            return False
        self.payload = payload
        return True

    def run(self) -> int:
        child = self._start()
        while True:
            timeout = None if self.deadline is None else self.deadline - time.monotonic()
            signum = self._wait(timeout)
            if signum is None:           # the child ignored SIGTERM for STOP_TIMEOUT
                log.error("application process %d did not stop within %g s; killing it",
                          child.pid, STOP_TIMEOUT)
                child.signal(signal.SIGKILL)
                self.deadline = None
            elif signum in (signal.SIGINT, signal.SIGTERM):
                self.stopping, self.restart = True, False
                self._stop_child(child, signum)
            elif signum == signal.SIGHUP:
                if not self.stopping and not self.restart and self._reload():
                    log.info("SIGHUP: model file checked; restarting the application")
                    self.restart = True
                    self._stop_child(child, signal.SIGTERM)
            else:                        # SIGCHLD
                pid, status = os.waitpid(child.pid, os.WNOHANG)
                if pid == 0:
                    continue
                self.deadline = None
                outcome = self._ended(child, status)
                if outcome is not None:
                    return outcome
                child = self._start()

    def _ended(self, child: _Child, status: int):
        """The child ended: the parent's exit status, or None to start a new child."""
        ran = time.monotonic() - child.started
        if os.WIFSIGNALED(status) and os.WTERMSIG(status) in FAULT_SIGNALS:
            return self._fault(child, os.WTERMSIG(status), ran)
        if self.restart and not self.stopping:
            self.restart = False
            return None
        if os.WIFSIGNALED(status):
            signum = os.WTERMSIG(status)
            if self.stopping and signum in (signal.SIGINT, signal.SIGTERM):
                return 0                 # stopped before it installed its handlers
            log.error("application process %d was killed by %s", child.pid, _name(signum))
            return 1
        return os.WEXITSTATUS(status) if os.WIFEXITED(status) else 1

    def _fault(self, child: _Child, signum: int, ran: float):
        if ran >= HEALTHY_RUN:
            self.retries = 0
        retry = not self.stopping and self.retries < self.fault_retries
        delay = min(RETRY_INITIAL * 2 ** self.retries, RETRY_MAX)
        then = (f"starting it again in {delay:g} s (fault retry {self.retries + 1} of "
                f"{self.fault_retries})" if retry else "exiting with status 1")
        log.error("application process %d died of %s after %.1f s: a bus error on %s; "
                  "likely %s; %s; %s", child.pid, _name(signum), ran, self.where,
                  LIKELY_CAUSE, CHECK_HINT, then)
        if not retry:
            return 1
        self.retries += 1
        self.restart = False
        end = time.monotonic() + delay
        while True:                      # the back-off, still answering signals
            signum = self._wait(end - time.monotonic())
            if signum is None:
                return None
            if signum in (signal.SIGINT, signal.SIGTERM):
                return 0
            if signum == signal.SIGHUP and self._reload():
                log.info("SIGHUP: model file checked; the next start uses it")
