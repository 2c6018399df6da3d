"""Clocks and deadlines: every wait in `nxt_link` goes through one of these.

Library code never calls ``time.time()``; it takes a :class:`Clock` (default
:data:`MONOTONIC`). Tests pass a :class:`VirtualClock`, so a 10-second
trajectory run against the in-memory emulator takes milliseconds and never
depends on the machine's load. Bricks emulated in threads of the same process
behind real pseudo-terminals run on a :class:`SimClock`: simulated time that
moves only when every thread taking part waits on it (see its docstring), so
a run's outcome depends neither on the machine's load nor on its speed.

>>> clock = VirtualClock()
>>> d = Deadline(clock, 0.5)
>>> clock.sleep(0.2); round(d.remaining(), 3)
0.3
>>> clock.sleep(0.4); d.expired()
True
"""
from __future__ import annotations

import itertools
import logging
import os
import threading
import time
import weakref
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, Protocol

__all__ = ["Clock", "MonotonicClock", "VirtualClock", "Deadline", "MONOTONIC", "SimClock",
           "SimulationStalled", "Pipe", "Channel", "start_thread", "join_threads", "new_lock",
           "clock_of_device"]

log = logging.getLogger(__name__)


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


# -- simulated time for in-process emulations ----------------------------------------------


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


