"""Clumps and their scheduling: ``finclump``, ``finclumpimmed``, ``subcall``, ``subret``,
``acquire``, ``release``, ``stop``, ``wait``, ``gettick``.

These are the instructions that end a turn (:mod:`nxt_link.emulator.vm.scheduler` runs
the turns): each moves its clump between the run queue, the rest queue and a
mutex's waiting list, and signals the run loop through ``vm._event``. The queue
primitives (``_enqueue``, ``_fire``, ``_sched_dependents``) are here because
only these instructions change the queues in the middle of a slice.
"""
from __future__ import annotations

from nxt_link.emulator.vm.core import DONE, NOT_A_DS_ID, ROTATE, STOP, SUSPEND, Fault, Op, VMCore
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.values import M32, Mutex, store

__all__ = ["ControlOps"]


class ControlOps(VMCore):
    """Compilers of the scheduling instructions, and the run queue's operations."""

    def _enqueue(self, c: int) -> None:
        if c in self.runq:
            raise Fault(f"clump {c} scheduled while it is already running (a subroutine "
                        f"called by two tasks at once, or recursion)")
        self.runq.append(c)

    def _sched_dependents(self, c: int, begin: int, end: int) -> None:
        deps = self.exe.clumps[c].dependents
        if begin == -1 and end == -1:
            return
        if not (0 <= begin <= end < len(deps)):
            raise Fault(f"FINCLUMP: dependents {begin}..{end} of clump {c}, which has "
                        f"{len(deps)}")
        for k in range(begin, end + 1):
            self._fire(deps[k])

    def _fire(self, target: int) -> None:
        self.fire[target] -= 1
        if self.fire[target] == 0:
            self._enqueue(target)

    def _finclump(self, c: int, begin: int, end: int) -> Op:
        def f() -> int:
            self._dequeue_head(c)
            self._sched_dependents(c, begin, end)
            self._event = DONE
            return -1
        return f

    def _finclumpimmed(self, c: int, target: int) -> Op:
        if target >= len(self.exe.clumps):
            raise Fault(f"FINCLUMPIMMED: clump {target} does not exist")

        def f() -> int:
            self._dequeue_head(c)
            self._fire(target)
            self._event = DONE
            return -1
        return f

    def _dequeue_head(self, c: int) -> None:
        if self.runq and self.runq[0] == c:
            self.runq.pop(0)
        else:
            self.runq.remove(c)

    def _subcall(self, callee: int, ret: int, nxt: int, name: str) -> Op:
        if callee >= len(self.exe.clumps):
            raise Fault(f"{name}: clump {callee} does not exist")
        self._scalar_arg(ret, name)
        m = self.mem
        rt = self.types[ret].tc
        stored = [store(rt, k) for k in range(len(self.exe.clumps))]  # the caller's index
        rq, restq = self.runq, self.restq

        def f() -> int:
            caller = rq.pop(0)
            m[ret] = stored[caller]
            if callee in rq or callee in restq:
                rq.insert(0, caller)
                raise Fault(f"{name}: subroutine clump {callee} called while it is already "
                            f"running (recursion, or two tasks calling it at once)")
            rq.append(callee)
            self._event = SUSPEND
            return ~nxt
        return f

    def _subret(self, ret: int) -> Op:
        self._scalar_arg(ret, "SUBRET")
        m = self.mem

        float_ret = self.types[ret].tc == TC.FLOAT
        clumps = len(self.exe.clumps)
        rq = self.runq

        def f() -> int:
            me = rq.pop(0)
            caller = (int(m[ret]) if float_ret else m[ret]) & 0xFF
            if caller >= clumps:
                rq.insert(0, me)
                raise Fault(f"SUBRET: return to clump {caller}, which does not exist")
            if caller in rq:
                self._enqueue(caller)  # the error
            rq.append(caller)
            self._event = DONE
            return -1
        return f

    def _acquire(self, i: int, nxt: int) -> Op:
        self._mutex_arg(i, "ACQUIRE")
        m = self.mem

        def f() -> int:
            mx: Mutex = m[i]
            me = self.runq[0]
            if mx.owner is None:
                mx.owner = me
                return nxt
            self.runq.pop(0)
            mx.waiting.append(me)
            self._event = SUSPEND
            return ~nxt
        return f

    def _release(self, i: int, nxt: int) -> Op:
        self._mutex_arg(i, "RELEASE")
        m = self.mem

        def f() -> int:
            mx: Mutex = m[i]
            mx.owner = mx.waiting.pop(0) if mx.waiting else None
            if mx.owner is not None:
                self._enqueue(mx.owner)
            return nxt
        return f

    def _stop(self, s: int, nxt: int) -> Op:
        rd = self._int_reader(s, "STOP") if s != NOT_A_DS_ID else None

        def f() -> int:
            if rd is None or rd() & M32:
                self._event = STOP
                return -1
            return nxt
        return f

    def _gettick(self, d: int, nxt: int) -> Op:
        self._scalar_arg(d, "GETTICK")
        return self._fuser.template(f"m[{d}] = store({self.types[d].tc}, vm.tick & 0xFFFFFFFF)\n"
                                    f"vm._polled = True")

    def _wait(self, d: int, s: int, nxt: int) -> Op:
        rd = self._int_reader(s, "WAIT")
        m = self.mem
        dt = self.types[self._scalar_arg(d, "WAIT")].tc if d != NOT_A_DS_ID else None

        def f() -> int:
            ms = rd() & M32
            if dt is not None:
                m[d] = store(dt, self.tick & M32)
            if ms == 0:
                self._event = ROTATE
                return ~nxt
            me = self.runq.pop(0)
            self.restq.append(me)
            wake = self.awaken[me] = self.tick + ms
            if wake < self._next_wake:
                self._next_wake = wake
            self._event = SUSPEND
            return ~nxt
        return f
