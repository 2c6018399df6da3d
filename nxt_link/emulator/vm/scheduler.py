"""The run loop: one millisecond time slice of clumps, turn by turn.

This is the fetch-and-dispatch loop, the only code that runs per instruction
besides the instructions themselves, so it is written for speed: locals for
everything it reads, one call per fused block (or per instruction when a
block does not fit the rest of the turn), and the queue bookkeeping only when
a turn ends. :mod:`nxt_link.emulator.vm.machine` describes the scheduling it models.

A slice ends at the first turn boundary after its budget (the firmware's
``TIMES_UP``). A turn that ends in an event (a clump finishing, calling a
subroutine, waiting) does not end the millisecond: the firmware's ``cCmdCtrl``
goes on with the next clump, and so does this loop, so that the end of a slice
is the firmware's. A program whose every turn is such an event, though (two
tasks handing over to each other with ``ExitTo``, one instruction each), would
then never give the CPU back: the emulator would answer no command and could
not be stopped. So past its budget a slice goes through such turns for at most
:data:`MAX_OVERRUN` instructions: one slice runs at most ``budget +
MAX_OVERRUN + INSTRUCTIONS_PER_TURN`` instructions, whatever the program does,
and a program whose turns end normally is not affected (its slice ends at the
first turn past the budget that does not end in an event, as before).

Whatever an instruction raises ends the program with a
:class:`~nxt_link.emulator.vm.errors.VMError` naming it: a ``Fault`` with the
firmware's reason, anything else (a value the interpreter cannot handle) as
"the interpreter cannot execute it". The caller (the firmware) reports the
program as aborted; nothing else escapes a slice.
"""
from __future__ import annotations

from nxt_link.emulator.vm.core import DONE, NEVER, ROTATE, STOP, SUSPEND, Fault, VMCore
from nxt_link.emulator.vm.errors import VMError
from nxt_link.emulator.vm.spin import SPIN_AFTER, SPIN_SOON

__all__ = ["Scheduler", "INSTRUCTIONS_PER_TURN", "MAX_OVERRUN"]

#: instructions one clump runs before the run queue rotates (``gInstrsToExecute``)
INSTRUCTIONS_PER_TURN = 20
#: instructions a slice may run past its budget through turns that end in an event
MAX_OVERRUN = INSTRUCTIONS_PER_TURN


class Scheduler(VMCore):
    """:meth:`run_slice`, the queues' wake-up, and whether the program still runs."""

    @property
    def running(self) -> bool:
        return not self.finished

    def run_slice(self, tick: int) -> bool:
        """Run the program's time slice of millisecond ``tick``; False once it ended.

        Raises :class:`VMError` for a fatal error (the program is then over)."""
        if self.finished:
            return False
        self.tick = tick
        rq = self.runq
        restq = self.restq
        if restq and tick >= self._next_wake:
            self._wake(tick)
        if not rq:
            if restq:
                return True  # every clump sleeps: nothing to run this millisecond
            self.finished = True
            return False
        budget = self.budget
        overrun_end = budget + MAX_OVERRUN
        executed = 0
        code = self._code
        pcs = self.pcs
        solo_ok = self._solo_ok
        spin_from = ((SPIN_SOON if self._spent else SPIN_AFTER) if self._skip_busy_waits
                     else NEVER)
        if spin_from != NEVER:
            self._polled = False
            self._spin.reset()
        try:
            while rq:
                if executed >= spin_from and self._polled:
                    skip = self._spin.check(self, executed, budget)
                    if skip:  # whole cycles of a busy-wait: counted, not run
                        executed += skip
                        self.skipped += skip
                        spin_from = NEVER
                c = rq[0]
                fns, lens, ops = code[c]
                pc = pcs[c]
                # the turn: 20 instructions, fewer when the slice is nearly used up; at
                # least one even past the end of the slice (as after a clump switch).
                # A clump alone in the run queue runs on to the end of the slice: the
                # turn boundaries would hand the CPU back to itself (except that a long
                # slice comes back to them to look for a busy-wait)
                k = budget - executed
                if k < INSTRUCTIONS_PER_TURN:
                    k = k if k > 0 else 1
                elif not solo_ok or len(rq) > 1:
                    k = INSTRUCTIONS_PER_TURN
                elif executed >= spin_from:
                    k = INSTRUCTIONS_PER_TURN if self._polled else min(k, SPIN_AFTER)
                elif k > spin_from - executed:
                    k = spin_from - executed
                left = k
                try:
                    while True:
                        n = lens[pc]
                        if n <= left:
                            nxt = fns[pc]()
                            left -= n
                        else:  # a block longer than the rest of the turn: one instruction
                            nxt = ops[pc]()
                            left -= 1
                        if nxt < 0:
                            break
                        pc = nxt
                        if not left:
                            break
                except Exception as exc:  # a Fault, or anything an instruction let escape
                    ran = 1
                    if lens[pc] <= left and lens[pc] > 1:
                        where = self._fuser.locate(exc.__traceback__)
                        if where is not None:
                            pc, ran = where
                    executed += k - left + ran
                    raise self._abort(c, pc, exc) from (None if isinstance(exc, Fault) else exc)
                executed += k - left
                if nxt >= 0:  # the turn is over (or the slice): rotate
                    pcs[c] = pc
                    if len(rq) > 1 and rq[0] == c:
                        rq.append(rq.pop(0))
                    if executed >= budget:
                        return True
                    continue
                event = self._event
                if event == SUSPEND:
                    pcs[c] = ~nxt
                elif event == DONE:
                    pcs[c] = 0
                    self.fire[c] = self._fire_counts[c]
                elif event == ROTATE:
                    pcs[c] = ~nxt
                    if len(rq) > 1 and rq[0] == c:
                        rq.append(rq.pop(0))
                elif event == STOP:
                    self.finished = True
                    return False
                if executed >= overrun_end:  # every turn ends in an event: yield anyway
                    return True
            if not restq:
                self.finished = True
                return False
            return True
        finally:
            self.instructions += executed
            self._spent = executed >= budget

    def _abort(self, c: int, pc: int, exc: Exception) -> VMError:
        """End the program for ``exc``, raised by the instruction at offset ``pc`` of
        clump ``c``: the :class:`VMError` to raise. A :class:`Fault` is a fatal error the
        firmware has too; anything else is a value the interpreter could not handle,
        and the program stops all the same, with the instruction named."""
        self.finished = True
        where = self.exe.clumps[c].code_start + pc
        if isinstance(exc, Fault):
            message = exc.args[0]
        else:
            message = (f"{self._opname(where)}: the interpreter cannot execute it "
                       f"({type(exc).__name__}: {exc})")
        self.error = VMError(message, pc=where, clump=c)
        return self.error

    def _wake(self, tick: int) -> None:
        """Move the clumps whose wait is over to the run queue, in the rest queue's order."""
        restq = self.restq
        awaken = self.awaken
        for c in list(restq):
            if awaken[c] <= tick:
                restq.remove(c)
                self.runq.append(c)
        self._next_wake = min((awaken[c] for c in restq), default=NEVER)
