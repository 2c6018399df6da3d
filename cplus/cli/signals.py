"""SIGINT and SIGTERM for the commands that move robots: stop within 2 s, whatever runs.

A command that drives bricks (``cplus online``, ``cplus execute``, ``cplus run``) must not die
with its motors turning and its log cut short, nor hang on a link that stopped answering when
the operator wants it to end. :class:`Shutdown` gives them one behaviour:

* **the first signal** is an orderly stop. The ``on_stop`` callbacks run at once (thread-safe
  requests such as :meth:`OnlineLoop.stop`), then :class:`Stopped`, a ``KeyboardInterrupt``,
  is raised in the main thread. So a wait on a link, a sleep or a select unwinds through the
  paths Ctrl-C already takes: the bricks are told to stop (ABORT, the streaming STOP), the log
  gets its end record, and the command exits with ``128 + signal`` (130 for SIGINT, 143 for
  SIGTERM) after one line on stderr;
* **a watchdog** starts with the first signal. If the orderly stop has not finished after
  ``grace_s`` (1.5 s, or the seconds in ``CPLUS_STOP_GRACE``: a slow controller PC, or a test
  that checks the orderly path on a loaded machine, may give it longer), because the main thread is stuck somewhere (a link retrying, a slow
  write), it runs the ``on_force`` callbacks itself (each in its own thread, bounded: motors
  off by direct commands that need no reply, the log's end record), says so on stderr and ends
  the process with the same code, within 2 s of the signal;
* **a second signal** ends the process at once: the ``on_force`` callbacks get 0.3 s, then
  the exit code is :data:`EXIT_FORCED` (124).

What no Python code can cut short is a single call into C that holds the interpreter lock:
a SAT solve. SIGINT interrupts it (pysat installs its own handler for the solve); SIGTERM is
handled when the solve returns (milliseconds on the shipped domains).

API (for ``cplus serve`` to adopt as well)::

    with Shutdown("cplus online") as shutdown:
        shutdown.on_stop(loop.stop)                 # thread-safe, quick
        shutdown.on_force(lambda: motors_off(bricks))  # from the watchdog thread; bounded
        try:
            result = loop.run()
        except KeyboardInterrupt as exc:
            print(f"cplus online: {reason_of(exc)}")
            return exit_code_of(exc)

``Shutdown`` is re-entrant (``cplus run`` calls ``cplus execute`` inside its own: the inner one
shares the outer's handling and reports its signal), does nothing outside the main thread, and
puts the previous handlers back on exit.
"""
from __future__ import annotations

import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Mapping
from types import FrameType
from typing import TextIO

__all__ = ["EXIT_FORCED", "GRACE_ENV", "GRACE_S", "Shutdown", "Stopped", "exit_code_of",
           "motors_off", "reason_of", "stop_grace"]

EXIT_FORCED = 124
"""A second SIGINT/SIGTERM ended the command at once (motors commanded off, best effort)."""

GRACE_S = 1.5
"""How long the orderly stop may take before the watchdog takes over (the whole stop stays
within 2 s: the forced callbacks get the rest), unless ``CPLUS_STOP_GRACE`` says otherwise."""

GRACE_ENV = "CPLUS_STOP_GRACE"
"""The environment variable that replaces :data:`GRACE_S` (seconds, more than 0, at most
:data:`MAX_GRACE_S`)."""

MAX_GRACE_S = 600.0

_FORCE_BUDGET_S = 0.4
_SECOND_BUDGET_S = 0.3
_NAMES: dict[int, str] = {int(signal.SIGINT): "SIGINT", int(signal.SIGTERM): "SIGTERM"}


class Stopped(KeyboardInterrupt):
    """Raised in the main thread by the first SIGINT or SIGTERM; ``str()`` is the reason for a
    log (``stopped by SIGTERM``) and ``code`` the exit code (``128 + signal``)."""

    def __init__(self, signum: int) -> None:
        name = _NAMES.get(signum, f"signal {signum}")
        super().__init__("interrupted (SIGINT)" if signum == signal.SIGINT else f"stopped by {name}")
        self.signum = signum
        self.code = 128 + signum


def stop_grace(prog: str, environ: Mapping[str, str] | None = None, default: float = GRACE_S) -> float:
    """The orderly stop's time limit: ``default`` (:data:`GRACE_S`; ``cplus serve`` has its
    own), or ``CPLUS_STOP_GRACE`` when it is set. A value that is not a number of seconds in
    (0, 600] is refused with one line naming the variable (a
    :class:`~cplus.cli.common.CliError`), never silently replaced."""
    text = (os.environ if environ is None else environ).get(GRACE_ENV, "").strip()
    if not text:
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value <= MAX_GRACE_S:
        from cplus.cli.common import CliError
        raise CliError(f"{prog}: error: {GRACE_ENV} must be a number of seconds > 0 and at most "
                       f"{MAX_GRACE_S:g}, got {text!r}")
    return value


def exit_code_of(exc: BaseException) -> int:
    """The exit code of a ``KeyboardInterrupt``: ``128 + signal`` for :class:`Stopped`, 130
    for a plain one (Ctrl-C caught inside the SAT solver)."""
    return exc.code if isinstance(exc, Stopped) else 130


