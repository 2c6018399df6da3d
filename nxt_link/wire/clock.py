"""Clocks and deadlines: every wait in `nxt_link` goes through one of these.

Library code never calls ``time.time()``; it takes a :class:`Clock` (default
:data:`MONOTONIC`). Tests pass a :class:`VirtualClock`, so a 10-second
trajectory run against the in-memory emulator takes milliseconds and never
depends on the machine's load. Bricks emulated in threads of the same process
behind real pseudo-terminals run on a :class:`SimClock`: simulated time that
moves only when every thread taking part waits on it (see its docstring), so
a run's outcome depends neither on the machine's load nor on its speed.

This module is the face for every clock: the simulated one lives in
:mod:`nxt_link.wire.simclock` (its calls) and :mod:`nxt_link.wire.sim_scheduler` (its baton),
and is imported from here like the rest.

>>> clock = VirtualClock()
>>> d = Deadline(clock, 0.5)
>>> clock.sleep(0.2); round(d.remaining(), 3)
0.3
>>> clock.sleep(0.4); d.expired()
True
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from nxt_link.wire.sim_scheduler import READABLE as READABLE
from nxt_link.wire.sim_scheduler import STOPPED as STOPPED
from nxt_link.wire.sim_scheduler import TIME as TIME
from nxt_link.wire.sim_scheduler import WOKEN as WOKEN
from nxt_link.wire.sim_scheduler import Channel, Pipe, SimulationStalled, _SimLock
from nxt_link.wire.simclock import SimClock, clock_of_device

__all__ = ["Clock", "MonotonicClock", "VirtualClock", "Deadline", "MONOTONIC", "SimClock",
           "SimulationStalled", "Pipe", "Channel", "start_thread", "join_threads", "new_lock",
           "clock_of_device"]

class Clock(Protocol):
    """A source of monotonic seconds that can also wait."""

    def now(self) -> float: ...

    def sleep(self, seconds: float) -> None: ...


class MonotonicClock:
    """The real clock: ``time.monotonic`` and ``time.sleep``."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


MONOTONIC = MonotonicClock()


class VirtualClock:
    """A clock that only moves when someone sleeps or advances it (thread-safe)."""

    def __init__(self, start: float = 0.0) -> None:
        self._now = start
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._now

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            with self._lock:
                self._now += seconds

    def advance_to(self, t: float) -> None:
        """Move forward to ``t`` (never backwards)."""
        with self._lock:
            if t > self._now:
                self._now = t


class Deadline:
    """A point in time on a given clock; ``timeout_s=None`` never expires.

    ``remaining()`` is 0 (poll) once expired, ``None`` for no deadline.
    """

    def __init__(self, clock: Clock, timeout_s: float | None) -> None:
        self.clock = clock
        self.timeout_s = timeout_s
        self.at = None if timeout_s is None else clock.now() + max(0.0, timeout_s)

    def remaining(self) -> float | None:
        if self.at is None:
            return None
        return max(0.0, self.at - self.clock.now())

    def expired(self) -> bool:
        return self.at is not None and self.clock.now() >= self.at


def new_lock(clock: Clock) -> Any:
    """A mutex for code that may run on a :class:`SimClock` (waits on it there)."""
    return _SimLock(clock) if isinstance(clock, SimClock) else threading.Lock()


def start_thread(clock: Clock, name: str, target: Callable[..., None], args: Sequence[Any] = ()
                 ) -> threading.Thread:
    """A daemon thread running ``target(*args)``, a participant of ``clock`` if it is a
    :class:`SimClock` (registered before it starts, so no time passes before it runs)."""
    if not isinstance(clock, SimClock):
        t = threading.Thread(target=target, args=tuple(args), name=name, daemon=True)
        t.start()
        return t
    p = clock.register(name)

    def body() -> None:
        clock.attach(p)
        try:
            target(*args)
        finally:
            clock.unregister(p)
    t = threading.Thread(target=body, name=name, daemon=True)
    t._sim_participant = p  # type: ignore[attr-defined]
    t.start()
    return t


def join_threads(clock: Clock, threads: Sequence[threading.Thread]) -> None:
    """Wait for threads made by :func:`start_thread` (on a :class:`SimClock`, through it)."""
    if isinstance(clock, SimClock) and clock.is_participant():
        ps = [getattr(t, "_sim_participant", None) for t in threads]
        clock.join([p for p in ps if p is not None])
    for t in threads:
        t.join()
