"""A worker process of a parallel search: live sessions, solved in slices.

A worker holds one session per horizon it was given (a :class:`QuerySession`, i.e. one
incremental solver), runs them in slices of a solver budget (pysat's ``solve_limited``
with a propagation budget, or a conflict budget for CaDiCaL), picks the next slice by
stride scheduling over the horizons' shares (strategy B: γ^i), and reads its pipe between
slices.  A session whose horizon is proved empty is extended upwards to the next horizon
the worker is given, so what its solver learned stays (as in the sequential search).
It leaves on ``stop``, on a closed pipe, on Ctrl-C, and (asked of the kernel) when its
parent dies. The parent's side is :mod:`cplus.parallel.dispatch`.
"""
from __future__ import annotations

import os
import signal
import time
import traceback
from typing import Any

from cplus.errors import CPlusError
from cplus.parallel.work import Work
from cplus.sat.horizon import HorizonStats, QuerySession

__all__ = ["SLICE_S", "worker_main", "die_with_parent"]

SLICE_S = 0.05
"""Target length of one solver slice (seconds): how long a worker may be deaf to its pipe
(a cancelled horizon goes on at most this long) against the cost of a call (restarting the
search from the root level with what was learned: microseconds)."""

_FIRST_BUDGET = {"propagations": 200_000, "conflicts": 500}
_CHUNK = 256     # histories per message


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
                slot.stat["result"] = msg[2] if len(msg) > 2 else "dropped"   # "taken": see strategy.chained
                self.conn.send(("dropped", self.wid, slot.m, slot.stat))
                self.free.append(slot.session)
        elif kind == "enumerate":
            self.enumerate(self.slots[msg[1]], msg[2])
        elif kind == "learn":
            self.work.learn(self.sessions(), msg[1])
        elif kind == "nice":
            try:
                os.nice(msg[1])
            except OSError:     # pragma: no cover - not allowed here: run at the parent's priority
                pass
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


def die_with_parent() -> None:
    """Ask Linux to SIGKILL this worker when its parent dies (prctl PR_SET_PDEATHSIG)."""
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)
    except (OSError, AttributeError):    # pragma: no cover - not Linux: the closed pipe ends it
        pass


def worker_main(conn, wid: int, work: Work) -> None:
    try:
        # forked with SIGINT blocked (see dispatch._Search._start): a Ctrl-C from now on ends it here, quietly
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        die_with_parent()
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
