"""The baton under :class:`nxt_link.wire.simclock.SimClock`: who waits for what, who runs next,
and when simulated time jumps.

A participant is one thread taking part (:class:`_Participant`); :class:`_Scheduler` holds
their states and passes the baton among them under the clock's one lock.  Kept apart from the
clock's public calls (:mod:`nxt_link.wire.simclock`) because this is the part that decides a
run's order of events, read on its own; both are given by :mod:`nxt_link.wire.clock`.
"""
from __future__ import annotations

import itertools
import logging
import threading
import time
from collections import deque

log = logging.getLogger("nxt_link.wire.clock")   # the name it had when this was part of clock.py


class SimulationStalled(RuntimeError):
    """The simulated clock could not move for ``SimClock.stall_timeout_s`` of real time.

    Raised in every participant that waits on the clock from then on: a thread that kept
    the clock from moving (blocked on something the clock does not know, or crashed) would
    otherwise freeze the run for ever."""


class Pipe:
    """One direction of a :class:`Channel`: bytes written by one participant and not yet
    read by the other (``pending``), counted in-process because a pty delivers them a little
    later than the write returns (the kernel's flip buffer), and time must not pass while
    they are on their way to a reader that waits for them."""

    __slots__ = ("name", "pending", "closed")

    def __init__(self, name: str) -> None:
        self.name = name
        self.pending = 0
        self.closed = False

    def __repr__(self) -> str:
        return f"Pipe({self.name!r}, pending={self.pending}, closed={self.closed})"


class Channel:
    """A pseudo-terminal between an emulated brick and the PC, as the clock sees it:
    ``to_brick`` (the PC writes the slave, the brick's server reads the master) and
    ``to_pc``. ``key`` is the slave's device path, which both ends know."""

    __slots__ = ("key", "to_brick", "to_pc")

    def __init__(self, key: str) -> None:
        self.key = key
        self.to_brick = Pipe(f"{key} to brick")
        self.to_pc = Pipe(f"{key} to PC")

    @property
    def closed(self) -> bool:
        return self.to_pc.closed


# the reasons a wait ends
TIME = "time"            # its deadline came
READABLE = "readable"    # bytes are on their way to it (or the channel closed)
STOPPED = "stopped"      # its participant was detached (its owner stops it)
WOKEN = "woken"          # what it waited for (a thread ended, a lock) happened

_RUNNING, _READY, _PARKED, _DETACHED = "running", "ready", "parked", "detached"


class _Participant:
    __slots__ = ("name", "seq", "ident", "thread", "cond", "state", "wake_at", "pipe", "joining",
                 "lock", "reason", "depth", "temporary")

    def __init__(self, name: str, seq: int, cond: threading.Condition) -> None:
        self.name = name
        self.seq = seq
        self.ident: int | None = None
        self.thread: threading.Thread | None = None
        self.cond = cond
        self.state = _READY
        self.wake_at: float | None = None
        self.pipe: Pipe | None = None
        self.joining: frozenset[_Participant] = frozenset()
        self.lock: _SimLock | None = None
        self.reason = WOKEN
        self.depth = 0
        self.temporary = False

    def what(self) -> str:
        if self.state != _PARKED:
            return f"{self.name} {self.state}"
        parts = []
        if self.pipe is not None:
            parts.append(f"bytes on {self.pipe.name}")
        if self.joining:
            parts.append("the end of " + ", ".join(p.name for p in self.joining))
        if self.lock is not None:
            parts.append("a lock")
        if self.wake_at is not None:
            parts.append(f"t={self.wake_at:.3f} s")
        return f"{self.name} waits for " + (" or ".join(parts) or "nothing")