class SimClock:
    """Simulated time shared by emulated bricks and the PC side that drives them: a
    discrete-event scheduler whose waiters are threads.

    *Participants* are the threads that take part (each brick's server loop, the PC thread
    that runs the link, the threads it starts for several bricks at once); they are
    registered explicitly (:meth:`participant`, :func:`start_thread`). Exactly one of them
    runs at a time — it holds the *baton* — and it keeps it until it waits on the clock:
    :meth:`sleep`, :meth:`wait_readable` (bytes on a :class:`Pipe`, with a deadline or
    none), :meth:`join` (another participant's end) or a lock made by :func:`new_lock`.
    Then the first participant whose wait is over gets the baton, in a deterministic order
    (first come, first served; ties of one instant in the order of registration). When
    every participant waits and none can go on (*quiescence*: no deadline due, no bytes on
    their way to a reader that waits for them), time jumps to the earliest deadline.

    So simulated time advances only as the emulation does, whatever the machine's load,
    and the same inputs (seeds included) give the same run, event for event: at any one
    moment one participant acts on the emulation, and which one is decided by simulated
    time alone. A slow PC makes the run take longer, never makes a brick look lost.

    Bytes between participants travel over real pseudo-terminals (the serial path is
    pyserial's, as with a real brick): each end counts the bytes it writes
    (:meth:`wrote`) and reads (:meth:`consumed`), and a reader woken for counted bytes
    waits for them in real time (they are already written), so time never passes while
    bytes are in flight to a participant waiting for them.

    Safety net: a participant that keeps the baton without waiting on the clock (a thread
    blocked on something the clock does not know) stops everyone else. When the baton has
    not moved for ``stall_timeout_s`` of real time, far longer than any legitimate
    computation between two waits, the clock fails: every wait raises
    :class:`SimulationStalled` with what each participant was doing. A participant whose
    thread died without unregistering is dropped (and logged) instead. A thread that is no
    participant may still wait on the clock: it is scheduled for that wait only, and what
    it does between its waits is not waited for (nor deterministic).

    Lock order: the clock's one lock is innermost; it is never held while calling out.
    """

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
        _CLOCKS.add(self)

    # -- time -------------------------------------------------------------------------

    def now(self) -> float:
        return self._now

    def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of simulated time (0: return at once, keeping the baton)."""
        if seconds > 0:
            self._wait(wake_at=self._now + seconds)
        else:
            self._check_failed()

    def wait_until(self, t: float) -> str:
        """Wait until simulated time ``t``; returns :data:`TIME` (or :data:`STOPPED`)."""
        return self._wait(wake_at=t)

    def wait_readable(self, pipe: Pipe, until: float | None) -> str:
        """Wait until bytes are on their way on ``pipe`` (or it closed): :data:`READABLE`;
        until simulated time ``until`` (None: no deadline): :data:`TIME`; or
        :data:`STOPPED` when the caller's participant was detached."""
        return self._wait(wake_at=until, pipe=pipe)

    # -- participants --------------------------------------------------------------------

    def register(self, name: str) -> _Participant:
        """A participant for a thread about to start (:func:`start_thread`): it counts from
        now, so time cannot pass before the thread runs. The thread calls :meth:`attach`."""
        with self._lock:
            p = _Participant(name, next(self._seq), threading.Condition(self._lock))
            self._all[p.seq] = p
            self._ready.append(p)
            self._dispatch()
            return p

    def attach(self, p: _Participant) -> None:
        """Bind ``p`` to the calling thread and wait for the baton."""
        with self._lock:
            p.ident = threading.get_ident()
            p.thread = threading.current_thread()
            self._participants[p.ident] = p
            p.depth = 1
            self._await_baton(p)

    def unregister(self, p: _Participant | None = None) -> None:
        """The calling thread (or ``p``) takes no more part; whoever waited for its end may
        go on. Safe to call twice."""
        with self._lock:
            if p is None:
                p = self._participants.get(threading.get_ident())
                if p is None:
                    return
            self._drop(p)
            self._dispatch()

    @contextmanager
    def participant(self, name: str) -> Iterator[None]:
        """The calling thread is a participant inside the block (nested blocks of one
        thread are one participant)."""
        ident = threading.get_ident()
        with self._lock:
            p = self._participants.get(ident)
            if p is not None and p.state != _DETACHED and not p.temporary:
                p.depth += 1
                nested = True
            else:
                nested = False
        if nested:
            try:
                yield
            finally:
                with self._lock:
                    p.depth -= 1    # type: ignore[union-attr]
            return
        p = self.register(name)
        self.attach(p)
        try:
            yield
        finally:
            self.unregister(p)

    def detach(self, p: _Participant) -> None:
        """Stop scheduling ``p`` (its owner stops it): its waits end with :data:`STOPPED`
        at once, and nobody waits for it any more."""
        with self._lock:
            if p.state == _DETACHED:
                return
            self._running.discard(p)
            if p in self._ready:
                self._ready.remove(p)
            p.state = _DETACHED
            p.reason = STOPPED
            p.cond.notify()
            self._release_joiners(p)
            self._progress = time.monotonic()
            self._dispatch()

    def is_participant(self) -> bool:
        """Whether the calling thread is a (scheduled) participant."""
        p = self._participants.get(threading.get_ident())
        return p is not None and p.state != _DETACHED and not p.temporary

    def join(self, ps: Iterable[_Participant]) -> None:
        """Wait until every participant of ``ps`` has unregistered (or was detached)."""
        targets = frozenset(ps)
        self._wait(joining=targets)

    # -- channels ---------------------------------------------------------------------------

    def open_channel(self, key: str) -> Channel:
        """A fresh channel for a new pseudo-terminal (its slave's path); replaces an older
        one of the same path."""
        with self._lock:
            ch = Channel(key)
            self._channels[key] = ch
            return ch

    def channel(self, key: str) -> Channel | None:
        """The channel of the pseudo-terminal whose slave is ``key``, if one is open."""
        with self._lock:
            return self._channels.get(key)

    def close_channel(self, ch: Channel) -> None:
        """The pty closed: bytes in flight are lost; readers waiting on it wake up (their
        read then fails, as a real link's does)."""
        with self._lock:
            for pipe in (ch.to_brick, ch.to_pc):
                pipe.closed = True
                pipe.pending = 0
                self._wake_readers(pipe)
            if self._channels.get(ch.key) is ch:
                del self._channels[ch.key]
            self._dispatch()

    def wrote(self, pipe: Pipe, n: int) -> None:
        """``n`` bytes are being written to ``pipe`` (called before the write)."""
        if n <= 0:
            return
        with self._lock:
            if pipe.closed:
                return
            pipe.pending += n
            self._wake_readers(pipe)
            self._dispatch()

    def consumed(self, pipe: Pipe, n: int) -> None:
        """``n`` bytes were read from ``pipe`` (or will never arrive)."""
        with self._lock:
            pipe.pending = max(0, pipe.pending - n)
            self._progress = time.monotonic()

    def lost(self, pipe: Pipe) -> None:
        """Whatever was counted on ``pipe`` will not arrive (a failed write, a flush)."""
        with self._lock:
            pipe.pending = 0

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


_CLOCKS: weakref.WeakSet[SimClock] = weakref.WeakSet()


def clock_of_device(path: str) -> SimClock | None:
    """The simulated clock of the brick emulated in this process that serves ``path`` (its
    pty, or a symlink to it), if there is one: a client of that brick must wait on that
    clock, even when it was given the path as if it were a device of its own."""
    key = os.path.realpath(path)
    for clock in list(_CLOCKS):
        if clock.channel(key) is not None:
            return clock
    return None


class _SimLock:
    """A mutex whose waiters wait on the :class:`SimClock` (a participant blocked on a plain
    lock held by a parked one would keep the baton and stop the clock)."""

    def __init__(self, clock: SimClock) -> None:
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
