"""Several horizons of one query at once, on worker processes, each with live solvers.

The parent grounds the query and builds the clause templates once, then forks the workers
(``fork``: they inherit the grounded theory, the templates and a session ready for its
first solve, without pickling any of it).  The parent schedules horizons over the workers
by a :mod:`~cplus.parallel.strategy` and waits on their pipes; it computes nothing itself.

The workers' side is :mod:`cplus.parallel.worker`.

The answer keeps CCALC's meaning unless ``any_length``: the shortest maxstep with a
history, so the search ends only once every shorter horizon is proved empty; a horizon
found satisfiable cancels every longer one.  With ``any_length`` the first history found
ends it, with the horizons below that were not proved empty said so.

Robot tasks plug in through :class:`Work`: a model may be refuted (refinement), and what is
learned from it is sent to every worker, since position nogoods hold at every horizon.

Stopping: Ctrl-C reaches every process of the terminal's group; each worker leaves quietly,
the parent terminates the rest and re-raises.  SIGTERM to the parent is turned into the same
path.  Workers ask the kernel for SIGKILL when the parent dies, and also leave when their
pipe closes.  A worker that dies (killed, out of memory) is replaced and its horizons
started again, up to :data:`MAX_REPLACEMENTS` times.
"""
from __future__ import annotations

import signal
import sys
import threading
import time
from collections.abc import Callable

from cplus.errors import CPlusError
from cplus.options import worker_bound
from cplus.parallel.strategy import Strategy, chained, in_flight, share, window_based
from cplus.parallel.work import Outcome, Work
from cplus.parallel.worker import worker_main

__all__ = ["search", "workers_for", "MAX_REPLACEMENTS"]

MAX_REPLACEMENTS = 3
"""Workers lost (killed, out of memory) and replaced in one search before it gives up."""


SPECULATIVE_NICE = 10
"""Under strategy B on two workers or more, the workers other than the first (the horizons
above the shortest unfinished one, :func:`~cplus.parallel.strategy.chained`) lower their
priority by this much (``nice``): they run on the cores nobody else wants, and on a busy
machine the first worker, which runs what the sequential search would, keeps its share."""


class _Proc:
    __slots__ = ("wid", "proc", "conn", "load", "last", "alive")

    def __init__(self, wid: int, proc, conn) -> None:
        self.wid = wid
        self.proc = proc
        self.conn = conn
        self.load: dict[int, float] = {}     # horizon -> share, of what runs there
        self.last = -1                       # the last horizon it was given (its session is there)
        self.alive = True