class _Scheduler:
    """The state of a :class:`~nxt_link.wire.simclock.SimClock` and the baton passing at its
    heart; the methods here are called with the clock's lock held (except :meth:`_wait`, which
    takes it).  :class:`~nxt_link.wire.simclock.SimClock` adds the calls its participants make."""

    def __init__(self, start: float = 0.0, *, stall_timeout_s: float = 120.0) -> None:
        self._now = start
        self._lock = threading.Lock()
        self._seq = itertools.count()
        self._participants: dict[int, _Participant] = {}     # by thread ident
        self._all: dict[int, _Participant] = {}              # by seq
        self._running: set[_Participant] = set()
        self._ready: deque[_Participant] = deque()
        self._channels: dict[str, Channel] = {}
        self._failed: str | None = None
        self._progress = time.monotonic()
        self.stall_timeout_s = stall_timeout_s
        self.switches = 0          # baton passes (for the benchmarks)


    # -- the scheduler (the lock is held) ---------------------------------------------------------

    def _wake_readers(self, pipe: Pipe) -> None:
        for p in self._all.values():
            if p.state == _PARKED and p.pipe is pipe:
                self._make_ready(p, READABLE)

    def _release_joiners(self, gone: _Participant) -> None:
        for p in self._all.values():
            if p.state == _PARKED and gone in p.joining:
                if all(t.state == _DETACHED or t.seq not in self._all for t in p.joining):
                    self._make_ready(p, WOKEN)

    def _make_ready(self, p: _Participant, reason: str) -> None:
        p.state = _READY
        p.reason = reason
        self._ready.append(p)

    def _drop(self, p: _Participant) -> None:
        self._running.discard(p)
        if p in self._ready:
            self._ready.remove(p)
        self._all.pop(p.seq, None)
        if p.ident is not None and self._participants.get(p.ident) is p:
            del self._participants[p.ident]
        p.state = _DETACHED
        self._release_joiners(p)
        self._progress = time.monotonic()

    def _dispatch(self) -> None:
        """Give the baton to the next participant if nobody holds it; advance time when
        nobody can go on."""
        if self._running:
            return
        while True:
            if self._ready:
                p = self._ready.popleft()
                p.state = _RUNNING
                self._running.add(p)
                self.switches += 1
                self._progress = time.monotonic()
                p.cond.notify()
                return
            due = [(p.wake_at, p.seq, p) for p in self._all.values()
                   if p.state == _PARKED and p.wake_at is not None]
            if not due:
                return   # idle: every participant waits for bytes, a thread or a lock
            t = min(at for at, _, _ in due)
            if t > self._now:
                self._now = t
            for at, _, p in sorted(due, key=lambda d: d[1]):
                if at <= self._now:
                    self._make_ready(p, TIME)

    def _await_baton(self, p: _Participant) -> None:
        """Block until ``p`` runs (lock held on entry and exit)."""
        try:
            while p.state in (_READY, _PARKED):
                if self._failed is not None:
                    raise SimulationStalled(self._failed)
                p.cond.wait(timeout=1.0)
                if p.state in (_READY, _PARKED):
                    self._watch()
        except BaseException:
            # Ctrl-C or a stall: go on (and unwind) as a running participant
            if p.state in (_READY, _PARKED):
                if p in self._ready:
                    self._ready.remove(p)
                p.state = _RUNNING
                self._running.add(p)
            raise

    def _watch(self) -> None:
        """The safety net, every second of real time a participant waits."""
        for q in list(self._running):
            if q.thread is not None and not q.thread.is_alive():
                log.warning("simulated clock: participant %s ended without unregistering", q.name)
                self._drop(q)
                self._dispatch()
        if self._failed is None and time.monotonic() - self._progress > self.stall_timeout_s:
            states = "; ".join(p.what() for p in sorted(self._all.values(), key=lambda q: q.seq))
            if self._running:
                why = ", ".join(q.name for q in self._running) + " kept running without waiting on it"
            elif any(p.state == _PARKED and (p.joining or p.lock is not None) for p in self._all.values()):
                why = "every participant waits for another one"
            else:
                # idle, not stuck: the bricks wait for bytes from a PC that is not a participant
                self._progress = time.monotonic()
                return
            self._failed = (f"simulated time stood still for {self.stall_timeout_s:g} s of real time: "
                            f"{why} ({states})")
            log.error("%s", self._failed)
            for q in self._all.values():
                q.cond.notify()
        if self._failed is not None:
            raise SimulationStalled(self._failed)

    def _check_failed(self) -> None:
        if self._failed is not None:
            raise SimulationStalled(self._failed)

    def _wait(self, *, wake_at: float | None = None, pipe: Pipe | None = None,
              joining: frozenset[_Participant] = frozenset(), lock: _SimLock | None = None) -> str:
        with self._lock:
            if self._failed is not None:
                raise SimulationStalled(self._failed)
            p = self._participants.get(threading.get_ident())
            if p is not None and p.state == _DETACHED:
                return STOPPED
            # nothing to wait for: keep the baton
            if pipe is not None and (pipe.pending > 0 or pipe.closed):
                return READABLE
            if joining and all(t.state == _DETACHED or t.seq not in self._all for t in joining):
                return WOKEN
            if lock is not None and not lock.held:
                lock.held = True
                return WOKEN
            if wake_at is not None and wake_at <= self._now:
                return TIME
            temporary = p is None
            if temporary:
                # not a participant: scheduled for this wait only
                p = _Participant(f"thread {threading.current_thread().name}", next(self._seq),
                                 threading.Condition(self._lock))
                p.ident = threading.get_ident()
                p.thread = threading.current_thread()
                p.temporary = True
                self._all[p.seq] = p
                self._participants[p.ident] = p
            assert p is not None
            self._running.discard(p)
            p.state = _PARKED
            p.wake_at, p.pipe, p.joining, p.lock = wake_at, pipe, joining, lock
            if lock is not None:
                lock.waiters.append(p)
            try:
                self._dispatch()
                self._await_baton(p)
            finally:
                p.wake_at, p.pipe, p.joining = None, None, frozenset()
                if lock is not None:
                    if p in lock.waiters:
                        lock.waiters.remove(p)
                    p.lock = None
                if temporary:
                    self._drop(p)
                    self._dispatch()
            return p.reason


class _SimLock:
    """A mutex whose waiters wait on the :class:`SimClock` (a participant blocked on a plain
    lock held by a parked one would keep the baton and stop the clock)."""

    def __init__(self, clock: _Scheduler) -> None:
        self.clock = clock
        self.held = False
        self.waiters: list[_Participant] = []

    def acquire(self) -> bool:
        # _wait takes the lock for us when it is free; when it is released to us, release()
        # already marked it held; a detached participant is no longer scheduled and takes it
        if self.clock._wait(lock=self) == STOPPED:
            self.held = True
        return True

    def release(self) -> None:
        clock = self.clock
        with clock._lock:
            waiters = [p for p in self.waiters if p.state == _PARKED]
            if waiters:
                first = waiters[0]
                self.waiters.remove(first)
                clock._make_ready(first, WOKEN)   # handed over: stays held
                clock._dispatch()
            else:
                self.held = False

    def __enter__(self) -> _SimLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
