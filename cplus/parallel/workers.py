"""Several horizons of one query at once, on worker processes, each with live solvers.

The parent grounds the query and builds the clause templates once, then forks the workers
(``fork``: they inherit the grounded theory, the templates and a session ready for its
first solve, without pickling any of it).  The parent schedules horizons over the workers
by a :mod:`~cplus.parallel.strategy` and waits on their pipes; it computes nothing itself.

A worker holds one session per horizon it was given (a :class:`QuerySession`, i.e. one
incremental solver), runs them in slices of a solver budget (pysat's ``solve_limited``
with a propagation budget, or a conflict budget for CaDiCaL), picks the next slice by
stride scheduling over the horizons' shares (strategy B: γ^i), and reads its pipe between
slices.  A session whose horizon is proved empty is extended upwards to the next horizon
the worker is given, so what its solver learned stays (as in the sequential search).

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

import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cplus.errors import CPlusError
from cplus.history import History
from cplus.parallel.strategy import Strategy, available_cores, in_flight, share, window_based
from cplus.sat.horizon import HorizonStats, QuerySession

__all__ = ["Work", "Outcome", "search", "available_cores", "SLICE_S", "MAX_REPLACEMENTS"]

SLICE_S = 0.05
"""Target length of one solver slice (seconds): how long a worker may be deaf to its pipe
(a cancelled horizon goes on at most this long) against the cost of a call (restarting the
search from the root level with what was learned: microseconds)."""

MAX_REPLACEMENTS = 3
"""Workers lost (killed, out of memory) and replaced in one search before it gives up."""

_FIRST_BUDGET = {"propagations": 200_000, "conflicts": 500}
_CHUNK = 256     # histories per message


class Work:
    """What the search needs from a domain inside a worker, and what a model means there.

    The plain planner's: a model is the horizon's answer.  Built in the parent before the
    workers are forked, so whatever it holds is in every worker without being sent."""

    def __init__(self, session: QuerySession) -> None:
        self.first: QuerySession | None = session      # ready for its first solve: one worker slot's
        self.theory = session.theory
        self.query = session.query
        self.solver = session._solver_name
        self.max_horizon = session.max_horizon
        h = session.horizon
        self.templates = (h.layout, h.t_rigid, h.t_init, h.t_trans)
        self.template_s = h.template_s
        self.index = {gc: i for i, gc in enumerate(self.theory.sig.ground)}

    def new_session(self) -> QuerySession:
        """A session for one more horizon in this worker (the inherited one first)."""
        if self.first is not None:
            s, self.first = self.first, None
            return s
        s = QuerySession(self.theory, self.query, self.solver, self.max_horizon, templates=self.templates)
        self.prepare(s)
        return s

    def prepare(self, session: QuerySession) -> None:
        """Whatever a new session must be taught before its first solve (robot: nogoods); the
        first session was given to the constructor and is the caller's to prepare."""

    def on_model(self, session: QuerySession, m: int, sessions: list[QuerySession]) -> tuple[bool, object]:
        """A model at horizon m: ``(True, payload)`` when it answers the horizon, ``(False,
        learned)`` when it is refuted and ``learned`` (already taught to ``sessions``, this
        worker's) goes to the other workers; the horizon is then solved again."""
        return True, None

    def learn(self, sessions: list[QuerySession], learned: object) -> None:
        """Teach this worker's sessions what another worker learned."""

    def on_unsat(self, session: QuerySession, m: int) -> object:
        """Extra facts about a horizon proved empty, for the parent (robot: were there plans)."""
        return None

    # histories travel as indices: ground constants are interned per process (identity is equality)
    def encode(self, hist: History) -> tuple:
        ix = self.index

        def table(t: dict) -> list:
            return [(ix[gc], gc.domain.index(v)) for gc, v in t.items()]
        return hist.maxstep, table(hist.rigid), [table(s) for s in hist.states], [table(a) for a in hist.actions]

    def decode(self, data: tuple) -> History:
        ground = self.theory.sig.ground
        m, rigid, states, actions = data

        def table(rows: list) -> dict:
            return {ground[i]: ground[i].domain[j] for i, j in rows}
        return History(m, table(rigid), tuple(table(s) for s in states), tuple(table(a) for a in actions))