def reason_of(exc: BaseException) -> str:
    return str(exc) if isinstance(exc, Stopped) else "interrupted"


class Shutdown:
    """Signal handling for one command that moves robots (see the module docstring)."""

    _active: Shutdown | None = None

    def __init__(self, prog: str, *, grace_s: float | None = None, err: TextIO | None = None) -> None:
        self.prog = prog
        self.grace_s = stop_grace(prog) if grace_s is None else grace_s
        self.err = err
        self._signum: int | None = None
        self._stop: list[Callable[[], None]] = []
        self._force: list[Callable[[], None]] = []
        self._done = threading.Event()
        self._previous: dict[int, object] = {}
        self._outer: Shutdown | None = None
        self._installed = False

    # -- registration ------------------------------------------------------------------------
    def on_stop(self, callback: Callable[[], None]) -> None:
        """Run ``callback`` at the first signal, in the handler, before :class:`Stopped` is
        raised (it must be quick and thread-safe)."""
        (self._outer or self)._stop.append(callback)

    def on_force(self, callback: Callable[[], None]) -> None:
        """Run ``callback`` when the orderly stop misses its deadline or at a second signal,
        from another thread, with a time bound: stop the motors, finish the logs."""
        (self._outer or self)._force.append(callback)

    @property
    def signum(self) -> int | None:
        """The first signal received, None before one; a nested ``Shutdown`` answers for the
        command it runs in (``cplus execute`` inside ``cplus run`` must know that ``cplus run``
        was stopped: no plot, and ``128 + signal`` for its exit code)."""
        return (self._outer or self)._signum

    @property
    def exit_code(self) -> int:
        return 130 if self.signum is None else 128 + self.signum

    # -- context -----------------------------------------------------------------------------
    def __enter__(self) -> Shutdown:
        if Shutdown._active is not None:          # nested: share the outer command's handling
            self._outer = Shutdown._active
            return self
        if threading.current_thread() is not threading.main_thread():
            return self
        for s in (signal.SIGINT, signal.SIGTERM):
            self._previous[s] = signal.signal(s, self._handle)
        self._installed = True
        Shutdown._active = self
        return self

    def __exit__(self, *exc: object) -> None:
        if self._outer is not None:
            return
        self._done.set()
        if self._installed:
            for s, handler in self._previous.items():
                signal.signal(s, handler)  # type: ignore[arg-type]
            Shutdown._active = None

    # -- what a signal does ------------------------------------------------------------------
    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is not None:               # the second one: at once
            self._say(f"{_NAMES.get(signum, str(signum))} again: stopping the motors and ending now")
            self._run_force(_SECOND_BUDGET_S)
            self._exit(EXIT_FORCED)
        self._signum = signum
        threading.Thread(target=self._watchdog, name="cplus-shutdown-watchdog", daemon=True).start()
        for callback in self._stop:
            try:
                callback()
            except Exception:  # noqa: BLE001 - a failing request must not prevent the stop
                pass
        raise Stopped(signum)

    def _watchdog(self) -> None:
        if self._done.wait(self.grace_s):
            return
        self._say(f"the orderly stop took more than {self.grace_s:g} s: stopping the motors and ending now")
        self._run_force(_FORCE_BUDGET_S)
        if not self._done.is_set():
            self._exit(self.exit_code)

    def _run_force(self, budget_s: float) -> None:
        """Every force callback in its own daemon thread, all of them within ``budget_s``."""
        threads = [threading.Thread(target=_quietly, args=(cb,), daemon=True) for cb in self._force]
        for t in threads:
            t.start()
        deadline = _now() + budget_s
        for t in threads:
            t.join(max(0.0, deadline - _now()))

    def _say(self, text: str) -> None:
        try:
            print(f"{self.prog}: {text}", file=self.err or sys.stderr, flush=True)
        except (OSError, ValueError):
            pass

    @staticmethod
    def _exit(code: int) -> None:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)


def motors_off(bricks: Iterable[object]) -> None:
    """Stop every brick's program and coast its three motors, with direct commands that need
    no reply, written straight to each brick's transport: the interrupted thread may hold the
    brick's request lock, or be waiting for a reply that never comes. Errors are ignored (a
    link that is down has nothing to stop)."""
    from nxt_link.wire import telegram as tg
    commands = [tg.encode_command(tg.StopProgram(reply=False))] + [
        tg.encode_command(tg.SetOutputState(port, 0, 0, 0, 0, 0, 0, False)) for port in range(3)]
    for brick in bricks:
        transport = getattr(brick, "transport", None)
        for data in commands:
            try:
                transport.send(data)  # type: ignore[union-attr]
            except Exception:  # noqa: BLE001 - best effort, brick by brick
                break


def _quietly(callback: Callable[[], None]) -> None:
    try:
        callback()
    except Exception:  # noqa: BLE001 - the process is ending; the other callbacks still run
        pass


def _now() -> float:
    import time
    return time.monotonic()