class _Search:
    def __init__(self, work: Work, jobs: int, strategy: Strategy, gamma: float, solutions: int,
                 any_length: bool, on_record: Callable[[dict], None] | None,
                 on_learned: Callable[[int, int, object], bool] | None) -> None:
        q = work.query
        self.work = work
        self.lo = q.lo
        self.hi = q.hi if q.hi is not None else work.max_horizon
        self.asked = jobs
        self.jobs = workers_for(jobs, strategy, gamma, self.lo, self.hi)
        self.strategy = strategy
        self.gamma = gamma
        self.solutions = solutions
        self.any_length = any_length
        self.on_record = on_record
        self.on_learned = on_learned
        self.width = in_flight(strategy, self.jobs, gamma)
        self.chain = chained(strategy, self.jobs)    # B: k alone on procs[0] (strategy.chained)
        self.next_h = self.lo
        self.k = self.lo
        self.proved: set[int] = set()
        self.running: dict[int, _Proc] = {}
        self.taken: set[tuple[int, int]] = set()    # (worker, horizon) taken over, its drop not yet answered
        self.stale: set[tuple[int, int]] = set()    # ... answered by a result sent before the drop arrived
        self.sat: dict[int, _Proc] = {}
        self.procs: list[_Proc] = []
        self.out = Outcome(None, [], [], [], workers=self.jobs)
        self.done = False
        self.answer: int | None = None
        self.lost = 0
        self.payloads: dict[int, object] = {}
        self._ctx = None
        self._made: list = []     # every worker process ever started: an interrupt may land before it is in procs

    # ------------------------------------------------------------------ processes
    def _start(self, wid: int) -> _Proc:
        import multiprocessing
        if self._ctx is None:
            self._ctx = multiprocessing.get_context("fork")     # type: ignore[assignment]
        ctx = self._ctx
        parent, child = ctx.Pipe()    # type: ignore[attr-defined]
        for stream in (sys.stdout, sys.stderr):    # a fork must not inherit unwritten output
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        proc = ctx.Process(target=worker_main, args=(child, wid, self.work), daemon=True)   # type: ignore[attr-defined]
        # the child starts with SIGINT blocked, until it is inside the code that handles it
        self._made.append(proc)
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            proc.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        child.close()
        return _Proc(wid, proc, parent)

    def _shutdown(self) -> None:
        for p in self.procs:
            if p.alive:
                try:
                    _send(p, ("stop",))
                except (OSError, ValueError):
                    p.alive = False
        deadline = time.monotonic() + 2.0
        for p in self.procs:
            if p.alive:
                try:
                    while p.conn.poll(max(0.0, deadline - time.monotonic())):
                        msg = p.conn.recv()
                        if msg[0] == "bye":
                            for st in msg[2]:
                                self._record(st)
                            break
                        if msg[0] == "dropped":
                            self._record(msg[3])
                except (EOFError, OSError):
                    pass
        for p in self.procs:
            p.proc.join(max(0.0, deadline - time.monotonic()))
            if p.proc.is_alive():
                p.proc.terminate()
                p.proc.join(1.0)
            if p.proc.is_alive():   # pragma: no cover - ignores SIGTERM
                p.proc.kill()
                p.proc.join()
            p.conn.close()
        known = {id(p.proc) for p in self.procs}
        for proc in self._made:    # started, but an interrupt came before it was recorded
            if id(proc) not in known and proc.pid is not None and proc.is_alive():
                proc.kill()
                proc.join()

    # ------------------------------------------------------------------ scheduling
    def _record(self, st: dict) -> None:
        self.out.records.append(st)
        if self.on_record:
            self.on_record(st)

    def _pick(self, m: int) -> _Proc:
        if self.chain:
            head = self.procs[0]
            if m == self.k and head.alive:
                return head
            live = [p for p in self.procs[1:] if p.alive] or [p for p in self.procs if p.alive]
        else:
            live = [p for p in self.procs if p.alive]
        # least loaded; among equals the one whose session is highest (it extends least)
        return min(live, key=lambda p: (sum(p.load.values()), -p.last, p.wid))

    def _fill(self) -> None:
        while not self.done:
            m = self.next_h
            if self.hi is not None and m > self.hi:
                return
            best = min(self.sat) if self.sat else None
            if best is not None and (m >= best or self.any_length):
                return
            if window_based(self.strategy):
                if m >= self.k + self.width:
                    return
            elif len(self.running) >= self.width:
                return
            self._give(m)
            self.next_h += 1

    def _give(self, m: int) -> None:
        p = self._pick(m)
        sh = share(self.strategy, self.gamma, m - self.k)
        _send(p, ("add", m, sh))
        p.load[m] = sh
        p.last = max(p.last, m)
        self.running[m] = p

    def _advance(self) -> None:
        k = self.k
        while k in self.proved:
            k += 1
        if k != self.k:
            self.k = k
            if window_based(self.strategy):
                for p in self.procs:
                    if p.alive and p.load:
                        new = {m: share(self.strategy, self.gamma, m - k) for m in p.load}
                        p.load.update(new)
                        _send(p, ("share", new))
        if self.hi is not None and self.k > self.hi:
            self.done = True
        elif self.sat and self.k == min(self.sat):
            self._finish(self.k)
        elif self.chain:
            self._take_over()

    def _take_over(self) -> None:
        """B's chain (:func:`~cplus.parallel.strategy.chained`): the shortest unfinished
        horizon k, when another worker holds it, is dropped there and given to the first worker,
        whose solver has just proved the horizon below empty (one not started yet goes there from
        :meth:`_fill`)."""
        k = self.k
        p = self.running.get(k)
        if p is None or p is self.procs[0]:
            return
        del self.running[k]
        p.load.pop(k, None)
        self.taken.add((p.wid, k))
        _send(p, ("drop", k, "taken"))
        self._give(k)

    def _finish(self, m: int) -> None:
        self.done = True
        self.answer = m

    def _drop_above(self, m: int) -> None:
        for h in [h for h in self.running if h > m]:
            p = self.running.pop(h)
            p.load.pop(h, None)
            _send(p, ("drop", h))

    def _handle(self, p: _Proc, msg: tuple) -> None:
        kind = msg[0]
        if kind == "done":
            _, _, m, ok, st, extra = msg
            if (p.wid, m) in self.taken:
                # Sent before the take-over's drop arrived: the first worker runs m now, and its
                # answer is the one used (a model found here could not be enumerated: the drop
                # removes it). A model's slot is still answered by the drop: not recorded twice.
                self.taken.discard((p.wid, m))
                if ok:
                    self.stale.add((p.wid, m))
                st["result"] = "taken"
                self._record(st)
                return
            self._record(st)
            self.running.pop(m, None)
            p.load.pop(m, None)
            if ok:
                self.sat[m] = p
                self.payloads[m] = extra
                self._drop_above(min(self.sat))
                if self.any_length:
                    self._finish(min(self.sat))
                    return
            else:
                self.proved.add(m)
                self.out.extras[m] = extra
            self._advance()
            self._fill()
        elif kind == "dropped":
            key = (msg[1], msg[2])
            self.taken.discard(key)
            if key in self.stale:       # recorded with the result that crossed the drop
                self.stale.discard(key)
                return
            self._record(msg[3])
        elif kind == "learn":
            _, wid, m, learned = msg
            self.out.learned.append((wid, m, learned))
            for other in self.procs:
                if other is not p and other.alive:
                    _send(other, ("learn", learned))
            if self.on_learned and self.on_learned(wid, m, learned):
                self.out.stopped_early = True
                self.done = True
        elif kind == "error":
            _, wid, exc, text = msg
            if exc is not None:
                raise exc
            raise RuntimeError(f"worker {wid} failed:\n{text}")

    def _lost(self, p: _Proc) -> None:
        """A worker died: start another in its place with its horizons (from scratch)."""
        p.alive = False
        code = p.proc.exitcode
        p.proc.join()
        p.conn.close()
        self.lost += 1
        if self.lost > MAX_REPLACEMENTS:
            how = f"was killed by signal {-code}" if code is not None and code < 0 else f"exited with code {code}"
            raise CPlusError(f"a solver worker {how}, {self.lost} times (out of memory?): giving up")
        mine = sorted(m for m, q in self.running.items() if q is p) + sorted(m for m, q in self.sat.items() if q is p)
        for m in mine:
            self.running.pop(m, None)
            self.sat.pop(m, None)
        self.taken = {key for key in self.taken if key[0] != p.wid}    # the new worker starts clean
        self.stale = {key for key in self.stale if key[0] != p.wid}
        new = self._start(p.wid)
        at = self.procs.index(p)
        self.procs[at] = new
        if self.chain and at > 0:
            _send(new, ("nice", SPECULATIVE_NICE))
        self.out.replaced += 1
        for _, _, learned in self.out.learned:
            _send(new, ("learn", learned))
        for m in mine:
            sh = share(self.strategy, self.gamma, m - self.k)
            _send(new, ("add", m, sh))
            new.load[m] = sh
            new.last = max(new.last, m)
            self.running[m] = new

    # ------------------------------------------------------------------ the loop
    def run(self) -> Outcome:
        old_term = None
        if threading.current_thread() is threading.main_thread():
            old_term = signal.signal(signal.SIGTERM, _term_as_interrupt)
        try:
            for w in range(self.jobs):
                self.procs.append(self._start(w))
            if self.chain:
                for p in self.procs[1:]:
                    _send(p, ("nice", SPECULATIVE_NICE))
            if self.hi is not None and self.lo > self.hi:
                self.done = True
            self._fill()
            self._loop()
            while self.answer is not None and not self._collect(self.answer):
                self.done, self.answer = False, None     # the answer's worker died: solve it again
                self._loop()
            return self._outcome()
        finally:
            self._shutdown()
            if old_term is not None:
                signal.signal(signal.SIGTERM, old_term)

    def _loop(self) -> None:
        from multiprocessing.connection import wait
        while not self.done:
            if not self.running and not self.sat:    # nothing can change any more
                break
            ends = {p.conn: p for p in self.procs if p.alive}
            ends.update({p.proc.sentinel: p for p in self.procs if p.alive})
            for ready in wait(list(ends)):
                p = ends[ready]
                if not p.alive or self.done:
                    continue
                if ready is p.conn or p.conn.poll(0):
                    try:
                        msg = p.conn.recv()
                    except (EOFError, OSError):
                        self._lost(p)
                        continue
                    self._handle(p, msg)
                else:
                    self._lost(p)

    def _collect(self, m: int) -> bool:
        """The answer's histories, from the worker that holds its solver; False when that
        worker died meanwhile (its horizons are then given to its replacement)."""
        p = self.sat[m]
        _send(p, ("enumerate", m, self.solutions))
        for q in self.procs:          # the others are not needed any more
            if q is not p and q.alive:
                _send(q, ("stop",))
        while True:
            try:
                msg = p.conn.recv()
            except (EOFError, OSError):
                self.out.histories = []
                self._lost(p)
                return False
            if msg[0] == "histories":
                self.out.histories.extend(self.work.decode(d) for d in msg[3])
                if msg[4]:
                    return True
            elif msg[0] in ("done", "dropped", "learn", "error"):
                self._handle(p, msg)

    def _outcome(self) -> Outcome:
        out = self.out
        out.maxstep = self.answer
        out.payload = self.payloads.get(self.answer) if self.answer is not None else None
        out.proved = sorted(self.proved)
        if self.answer is not None:
            out.unproved = [m for m in range(self.lo, self.answer) if m not in self.proved]
        return out