@dataclass
class Outcome:
    """What a search found.  ``records``: one per (worker, horizon) that ran, in the order they
    ended (``result``: ``unsat``, ``sat``, ``dropped`` for one cancelled by a shorter plan,
    ``stopped`` for one still running at the end)."""

    maxstep: int | None
    histories: list[History]
    proved: list[int]               # horizons proved empty, ascending
    unproved: list[int]             # below maxstep and not proved empty (only with any_length)
    records: list[dict] = field(default_factory=list)
    extras: dict[int, object] = field(default_factory=dict)    # Work.on_unsat's, by horizon
    payload: object = None          # Work.on_model's for the answer
    learned: list[tuple[int, int, object]] = field(default_factory=list)   # (worker, maxstep, learned)
    workers: int = 0
    replaced: int = 0
    stopped_early: bool = False     # a hook ended the search (robot: --max-iterations)


# ---------------------------------------------------------------------------------------- worker


class _Slot:
    __slots__ = ("m", "session", "share", "pass_", "opened", "parked", "stat")

    def __init__(self, m: int, session: QuerySession, share: float, pass_: float, wid: int) -> None:
        self.m = m
        self.session = session
        self.share = share
        self.pass_ = pass_
        self.opened = False
        self.parked = False
        self.stat: dict[str, Any] = {"worker": wid, "maxstep": m, "result": None, "variables": 0, "clauses": 0, "encode_s": 0.0,
                     "solve_s": 0.0, "cpu_s": 0.0, "slices": 0}


class _Worker:
    def __init__(self, conn, wid: int, work: Work) -> None:
        self.conn = conn
        self.wid = wid
        self.work = work
        self.slots: dict[int, _Slot] = {}
        self.free: list[QuerySession] = []
        self.budget: dict[str, int] = dict(_FIRST_BUDGET)

    def sessions(self) -> list[QuerySession]:
        return [s.session for s in self.slots.values()] + self.free

    def run(self) -> None:
        while True:
            while self.conn.poll(0) or not any(not s.parked for s in self.slots.values()):
                try:
                    msg = self.conn.recv()
                except EOFError:       # the parent is gone
                    return
                if not self.handle(msg):
                    return
            slot = min((s for s in self.slots.values() if not s.parked), key=lambda s: s.pass_)
            self.slice(slot)

    def handle(self, msg: tuple) -> bool:
        kind = msg[0]
        if kind == "add":
            _, m, sh = msg
            self.slots[m] = _Slot(m, self._session_for(m), sh, self._min_pass(), self.wid)
        elif kind == "share":
            for m, sh in msg[1].items():
                if m in self.slots:
                    self.slots[m].share = sh
        elif kind == "drop":
            slot = self.slots.pop(msg[1], None)
            if slot is not None:
                slot.stat["result"] = "dropped"
                self.conn.send(("dropped", self.wid, slot.m, slot.stat))
                self.free.append(slot.session)
        elif kind == "enumerate":
            self.enumerate(self.slots[msg[1]], msg[2])
        elif kind == "learn":
            self.work.learn(self.sessions(), msg[1])
        elif kind == "stop":
            left = []
            for slot in self.slots.values():
                if slot.stat["result"] is None:
                    slot.stat["result"] = "stopped"
                    left.append(slot.stat)
            self.conn.send(("bye", self.wid, left))
            return False
        return True

    def _min_pass(self) -> float:
        running = [s.pass_ for s in self.slots.values() if not s.parked]
        return min(running) if running else 0.0

    def _session_for(self, m: int) -> QuerySession:
        """The free session closest below m (its learned clauses kept), else a new one."""
        usable = [s for s in self.free if s.horizon.m <= m]
        if usable:
            best = max(usable, key=lambda s: s.horizon.m)
            self.free.remove(best)
            for s in [s for s in self.free if s.horizon.m > m]:   # never usable again: horizons only grow
                self.free.remove(s)
                s.horizon.solver.delete()
            return best
        return self.work.new_session()

    def slice(self, slot: _Slot) -> None:
        s = slot.session
        st = slot.stat
        t0, c0 = time.perf_counter(), time.process_time()
        if not slot.opened:
            s.open_horizon(slot.m)
            slot.opened = True
            h = s.horizon
            t1 = time.perf_counter()
            s.stats.append(HorizonStats(slot.m, h.top, h.solver.count, t1 - t0, 0.0))
            st["encode_s"] += t1 - t0
            st["variables"], st["clauses"] = h.top, h.solver.count
            cpu = time.process_time() - c0
            st["cpu_s"] += cpu
            slot.pass_ += cpu / slot.share
            return
        solver = s.horizon.solver
        assumptions = [s.act, *s.assumptions]
        kind = solver.budget_kind
        if kind == "propagations":
            ok = solver.solve_limited(assumptions, self.budget[kind])
        elif kind == "conflicts":
            ok = solver.solve_conflicts(assumptions, self.budget[kind])
        else:        # a backend without budgets: one slice is the whole solve
            ok = solver.solve(assumptions)
        dt, cpu = time.perf_counter() - t0, time.process_time() - c0
        if kind is not None and ok is None:     # aim the next slice at SLICE_S
            factor = min(2.0, max(0.5, SLICE_S / max(dt, 1e-4)))
            self.budget[kind] = max(1000 if kind == "propagations" else 10, int(self.budget[kind] * factor))
        slot.pass_ += cpu / slot.share
        st["solve_s"] += dt
        st["cpu_s"] += cpu
        st["slices"] += 1
        s.stats[-1].solve_s += dt
        if ok is None:
            return
        s.stats[-1].satisfiable = ok
        if ok:
            final, payload = self.work.on_model(s, slot.m, self.sessions())
            if not final:
                self.conn.send(("learn", self.wid, slot.m, payload))
                return
            slot.parked = True
            st["result"] = "sat"
            self.conn.send(("done", self.wid, slot.m, True, st, payload))
            return
        extra = self.work.on_unsat(s, slot.m)
        st["result"] = "unsat"
        del self.slots[slot.m]
        self.free.append(s)
        self.conn.send(("done", self.wid, slot.m, False, st, extra))

    def enumerate(self, slot: _Slot, n: int) -> None:
        """Send up to n histories at the slot's horizon (0: all), in chunks."""
        from cplus.planner import iter_histories
        s = slot.session
        batch: list[tuple] = []
        count = 0
        for hist in iter_histories(s):
            batch.append(self.work.encode(hist))
            count += 1
            if n and count >= n:
                break
            if len(batch) >= _CHUNK:
                self.conn.send(("histories", self.wid, slot.m, batch, False))
                batch = []
        self.conn.send(("histories", self.wid, slot.m, batch, True))


