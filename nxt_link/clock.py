"""Clocks and deadlines: every wait in `nxt_link` goes through one of these.

Library code never calls ``time.time()``; it takes a :class:`Clock` (default
:data:`MONOTONIC`). Tests pass a :class:`VirtualClock`, so a 10-second
trajectory run against the in-memory emulator takes milliseconds and never
depends on the machine's load.

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
from typing import Protocol

__all__ = ["Clock", "MonotonicClock", "VirtualClock", "Deadline", "MONOTONIC"]


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
