""":class:`SimClock`, simulated time for bricks emulated in threads of this process, and
:func:`clock_of_device`, which finds the clock of a brick from its device path.

The calls a participant makes (wait, register, count bytes on a channel) are here; the
scheduling they rest on is :mod:`nxt_link.wire.sim_scheduler`'s.  Apart from the plain clocks
of :mod:`nxt_link.wire.clock` (which gives these names too) because only the in-process
emulations need it.
"""
from __future__ import annotations

import os
import threading
import time
import weakref
from collections.abc import Iterable, Iterator
from contextlib import contextmanager

from nxt_link.wire.sim_scheduler import (
    _DETACHED,
    STOPPED,
    Channel,
    Pipe,
    _Participant,
    _Scheduler,
)

# -- simulated time for in-process emulations ----------------------------------------------


class SimClock(_Scheduler):
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
        super().__init__(start, stall_timeout_s=stall_timeout_s)
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