def _die_with_parent() -> None:
    """Ask Linux to SIGKILL this worker when its parent dies (prctl PR_SET_PDEATHSIG)."""
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)
    except (OSError, AttributeError):    # pragma: no cover - not Linux: the closed pipe ends it
        pass


def _worker_main(conn, wid: int, work: Work) -> None:
    try:
        # forked with SIGINT blocked (see _Search._start): a Ctrl-C from now on ends it here, quietly
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        _die_with_parent()
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        _Worker(conn, wid, work).run()
    except KeyboardInterrupt:
        os._exit(130)
    except BaseException as exc:   # report it: the parent raises it (a located error stays located)
        try:
            conn.send(("error", wid, exc if isinstance(exc, CPlusError) else None, traceback.format_exc()))
        except Exception:   # unpicklable or the pipe is gone
            try:
                conn.send(("error", wid, None, traceback.format_exc()))
            except Exception:
                pass
        os._exit(1)
    os._exit(0)


# ---------------------------------------------------------------------------------------- parent


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
        self.jobs = jobs
        self.strategy = strategy
        self.gamma = gamma
        self.solutions = solutions
        self.any_length = any_length
        self.on_record = on_record
        self.on_learned = on_learned
        self.lo = q.lo
        self.hi = q.hi if q.hi is not None else work.max_horizon
        self.width = in_flight(strategy, jobs, gamma)
        self.next_h = self.lo
        self.k = self.lo
        self.proved: set[int] = set()
        self.running: dict[int, _Proc] = {}
        self.sat: dict[int, _Proc] = {}
        self.procs: list[_Proc] = []
        self.out = Outcome(None, [], [], [], workers=jobs)
        self.done = False
        self.answer: int | None = None
        self.lost = 0
        self.payloads: dict[int, object] = {}
        self._ctx = None

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
        proc = ctx.Process(target=_worker_main, args=(child, wid, self.work), daemon=True)   # type: ignore[attr-defined]
        # the child starts with SIGINT blocked, until it is inside the code that handles it
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

    # ------------------------------------------------------------------ scheduling
    def _record(self, st: dict) -> None:
        self.out.records.append(st)
        if self.on_record:
            self.on_record(st)

    def _pick(self) -> _Proc:
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
        p = self._pick()
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
        new = self._start(p.wid)
        self.procs[self.procs.index(p)] = new
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
            self.procs = [self._start(w) for w in range(self.jobs)]
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
    """Search the query's horizons on ``jobs`` worker processes (see the module's docstring).

    ``on_record`` hears each (worker, horizon) record as it ends; ``on_learned(worker,
    maxstep, learned)`` hears what a worker learned from a refuted model and ends the search
    by returning true."""
    return _Search(work, jobs, Strategy(strategy), gamma, solutions, any_length, on_record, on_learned).run()