def workers_for(jobs: int, strategy: Strategy, gamma: float, lo: int, hi: int | None) -> int:
    """How many workers a search on ``jobs`` starts: no more than horizons can run at once
    (the strategy's, and the maxstep range's ``lo..hi``: a one-horizon query needs one), nor
    more than :data:`cplus.options.WORKERS_PER_CORE` per core (:func:`cplus.options.worker_bound`)."""
    useful = in_flight(strategy, jobs, gamma)
    if hi is not None:
        useful = min(useful, max(1, hi - lo + 1))
    return worker_bound(jobs, useful)


def _send(p: _Proc, msg: tuple) -> None:
    """A message to a worker; one that died meanwhile misses it, and its end (seen on its
    process sentinel) has everything it had re-sent to its replacement (:meth:`_Search._lost`)."""
    try:
        p.conn.send(msg)
    except (OSError, ValueError):
        pass


def _term_as_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def search(work: Work, jobs: int, strategy: Strategy | str = Strategy.A, gamma: float = 0.8, solutions: int = 1,
           any_length: bool = False, on_record: Callable[[dict], None] | None = None,
           on_learned: Callable[[int, int, object], bool] | None = None) -> Outcome:
    """Search the query's horizons on up to ``jobs`` worker processes (:func:`workers_for`; see
    the module's docstring).

    ``on_record`` hears each (worker, horizon) record as it ends; ``on_learned(worker,
    maxstep, learned)`` hears what a worker learned from a refuted model and ends the search
    by returning true."""
    return _Search(work, jobs, Strategy(strategy), gamma, solutions, any_length, on_record, on_learned).run()
