"""The NXT bytecode interpreter: clumps, their scheduling, and every instruction.

Scheduling is the firmware's (``cCmdCtrl``, ``cCmdInterpFromClump``): once per
millisecond :meth:`VM.run_slice` wakes the clumps whose ``wait`` has elapsed,
then runs the clump at the head of the run queue for up to 20 instructions,
rotates it to the tail, and so on until the time slice is used up
(``instructions_per_ms``: the emulated CPU's speed) or no clump is runnable.
A clump leaves the run queue when it finishes (``finclump``, its dependents'
fire counts drop and those reaching zero are queued), calls a subroutine
(``subcall``: the callee is queued, the caller resumes at ``subret``), waits
for a mutex or sleeps (``wait``). The program ends when both the run and the
rest queue are empty (clumps blocked on a mutex do not keep it alive), or at
``stop``. A clump alone in the run queue is not stopped every 20 instructions
(the rotation would give the CPU back to it; only ``release`` can queue another
clump in the middle of a turn, so programs that use it always rotate), and a
slice that provably goes round in circles is cut short (:mod:`nxt_link.vm.spin`).

Instructions are compiled once, at load: into closures specialised on their
operands' types (each returns the offset of the next instruction, or a
negative event code), the common ones from source templates; straight-line
runs of them are then fused into one generated function each
(:mod:`nxt_link.vm.fuse`), so that a typical instruction costs a few tens of
nanoseconds. None of this changes what a program does: instruction counts,
turns and slices are the firmware's (tests compare the fused and the plain
interpreter, millisecond by millisecond). Fatal errors the firmware would
abort the program for — an unknown opcode or system call, an array index out
of range, a jump outside the clump, running out of memory — raise
:class:`~nxt_link.vm.errors.VMError` naming the opcode, the program counter
and the clump; nothing is ever skipped silently.
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Any

from nxt_link.vm import poly
from nxt_link.vm.errors import VMError
from nxt_link.vm.fuse import Fuser, Step
from nxt_link.vm.iomap import (
    INPUT_FIELD_TYPES,
    NO_OF_INPUTS,
    NO_OF_OUTPUTS,
    OUTPUT_FIELD_TYPES,
    BrickIO,
    InputField,
    OutputField,
)
from nxt_link.vm.opcodes import OPCODE_NAMES, SHORT_OPCODE_NAMES, SYSCALL_NAMES, TC
from nxt_link.vm.rxe import (
    CLUMP_RECORD_POOL_BYTES,
    POOL_SIZE,
    Executable,
    Instruction,
    decode_clump,
    expected_size,
)
from nxt_link.vm.spin import SPIN_AFTER, SPIN_SOON, SpinDetector
from nxt_link.vm.syscalls import SYSCALLS, SyscallError
from nxt_link.vm.values import (
    INT_TYPES,
    M32,
    SIGNED,
    UNSIGNED,
    DType,
    Mutex,
    copy_value,
    flat_size,
    flatten,
    int_of,
    store,
    to_f32,
    unflatten,
    wrap,
)

__all__ = ["VM", "DEFAULT_INSTRUCTIONS_PER_MS", "INSTRUCTIONS_PER_TURN"]

#: instructions one clump runs before the run queue rotates (``gInstrsToExecute``)
INSTRUCTIONS_PER_TURN = 20
#: instructions the emulated ARM7 gets through in one millisecond slice (an estimate)
DEFAULT_INSTRUCTIONS_PER_MS = 500
NOT_A_DS_ID = 0xFFFF
_NEVER = 1 << 62

# events a closure signals by returning ~resume_index (a negative number)
_DONE, _SUSPEND, _ROTATE, _STOP = 1, 2, 3, 4
Op = Callable[[], int]
# instructions that may not fall through to the next one (they end a fused block):
# JMP, BRCMP, BRTST, STOP, FINCLUMP, FINCLUMPIMMED, ACQUIRE, SUBCALL, SUBRET, WAIT
_LONG_ENDS = frozenset((0x25, 0x26, 0x27, 0x29, 0x2A, 0x2B, 0x2C, 0x2E, 0x2F, 0x34))
_SHORT_ENDS = frozenset((1, 3))  # short ACQUIRE, SUBCALL
# Python operators of the integer binops and the condition codes (for templates)
_BINOP_SYMBOLS = {poly.OP_ADD: "+", poly.OP_SUB: "-", poly.OP_MUL: "*", poly.OP_AND: "&",
                  poly.OP_OR: "|", poly.OP_XOR: "^"}
_CC_SYMBOLS = {0: "<", 1: ">", 2: "<=", 3: ">=", 4: "==", 5: "!="}


class _Fault(Exception):
    """A fatal error inside an instruction; the run loop adds pc and clump."""


def _signed16(v: int) -> int:
    return v - 0x10000 if v & 0x8000 else v


_FLOAT_RE = re.compile(rb"\s*([+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan))",
                       re.IGNORECASE)


class VM:
    """One activation of a program.

    Args:
        exe: the loaded executable.
        io: the brick around the VM (:class:`~nxt_link.vm.iomap.BrickIO`).
        start_tick: the millisecond tick the program starts at.
        instructions_per_ms: size of the millisecond time slice; ``None``: run
            until every clump waits (an infinitely fast CPU, for comparing the
            program with a model that takes no time), at most
            ``1_000_000`` instructions per slice.
        fused: run straight-line code as fused blocks (:mod:`nxt_link.vm.fuse`);
            False: one instruction at a time. The results are the same.
        skip_busy_waits: count the whole cycles of a slice that provably goes
            round in circles without running them (:mod:`nxt_link.vm.spin`);
            the results are the same.

    Attributes:
        instructions: instructions the program has executed, as the brick counts
            them (busy-wait cycles included).
        skipped: how many of them were counted without being run.
    """

    def __init__(self, exe: Executable, io: BrickIO, *, start_tick: int = 0,
                 instructions_per_ms: int | None = DEFAULT_INSTRUCTIONS_PER_MS,
                 fused: bool = True, skip_busy_waits: bool = True) -> None:
        self.exe = exe
        self.io = io
        self.types = exe.types
        self.start_tick = start_tick
        self.tick = start_tick
        self.budget = 1_000_000 if instructions_per_ms is None else max(1, instructions_per_ms)
        self.mem: list[Any] = [None] * len(exe.types)
        for i, v in exe.initial_values().items():
            self.mem[i] = v
        self._addressable = set(exe.slots) | {i for i in exe.top_level
                                              if exe.types[i].tc == TC.CLUSTER}
        self._add_cluster_members()
        n = len(exe.clumps)
        self.fire = [c.fire_count for c in exe.clumps]
        self._fire_counts = tuple(self.fire)
        self.pcs = [0] * n
        self.runq: list[int] = [c.index for c in exe.clumps if c.fire_count == 0]
        self.restq: list[int] = []
        self.awaken = [0] * n
        self._next_wake = _NEVER  # earliest wake-up time in the rest queue
        #: counts the instructions that changed something outside the VM's memory
        self.io_epoch = 0
        self._polled = False  # this slice read the tick, a port or a read-only syscall
        self._spin = SpinDetector()
        self._skip_busy_waits = skip_busy_waits and self.budget > SPIN_AFTER
        self._spent = False  # the last slice used up its budget
        self.skipped = 0
        self.instructions = 0
        self.finished = False
        self.error: VMError | None = None
        self.array_bytes: dict[int, int] = {}
        pool = n * CLUMP_RECORD_POOL_BYTES
        pool += (-pool) % 4
        self._fixed_bytes = pool + exe.static_size
        self.memory_used = 0
        for i in exe.slots:
            if exe.types[i].tc == TC.ARRAY:
                self._account(i, self.mem[i])
        self._event_pc = 0
        self._event = 0
        self._fuser = Fuser({"m": self.mem, "vm": self, "wrap": wrap, "store": store,
                             "s32": poly.s32, "int_of": int_of, "index_fault": _index_fault,
                             "port_fault": _port_fault, "io_get": io.output_get,
                             "io_set": io.output_set})
        compiled = [self._compile_clump(c.index) for c in exe.clumps]
        self.ops: list[list[Op]] = [ops for ops, _ in compiled]
        self.fused = fused
        # only RELEASE adds a clump to the run queue in the middle of a turn; without
        # it, a clump alone in the queue stays alone until its turn ends with an event
        self._solo_ok = not any(ins.opcode == (2 if ins.short else 0x2D)
                                for c in exe.clumps for ins in decode_clump(exe.code, c))
        fns, lens = self._fuser.build(compiled, blocks=fused)
        #: per clump: block functions (or instructions) and lengths by offset, instructions
        self._code = [(f, n, ops) for f, n, ops in zip(fns, lens, self.ops)]

    def _add_cluster_members(self) -> None:
        """Members of top-level clusters are addressable (they are top-level storage)."""
        def walk(t: DType) -> None:
            for m in t.members:
                self._addressable.add(m.index)
                if m.tc == TC.CLUSTER:
                    walk(m)
        for i in self.exe.top_level:
            if self.types[i].tc == TC.CLUSTER:
                walk(self.types[i])

    # -- values of addressable entries ----------------------------------------------------

    def get(self, i: int) -> Any:
        """The value of dataspace entry ``i`` (a cluster: a list of its members)."""
        t = self.types[i]
        if t.tc == TC.CLUSTER:
            return [self.get(m.index) for m in t.members]
        return self.mem[i]

    def set(self, i: int, v: Any) -> None:
        t = self.types[i]
        if t.tc == TC.CLUSTER:
            for m, e in zip(t.members, v):
                self.set(m.index, e)
        elif t.tc == TC.ARRAY:
            self._account(i, v)
            self.mem[i] = v
        else:
            self.mem[i] = v

    def _account(self, i: int, v: Any) -> None:
        """Pool bytes of the top-level arrays; beyond the 32 KB pool: ERR_MEM."""
        t = self.types[i]
        size = len(v) * t.elem_size
        size += (-size) % 4
        old = self.array_bytes.get(i, 0)
        if size != old:
            used = self.memory_used - old + size
            if used + self._fixed_bytes > POOL_SIZE and size > old:
                raise _Fault(f"out of memory: {used + self._fixed_bytes} bytes needed, the "
                             f"brick's pool has {POOL_SIZE} (array at dataspace entry {i}, "
                             f"{len(v)} elements)")
            self.array_bytes[i] = size
            self.memory_used = used

    def variables(self) -> dict[int, Any]:
        """Current values of every storage slot (inspection, tests)."""
        return {i: self.mem[i] for i in self.exe.slots}

    # -- scheduling -----------------------------------------------------------------------

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
        executed = 0
        code = self._code
        pcs = self.pcs
        solo_ok = self._solo_ok
        spin_from = ((SPIN_SOON if self._spent else SPIN_AFTER) if self._skip_busy_waits
                     else _NEVER)
        if spin_from != _NEVER:
            self._polled = False
            self._spin.reset()
        try:
            while rq:
                if executed >= spin_from and self._polled:
                    skip = self._spin.check(self, executed, budget)
                    if skip:  # whole cycles of a busy-wait: counted, not run
                        executed += skip
                        self.skipped += skip
                        spin_from = _NEVER
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
                except _Fault as f:
                    ran = 1
                    if lens[pc] <= left and lens[pc] > 1:
                        where = self._fuser.locate(f.__traceback__)
                        if where is not None:
                            pc, ran = where
                    executed += k - left + ran
                    self.finished = True
                    self.error = VMError(f.args[0], pc=self.exe.clumps[c].code_start + pc, clump=c)
                    raise self.error from None
                executed += k - left
                if nxt >= 0:  # the turn is over (or the slice): rotate
                    pcs[c] = pc
                    if len(rq) > 1 and rq[0] == c:
                        rq.append(rq.pop(0))
                    if executed >= budget:
                        return True
                    continue
                event = self._event
                if event == _SUSPEND:
                    pcs[c] = ~nxt
                elif event == _DONE:
                    pcs[c] = 0
                    self.fire[c] = self._fire_counts[c]
                elif event == _ROTATE:
                    pcs[c] = ~nxt
                    if len(rq) > 1 and rq[0] == c:
                        rq.append(rq.pop(0))
                elif event == _STOP:
                    self.finished = True
                    return False
            if not restq:
                self.finished = True
                return False
            return True
        finally:
            self.instructions += executed
            self._spent = executed >= budget

    def _wake(self, tick: int) -> None:
        """Move the clumps whose wait is over to the run queue, in the rest queue's order."""
        restq = self.restq
        awaken = self.awaken
        for c in list(restq):
            if awaken[c] <= tick:
                restq.remove(c)
                self.runq.append(c)
        self._next_wake = min((awaken[c] for c in restq), default=_NEVER)

    def _enqueue(self, c: int) -> None:
        if c in self.runq:
            raise _Fault(f"clump {c} scheduled while it is already running (a subroutine "
                         f"called by two tasks at once, or recursion)")
        self.runq.append(c)

    def _sched_dependents(self, c: int, begin: int, end: int) -> None:
        deps = self.exe.clumps[c].dependents
        if begin == -1 and end == -1:
            return
        if not (0 <= begin <= end < len(deps)):
            raise _Fault(f"FINCLUMP: dependents {begin}..{end} of clump {c}, which has "
                         f"{len(deps)}")
        for k in range(begin, end + 1):
            self._fire(deps[k])

    def _fire(self, target: int) -> None:
        self.fire[target] -= 1
        if self.fire[target] == 0:
            self._enqueue(target)

    # -- compilation -------------------------------------------------------------------------

    def _compile_clump(self, c: int) -> tuple[list[Op], list[Step]]:
        """The clump's closures by word offset, and its instructions in order."""
        clump = self.exe.clumps[c]
        length = clump.code_end - clump.code_start + 1
        ops: list[Op] = [_raiser("jump into the middle of an instruction")] * (length + 1)
        ops[length] = _raiser(f"ran past the end of clump {c}")
        steps: list[Step] = []
        for ins in decode_clump(self.exe.code, clump):
            local = ins.pc - clump.code_start
            ends = ins.opcode in (_SHORT_ENDS if ins.short else _LONG_ENDS)
            targets: tuple[int, ...] = ()
            if not ins.short and ins.opcode in (0x25, 0x26, 0x27) and ins.args:
                targets = (local + _signed16(ins.args[0]),)
            goto = targets[0] if not ins.short and ins.opcode == 0x25 and targets else None
            try:
                ops[local] = self._compile(ins, local, length, c)
            except _Fault as f:
                ops[local] = _raiser(f.args[0])
                ends, goto = True, None
            steps.append(Step(local, local + ins.words, ops[local], ends, targets, goto))
        return ops, steps

    def _target(self, local: int, offset: int, length: int, name: str) -> int:
        t = local + _signed16(offset)
        if not 0 <= t < length:
            raise _Fault(f"{name}: jump by {_signed16(offset)} words leaves the clump")
        return t

    def _arg(self, i: int, name: str, what: str = "argument") -> int:
        if i >= len(self.types):
            raise _Fault(f"{name}: {what} refers to dataspace entry {i}, the program has "
                         f"{len(self.types)}")
        if i not in self._addressable:
            raise _Fault(f"{name}: {what} refers to dataspace entry {i}, which is part of an "
                         f"array element type")
        return i

    def _scalar_arg(self, i: int, name: str) -> int:
        self._arg(i, name)
        t = self.types[i]
        if not t.is_scalar:
            raise _Fault(f"{name}: dataspace entry {i} is a {t.name}, a scalar is needed")
        return i

    def _int_reader(self, i: int, name: str) -> Callable[[], int]:
        """A getter of the 32-bit integer value of a scalar argument (or 0 if unwired)."""
        m = self.mem
        if i == NOT_A_DS_ID:
            return lambda: 0
        self._scalar_arg(i, name)
        tc = self.types[i].tc
        if tc == TC.FLOAT:
            return lambda: int_of(TC.FLOAT, m[i])
        return lambda: m[i]

    def _int_src(self, i: int, name: str) -> str:
        """:meth:`_int_reader` as an expression of a template."""
        self._int_reader(i, name)
        if i == NOT_A_DS_ID:
            return "0"
        if self.types[i].tc == TC.FLOAT:
            return f"int_of({TC.FLOAT}, m[{i}])"
        return f"m[{i}]"

    def _compile(self, ins: Instruction, local: int, length: int, c: int) -> Op:
        if ins.error:
            raise _Fault(ins.error)
        nxt = local + ins.words
        if ins.short:
            name = SHORT_OPCODE_NAMES[ins.opcode]
            if ins.opcode == 0:
                return self._mov(ins.args[0], ins.args[1], nxt, "MOV")
            if ins.opcode == 1:
                return self._acquire(ins.args[0], nxt)
            if ins.opcode == 2:
                return self._release(ins.args[0], nxt)
            return self._subcall(ins.args[0], ins.args[1], nxt, name)
        op = ins.opcode
        if op not in OPCODE_NAMES:
            raise _Fault(f"unknown opcode 0x{op:02X}")
        name = OPCODE_NAMES[op]
        size = expected_size(op)
        if size is False or (size is not None and size != 2 * ins.words):
            raise _Fault(f"opcode 0x{op:02X} ({name}) is not an instruction of firmware 1.28 "
                         f"with {ins.words - 1} argument words")
        a = ins.args
        cc = ins.cc
        if op in (0x00, 0x01, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08):
            return self._binop(op, a[0], a[1], a[2], nxt, name)
        if op == 0x11:
            return self._cmp(cc, a[0], a[1], a[2], nxt)
        if op in (0x02, 0x09, 0x12, 0x36, 0x37):
            return self._unop(op, cc, a[0], a[1], nxt, name)
        if op == 0x1B:
            return self._mov(a[0], a[1], nxt, name)
        if op == 0x1C:
            return self._set(a[0], a[1], nxt)
        if op == 0x25:
            return self._fuser.template(f"return {self._target(local, a[0], length, name)}")
        if op == 0x27:
            return self._brtst(cc, self._target(local, a[0], length, name), a[1], nxt)
        if op == 0x26:
            return self._brcmp(cc, self._target(local, a[0], length, name), a[1], a[2], nxt)
        if op == 0x2A:
            return self._finclump(c, _signed16(a[0]), _signed16(a[1]))
        if op == 0x2B:
            return self._finclumpimmed(c, a[0])
        if op == 0x2E:
            return self._subcall(a[0], a[1], nxt, name)
        if op == 0x2F:
            return self._subret(a[0])
        if op == 0x2C:
            return self._acquire(a[0], nxt)
        if op == 0x2D:
            return self._release(a[0], nxt)
        if op == 0x29:
            return self._stop(a[0], nxt)
        if op == 0x35:
            return self._gettick(a[0], nxt)
        if op == 0x34:
            return self._wait(a[0], a[1], nxt)
        if op == 0x17:
            return self._arrsize(a[0], a[1], nxt)
        if op == 0x15:
            return self._index(a[0], a[1], a[2], nxt)
        if op == 0x16:
            return self._replace(a[0], a[1], a[2], a[3], nxt)
        if op == 0x1A:
            return self._arrinit(a[0], a[1], a[2], nxt)
        if op == 0x19:
            return self._arrsubset(a[0], a[1], a[2], a[3], nxt)
        if op == 0x18:
            return self._arrbuild(a[1], a[2:], nxt)
        if op == 0x21:
            return self._strcat(a[1], a[2:], nxt)
        if op == 0x22:
            return self._strsubset(a[0], a[1], a[2], a[3], nxt)
        if op == 0x23:
            return self._strtobytearr(a[0], a[1], nxt)
        if op == 0x24:
            return self._bytearrtostr(a[0], a[1], nxt)
        if op == 0x1F:
            return self._numtostring(a[0], a[1], nxt)
        if op == 0x20:
            return self._stringtonum(a[0], a[1], a[2], a[3], a[4], nxt)
        if op == 0x1D:
            return self._flatten(a[0], a[1], nxt)
        if op == 0x1E:
            return self._unflatten(a[0], a[1], a[2], a[3], nxt)
        if op == 0x28:
            return self._syscall(a[0], a[1], nxt)
        if op == 0x30:
            return self._setin(a[0], a[1], a[2], nxt)
        if op == 0x32:
            return self._getin(a[0], a[1], a[2], nxt)
        if op == 0x33:
            return self._getout(a[0], a[1], a[2], nxt)
        if op == 0x31:
            return self._setout(a[1], a[2:], nxt)
        raise _Fault(f"opcode 0x{op:02X} ({name}) is not implemented by firmware 1.28")

    # -- math, logic, comparison ----------------------------------------------------------------

    def _binop(self, op: int, d: int, a: int, b: int, nxt: int, name: str) -> Op:
        for x in (d, a, b):
            self._arg(x, name)
        m = self.mem
        td, ta, tb = self.types[d], self.types[a], self.types[b]
        if td.tc in INT_TYPES and ta.tc in INT_TYPES and tb.tc in INT_TYPES:
            dt = td.tc
            sym = _BINOP_SYMBOLS.get(op)
            if sym is not None and dt == TC.SLONG:
                return self._fuser.template(
                    f"v = (m[{a}] {sym} m[{b}]) & 0xFFFFFFFF\n"
                    f"m[{d}] = v - 0x100000000 if v & 0x80000000 else v")
            if sym is not None:
                return self._fuser.template(_wrap_src(dt, f"m[{a}] {sym} m[{b}]", f"m[{d}]"))
            signed = ta.tc in SIGNED and tb.tc in SIGNED
            if op == poly.OP_DIV and signed and dt == TC.SLONG:
                return self._fuser.template(
                    f"y = m[{b}]\n"
                    f"if y == 0:\n"
                    f"    m[{d}] = 0\n"
                    f"else:\n"
                    f"    x = m[{a}]\n"
                    f"    q = abs(x) // abs(y)\n"
                    f"    if (x < 0) != (y < 0):\n"
                    f"        q = -q\n"
                    f"    m[{d}] = q - 0x100000000 if q >= 0x80000000 else q")
            tat, tbt = ta.tc, tb.tc

            def f() -> int:
                m[d] = wrap(dt, poly.int_binop(op, 0, m[a], m[b], tat, tbt))
                return nxt
            return f
        get_a, get_b = self._getter(a), self._getter(b)
        set_d = self._setter(d)

        def g() -> int:
            try:
                set_d(poly.poly_binop(op, 0, td, ta, tb, get_a(), get_b()))
            except poly.PolyError as exc:
                raise _Fault(f"{name}: {exc}") from None
            return nxt
        return g

    def _cmp(self, cc: int, d: int, a: int, b: int, nxt: int) -> Op:
        for x in (d, a, b):
            self._arg(x, "CMP")
        td, ta, tb = self.types[d], self.types[a], self.types[b]
        if td.tc in INT_TYPES and ta.tc in INT_TYPES and tb.tc in INT_TYPES:
            # typed values compare as they are, except that an unsigned comparison
            # reads a signed side as its 32-bit pattern; 1 and 0 fit every type
            sym = _CC_SYMBOLS.get(cc)
            if sym is None:
                return self._fuser.template(f"m[{d}] = 0")
            if ta.tc in UNSIGNED or tb.tc in UNSIGNED:
                return self._fuser.template(
                    f"m[{d}] = 1 if (m[{a}] & 0xFFFFFFFF) {sym} (m[{b}] & 0xFFFFFFFF) else 0")
            return self._fuser.template(f"m[{d}] = 1 if m[{a}] {sym} m[{b}] else 0")
        get_a, get_b = self._getter(a), self._getter(b)
        set_d = self._setter(d)
        agg = not ta.is_scalar and not tb.is_scalar and td.is_scalar

        def g() -> int:
            try:
                if agg:
                    set_d(store(td.tc, poly.compare_aggregates(cc, ta, tb, get_a(), get_b())))
                else:
                    set_d(poly.poly_binop(poly.OP_CMP, cc, td, ta, tb, get_a(), get_b()))
            except poly.PolyError as exc:
                raise _Fault(f"CMP: {exc}") from None
            return nxt
        return g

    def _unop(self, op: int, cc: int, d: int, s: int, nxt: int, name: str) -> Op:
        self._arg(d, name)
        self._arg(s, name)
        m = self.mem
        td, ts = self.types[d], self.types[s]
        if td.tc in INT_TYPES and ts.tc in INT_TYPES:
            # poly.int_unop on a typed integer value, stored with a wrap
            dt = td.tc
            if op == poly.OP_NOT:
                return self._fuser.template(f"m[{d}] = 0 if m[{s}] & 0xFFFFFFFF else 1")
            if op == poly.OP_NEG:
                return self._fuser.template(_wrap_src(dt, f"-s32(m[{s}])", f"m[{d}]"))
            if op == poly.OP_ABS:
                return self._fuser.template(_wrap_src(dt, f"abs(s32(m[{s}]))", f"m[{d}]"))
            if op == poly.OP_TST:
                sym = _CC_SYMBOLS.get(cc)
                if sym is None:
                    return self._fuser.template(f"m[{d}] = 0")
                v = f"(m[{s}] & 0xFFFFFFFF)" if ts.tc in UNSIGNED else f"s32(m[{s}])"
                return self._fuser.template(f"m[{d}] = 1 if {v} {sym} 0 else 0")
        if td.is_scalar and ts.is_scalar:
            def g() -> int:
                m[d] = poly.poly_unop(op, cc, td, ts, m[s])
                return nxt
            return g
        get_s, set_d = self._getter(s), self._setter(d)

        def h() -> int:
            try:
                set_d(poly.poly_unop(op, cc, td, ts, get_s()))
            except poly.PolyError as exc:
                raise _Fault(f"{name}: {exc}") from None
            return nxt
        return h

    # -- data manipulation ------------------------------------------------------------------

    def _getter(self, i: int) -> Callable[[], Any]:
        m = self.mem
        if self.types[i].tc == TC.CLUSTER:
            return lambda: self.get(i)
        return lambda: m[i]

    def _setter(self, i: int) -> Callable[[Any], None]:
        m = self.mem
        t = self.types[i]
        if t.tc == TC.CLUSTER or t.tc == TC.ARRAY:
            return lambda v: self._set_checked(i, v)

        def s(v: Any) -> None:
            m[i] = v
        return s

    def _set_checked(self, i: int, v: Any) -> None:
        self.set(i, v)

    def _mov(self, d: int, s: int, nxt: int, name: str) -> Op:
        self._arg(d, name)
        self._arg(s, name)
        m = self.mem
        td, ts = self.types[d], self.types[s]
        if td.tc in INT_TYPES and ts.tc in INT_TYPES:
            dt = td.tc
            if td.tc == ts.tc or (td.tc == TC.SLONG and ts.tc in (TC.UBYTE, TC.SBYTE, TC.UWORD,
                                                                   TC.SWORD)):
                return self._fuser.template(f"m[{d}] = m[{s}]")
            if dt == TC.UBYTE:
                return self._fuser.template(f"m[{d}] = m[{s}] & 0xFF")
            if dt == TC.ULONG:
                return self._fuser.template(f"m[{d}] = m[{s}] & 0xFFFFFFFF")
            if dt == TC.SLONG:  # from a ulong
                return self._fuser.template(
                    f"v = m[{s}]\nm[{d}] = v - 0x100000000 if v & 0x80000000 else v")
            return self._fuser.template(_wrap_src(dt, f"m[{s}]", f"m[{d}]"))
        if td.tc == TC.FLOAT and ts.tc == TC.FLOAT:
            return self._fuser.template(f"m[{d}] = m[{s}]")
        if td.tc == TC.ARRAY and ts.tc == TC.ARRAY and td.string and ts.string:
            def k() -> int:
                v = bytearray(m[s])
                self._account(d, v)
                m[d] = v
                return nxt
            return k
        get_s, set_d = self._getter(s), self._setter(d)

        def gen() -> int:
            try:
                set_d(poly.convert(td, ts, get_s()))
            except poly.PolyError as exc:
                raise _Fault(f"{name}: {exc}") from None
            return nxt
        return gen

    def _set(self, d: int, imm: int, nxt: int) -> Op:
        self._scalar_arg(d, "SET")
        m = self.mem
        v = store(self.types[d].tc, imm)
        if isinstance(v, int):
            return self._fuser.template(f"m[{d}] = {v}")

        def f() -> int:
            m[d] = v
            return nxt
        return f

    def _arrsize(self, d: int, s: int, nxt: int) -> Op:
        self._scalar_arg(d, "ARRSIZE")
        self._array_arg(s, "ARRSIZE")
        return self._fuser.template(f"m[{d}] = store({self.types[d].tc}, len(m[{s}]))")

    def _array_arg(self, i: int, name: str, string: bool = False) -> DType:
        self._arg(i, name)
        t = self.types[i]
        if t.tc != TC.ARRAY or (string and not t.string):
            raise _Fault(f"{name}: dataspace entry {i} is a {t.name}, "
                         f"{'a string' if string else 'an array'} is needed")
        return t

    def _index(self, d: int, s: int, i: int, nxt: int) -> Op:
        self._arg(d, "INDEX")
        ts = self._array_arg(s, "INDEX")
        idx = self._int_reader(i, "INDEX")
        m = self.mem
        td = self.types[d]
        te = ts.elem
        assert te is not None
        if td.tc in INT_TYPES and te.tc in INT_TYPES:
            dt = td.tc
            same = dt == te.tc or dt == TC.SLONG and te.tc != TC.ULONG
            return self._fuser.template(
                f"k = {self._int_src(i, 'INDEX')} & 0xFFFFFFFF\n"
                f"arr = m[{s}]\n"
                f"if k >= len(arr):\n"
                f"    index_fault(k, {s}, arr)\n"
                + (f"m[{d}] = arr[k]" if same else _wrap_src(dt, "arr[k]", f"m[{d}]")))
        set_d = self._setter(d)

        def g() -> int:
            k = idx() & M32
            arr = m[s]
            if k >= len(arr):
                _index_fault(k, s, arr)
            try:
                set_d(poly.convert(td, te, copy_value(te, arr[k])))
            except poly.PolyError as exc:
                raise _Fault(f"INDEX: {exc}") from None
            return nxt
        return g

    def _replace(self, d: int, s: int, i: int, v: int, nxt: int) -> Op:
        td = self._array_arg(d, "REPLACE")
        ts = self._array_arg(s, "REPLACE")
        self._arg(v, "REPLACE")
        idx = self._int_reader(i, "REPLACE")
        m = self.mem
        tv = self.types[v]
        te = td.elem
        assert te is not None
        get_v = self._getter(v)
        copy = d != s
        if te.tc in INT_TYPES and tv.tc in INT_TYPES:
            et = te.tc
            same = et == tv.tc
            if not copy:
                return self._fuser.template(
                    f"arr = m[{d}]\n"
                    f"k = {self._int_src(i, 'REPLACE')} & 0xFFFFFFFF\n"
                    f"if k < len(arr):\n"
                    + (f"    arr[k] = m[{v}]" if same
                       else _indent(_wrap_src(et, f"m[{v}]", "arr[k]"))))

            def f() -> int:
                if copy:
                    new = poly.convert(td, ts, m[s])
                    self._account(d, new)
                    m[d] = new
                arr = m[d]
                k = idx() & M32
                if k < len(arr):
                    arr[k] = m[v] if same else wrap(et, m[v])
                return nxt
            return f

        def g() -> int:
            try:
                if copy:
                    new = poly.convert(td, ts, m[s])
                    self._account(d, new)
                    m[d] = new
                arr = m[d]
                k = idx() & M32
                n = len(arr)
                if k >= n:
                    return nxt
                val = get_v()
                if tv.tc != TC.ARRAY or _same_type(te, tv):
                    # one new element (an array replacing a row of an array of arrays,
                    # which firmware 1.29's code would treat as a list of elements)
                    arr[k] = poly.convert(te, tv, copy_value(tv, val))
                else:
                    assert tv.elem is not None
                    for j in range(min(n - k, len(val))):
                        arr[k + j] = poly.convert(te, tv.elem, copy_value(tv.elem, val[j]))
            except poly.PolyError as exc:
                raise _Fault(f"REPLACE: {exc}") from None
            return nxt
        return g

    def _arrinit(self, d: int, v: int, n: int, nxt: int) -> Op:
        td = self._array_arg(d, "ARRINIT")
        self._arg(v, "ARRINIT")
        count = self._int_reader(n, "ARRINIT")
        m = self.mem
        tv = self.types[v]
        te = td.elem
        assert te is not None
        get_v = self._getter(v)

        def f() -> int:
            k = count() & 0xFFFF
            val = get_v()
            try:
                if tv.tc in INT_TYPES:
                    e = store(te.tc, val) if te.is_scalar else None
                    if e is None:
                        raise _Fault(f"ARRINIT: {te.name} elements from a {tv.name}")
                    new: Any = bytearray([e]) * k if td.string else [e] * k
                elif te.is_scalar:
                    e = poly.convert(te, tv, val)
                    new = bytearray([e]) * k if td.string else [e] * k
                else:
                    e = poly.convert(te, tv, val)
                    new = [copy_value(te, e) for _ in range(k)]
            except poly.PolyError as exc:
                raise _Fault(f"ARRINIT: {exc}") from None
            self._account(d, new)
            m[d] = new
            return nxt
        return f

    def _arrsubset(self, d: int, s: int, i: int, n: int, nxt: int) -> Op:
        td = self._array_arg(d, "ARRSUBSET")
        ts = self._array_arg(s, "ARRSUBSET")
        idx = self._int_reader(i, "ARRSUBSET")
        length = None if n == NOT_A_DS_ID else self._int_reader(n, "ARRSUBSET")
        m = self.mem

        def f() -> int:
            src = m[s]
            k = idx() & M32
            if k > len(src):
                part = src[:0]
            else:
                cnt = len(src) - k
                if length is not None:
                    cnt = min(cnt, length() & M32)
                part = src[k:k + cnt]
            try:
                new = poly.convert(td, ts, part)
            except poly.PolyError as exc:
                raise _Fault(f"ARRSUBSET: {exc}") from None
            self._account(d, new)
            m[d] = new
            return nxt
        return f

    def _arrbuild(self, d: int, srcs: tuple[int, ...], nxt: int) -> Op:
        td = self._array_arg(d, "ARRBUILD")
        te = td.elem
        assert te is not None
        parts = []
        for s in srcs:
            self._arg(s, "ARRBUILD")
            ts = self.types[s]
            # a source of the destination's type is an array to append, anything else
            # one element (converted like a move: NBC passes constants of any size)
            parts.append((_same_type(td, ts), self._getter(s), ts))
        m = self.mem

        def f() -> int:
            out: list[Any] = []
            try:
                for whole, get, ts in parts:
                    if whole:
                        out.extend(copy_value(ts, get()))
                    else:
                        out.append(poly.convert(te, ts, copy_value(ts, get())))
            except poly.PolyError as exc:
                raise _Fault(f"ARRBUILD: {exc}") from None
            new = bytearray(out) if td.string else out
            self._account(d, new)
            m[d] = new
            return nxt
        return f

    # -- strings -------------------------------------------------------------------------

    def _strcat(self, d: int, srcs: tuple[int, ...], nxt: int) -> Op:
        self._array_arg(d, "STRCAT", string=True)
        for s in srcs:
            self._array_arg(s, "STRCAT", string=True)
        m = self.mem

        def f() -> int:
            out = bytearray()
            for s in srcs:
                v = m[s]
                out += v[:-1] if v else v
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _strsubset(self, d: int, s: int, i: int, n: int, nxt: int) -> Op:
        self._array_arg(d, "STRSUBSET", string=True)
        self._array_arg(s, "STRSUBSET", string=True)
        idx = self._int_reader(i, "STRSUBSET")
        length = None if n == NOT_A_DS_ID else self._int_reader(n, "STRSUBSET")
        m = self.mem

        def f() -> int:
            src = m[s]
            count = max(0, len(src) - 1)
            k = idx() & M32
            if k > count:
                out = bytearray(b"\0")
            else:
                cnt = count - k
                if length is not None:
                    cnt = min(cnt, length() & M32)
                out = bytearray(src[k:k + cnt])
                out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _strtobytearr(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "STRTOBYTEARR", string=True)
        self._array_arg(s, "STRTOBYTEARR", string=True)
        m = self.mem

        def f() -> int:
            src = m[s]
            if src:
                out = bytearray(src[:-1])
                self._account(d, out)
                m[d] = out
            return nxt
        return f

    def _bytearrtostr(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "BYTEARRTOSTR", string=True)
        self._array_arg(s, "BYTEARRTOSTR", string=True)
        m = self.mem

        def f() -> int:
            out = bytearray(m[s])
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _numtostring(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "NUMTOSTRING", string=True)
        self._scalar_arg(s, "NUMTOSTRING")
        m = self.mem
        ts = self.types[s].tc

        def f() -> int:
            v = m[s]
            if ts == TC.FLOAT:
                text = _format_float(v)
            elif ts in SIGNED:
                text = str(v)
            else:
                text = str(v & M32)
            out = bytearray(text.encode("ascii"))
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _stringtonum(self, d: int, past: int, s: int, off: int, dflt: int, nxt: int) -> Op:
        self._scalar_arg(d, "STRINGTONUM")
        self._scalar_arg(past, "STRINGTONUM")
        self._array_arg(s, "STRINGTONUM", string=True)
        offset = self._int_reader(off, "STRINGTONUM")
        default = self._int_reader(dflt, "STRINGTONUM")
        m = self.mem
        td, tp = self.types[d].tc, self.types[past].tc

        def f() -> int:
            text = bytes(m[s])
            nul = text.find(b"\0")
            if nul >= 0:
                text = text[:nul]
            k = offset() & M32
            match = _FLOAT_RE.match(text, k) if k <= len(text) else None
            if match:
                value = to_f32(float(match.group(1)))
                i = k
                while i < len(text) and not 0x30 <= text[i] <= 0x39:
                    i += 1
                dot = False
                while i < len(text):
                    ch = text[i]
                    if 0x30 <= ch <= 0x39:
                        i += 1
                    elif ch == 0x2E and not dot:
                        dot = True
                        i += 1
                    else:
                        break
                end = i
            else:
                value = to_f32(float(default()))
                end = 0
            m[d] = store(td, value)
            m[past] = store(tp, end)
            return nxt
        return f

    def _flatten(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "FLATTEN", string=True)
        self._arg(s, "FLATTEN")
        ts = self.types[s]
        get_s = self._getter(s)
        m = self.mem

        def f() -> int:
            out = bytearray()
            flatten(ts, get_s(), out)
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _unflatten(self, d: int, err: int, s: int, tmpl: int, nxt: int) -> Op:
        self._arg(d, "UNFLATTEN")
        self._scalar_arg(err, "UNFLATTEN")
        self._array_arg(s, "UNFLATTEN", string=True)
        self._arg(tmpl, "UNFLATTEN")
        td, tt = self.types[d], self.types[tmpl]
        get_t, set_d = self._getter(tmpl), self._setter(d)
        m = self.mem
        et = self.types[err].tc

        def f() -> int:
            template = get_t()
            try:
                value = poly.convert(td, tt, copy_value(tt, template))
            except poly.PolyError as exc:
                raise _Fault(f"UNFLATTEN: {exc}") from None
            data = bytes(m[s])
            n = max(0, len(data) - 1)
            if n == flat_size(td, value):
                value, _ = unflatten(td, value, data, 0)
                m[err] = store(et, 0)
            else:
                m[err] = store(et, 1)
            set_d(value)
            return nxt
        return f

    # -- control flow ------------------------------------------------------------------------

    def _brtst(self, cc: int, target: int, s: int, nxt: int) -> Op:
        if s == NOT_A_DS_ID:
            taken = cc in (4, 2, 3)
            return self._fuser.template(f"return {target if taken else nxt}")
        self._scalar_arg(s, "BRTST")
        ts = self.types[s].tc
        if ts in INT_TYPES:
            # the value as a signed 32-bit integer against 0 (the typed value itself,
            # except for an ulong)
            sym = _CC_SYMBOLS.get(cc)
            if sym is None:
                return self._fuser.template(f"return {nxt}")
            v = f"s32(m[{s}])" if ts == TC.ULONG else f"m[{s}]"
            return self._fuser.template(f"return {target} if {v} {sym} 0 else {nxt}")
        rd = self._int_reader(s, "BRTST")

        def g() -> int:
            v = poly.s32(rd())
            return target if poly._cc(cc, v, 0) else nxt
        return g

    def _brcmp(self, cc: int, target: int, a: int, b: int, nxt: int) -> Op:
        self._arg(a, "BRCMP")
        self._arg(b, "BRCMP")
        ta, tb = self.types[a], self.types[b]
        if ta.tc in INT_TYPES and tb.tc in INT_TYPES:
            # poly.compare_int: unsigned as soon as one side is unsigned
            sym = _CC_SYMBOLS.get(cc)
            if sym is None:
                return self._fuser.template(f"return {nxt}")
            if ta.tc in UNSIGNED or tb.tc in UNSIGNED:
                cond = f"(m[{a}] & 0xFFFFFFFF) {sym} (m[{b}] & 0xFFFFFFFF)"
            else:
                cond = f"m[{a}] {sym} m[{b}]"
            return self._fuser.template(f"return {target} if {cond} else {nxt}")
        if ta.is_scalar and tb.is_scalar:
            ra, rb = self._int_reader(a, "BRCMP"), self._int_reader(b, "BRCMP")
            tat, tbt = ta.tc, tb.tc

            def f() -> int:
                return target if poly.compare_int(cc, ra(), rb(), tat, tbt) else nxt
            return f
        get_a, get_b = self._getter(a), self._getter(b)

        def g() -> int:
            try:
                r = poly.compare_aggregates(cc, ta, tb, get_a(), get_b())
            except poly.PolyError as exc:
                raise _Fault(f"BRCMP: {exc}") from None
            return target if r else nxt
        return g

    def _finclump(self, c: int, begin: int, end: int) -> Op:
        def f() -> int:
            self._dequeue_head(c)
            self._sched_dependents(c, begin, end)
            self._event = _DONE
            return -1
        return f

    def _finclumpimmed(self, c: int, target: int) -> Op:
        if target >= len(self.exe.clumps):
            raise _Fault(f"FINCLUMPIMMED: clump {target} does not exist")

        def f() -> int:
            self._dequeue_head(c)
            self._fire(target)
            self._event = _DONE
            return -1
        return f

    def _dequeue_head(self, c: int) -> None:
        if self.runq and self.runq[0] == c:
            self.runq.pop(0)
        else:
            self.runq.remove(c)

    def _subcall(self, callee: int, ret: int, nxt: int, name: str) -> Op:
        if callee >= len(self.exe.clumps):
            raise _Fault(f"{name}: clump {callee} does not exist")
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
                raise _Fault(f"{name}: subroutine clump {callee} called while it is already "
                             f"running (recursion, or two tasks calling it at once)")
            rq.append(callee)
            self._event = _SUSPEND
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
                raise _Fault(f"SUBRET: return to clump {caller}, which does not exist")
            if caller in rq:
                self._enqueue(caller)  # the error
            rq.append(caller)
            self._event = _DONE
            return -1
        return f

    def _mutex_arg(self, i: int, name: str) -> int:
        self._arg(i, name)
        if self.types[i].tc != TC.MUTEX:
            raise _Fault(f"{name}: dataspace entry {i} is a {self.types[i].name}, not a mutex")
        return i

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
            self._event = _SUSPEND
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
                self._event = _STOP
                return -1
            return nxt
        return f

    # -- timing ------------------------------------------------------------------------------

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
                self._event = _ROTATE
                return ~nxt
            me = self.runq.pop(0)
            self.restq.append(me)
            wake = self.awaken[me] = self.tick + ms
            if wake < self._next_wake:
                self._next_wake = wake
            self._event = _SUSPEND
            return ~nxt
        return f

    # -- ports ---------------------------------------------------------------------------------

    def _setin(self, s: int, port: int, field: int, nxt: int) -> Op:
        src = self._int_reader(s, "SETIN")
        prt = self._int_reader(port, "SETIN")
        io = self.io
        if field >= InputField.COUNT:
            raise _Fault(f"SETIN: input field {field} does not exist")
        ft = INPUT_FIELD_TYPES[field]

        def f() -> int:
            p = prt() & M32
            if p >= NO_OF_INPUTS:
                raise _Fault(f"SETIN: input port {p} does not exist")
            io.input_set(p, field, wrap(ft, src()))
            self.io_epoch += 1
            return nxt
        return f

    def _getin(self, d: int, port: int, field: int, nxt: int) -> Op:
        self._scalar_arg(d, "GETIN")
        prt = self._int_reader(port, "GETIN")
        io = self.io
        m = self.mem
        dt = self.types[d].tc
        if field >= InputField.COUNT:
            raise _Fault(f"GETIN: input field {field} does not exist")

        def f() -> int:
            p = prt() & M32
            if p >= NO_OF_INPUTS:
                raise _Fault(f"GETIN: input port {p} does not exist")
            m[d] = store(dt, io.input_get(p, field))
            self._polled = True
            return nxt
        return f

    def _getout(self, d: int, port: int, field: int, nxt: int) -> Op:
        self._scalar_arg(d, "GETOUT")
        prt = self._int_src(port, "GETOUT")
        dt = self.types[d].tc
        if field >= OutputField.COUNT:
            raise _Fault(f"GETOUT: output field {field} does not exist")
        value = f"io_get(p, {field})"
        return self._fuser.template(
            f"p = {prt} & 0xFFFFFFFF\n"
            f"if p >= {NO_OF_OUTPUTS}:\n"
            f"    port_fault('GETOUT: output', p)\n"
            f"m[{d}] = " + (_wrap_expr(dt, value) if dt in INT_TYPES else f"store({dt}, {value})")
            + "\nvm._polled = True")

    def _setout(self, port: int, rest: tuple[int, ...], nxt: int) -> Op:
        self._arg(port, "SETOUT")
        if len(rest) % 2:
            raise _Fault("SETOUT: odd number of field/value words")
        pairs = []
        for k in range(0, len(rest), 2):
            fld, src = rest[k], rest[k + 1]
            if fld >= OutputField.COUNT:
                raise _Fault(f"SETOUT: output field {fld} does not exist")
            ft = OUTPUT_FIELD_TYPES[fld]
            value = self._int_src(src, "SETOUT")
            # a value that always fits the field needs no wrap
            st = self.types[src].tc if src != NOT_A_DS_ID else ft
            pairs.append((fld, value if _fits(st, ft) else _wrap_expr(ft, value)))
        sets = "".join(f"    io_set(p, {fld}, {value})\n" for fld, value in pairs)
        tp = self.types[port]
        if tp.tc != TC.ARRAY:
            return self._fuser.template(
                f"p = {self._int_src(port, 'SETOUT')} & 0xFFFFFFFF\n"
                f"if p < {NO_OF_OUTPUTS}:\n{sets}"
                f"vm.io_epoch += 1")
        assert tp.elem is not None
        if not tp.elem.is_scalar:
            raise _Fault(f"SETOUT: port list of {tp.elem.name}")
        return self._fuser.template(
            f"for p in m[{port}]:\n"
            f"    p = int_of({tp.elem.tc}, p) & 0xFFFFFFFF\n"
            f"    if p < {NO_OF_OUTPUTS}:\n" + _indent(sets.rstrip("\n")) + "\n"
            "vm.io_epoch += 1")

    # -- system calls --------------------------------------------------------------------------

    def _syscall(self, sid: int, cluster: int, nxt: int) -> Op:
        name = SYSCALL_NAMES.get(sid)
        if name is None:
            raise _Fault(f"unknown system call {sid}")
        impl = SYSCALLS.get(sid)
        if impl is None:
            raise _Fault(f"system call {sid} ({name}) is not supported by the emulated brick")
        self._arg(cluster, f"SYSCALL {name}")
        t = self.types[cluster]
        if t.tc != TC.CLUSTER:
            raise _Fault(f"SYSCALL {name}: arguments in a {t.name}, a cluster is needed")
        args = [m.index for m in t.members]
        expected = impl.arity
        if len(args) < expected:
            raise _Fault(f"SYSCALL {name}: {len(args)} arguments, it takes {expected}")
        fn = impl.fn
        if impl.reads_only:
            def f() -> int:
                try:
                    fn(self, args)
                except SyscallError as exc:
                    raise _Fault(f"SYSCALL {name}: {exc}") from None
                self._polled = True
                return nxt
            return f

        def g() -> int:
            try:
                fn(self, args)
            except SyscallError as exc:
                raise _Fault(f"SYSCALL {name}: {exc}") from None
            self.io_epoch += 1
            return nxt
        return g


def _wrap_src(tc: int, expr: str, dest: str) -> str:
    """Statements of a template storing ``wrap(tc, expr)`` into ``dest``."""
    mask, sign = _WRAP_MASKS[tc]
    if sign is None:
        return f"{dest} = ({expr}) & {mask:#x}"
    return f"v = ({expr}) & {mask:#x}\n{dest} = v - {2 * sign:#x} if v & {sign:#x} else v"


def _wrap_expr(tc: int, expr: str) -> str:
    """An expression of ``wrap(tc, expr)``."""
    mask, sign = _WRAP_MASKS[tc]
    if sign is None:
        return f"(({expr}) & {mask:#x})"
    return f"((({expr}) + {sign:#x} & {mask:#x}) - {sign:#x})"


def _port_fault(what: str, p: int) -> None:
    raise _Fault(f"{what} port {p} does not exist")


def _indent(src: str) -> str:
    return "\n".join("    " + line for line in src.split("\n"))


#: wrap()'s mask and sign bit per integer type (None: unsigned)
_WRAP_MASKS = {TC.UBYTE: (0xFF, None), TC.SBYTE: (0xFF, 0x80), TC.UWORD: (0xFFFF, None),
               TC.SWORD: (0xFFFF, 0x8000), TC.ULONG: (M32, None),
               TC.SLONG: (M32, 0x80000000)}

_INT_RANGES = {TC.UBYTE: (0, 0xFF), TC.SBYTE: (-0x80, 0x7F), TC.UWORD: (0, 0xFFFF),
               TC.SWORD: (-0x8000, 0x7FFF), TC.ULONG: (0, M32),
               TC.SLONG: (-0x80000000, 0x7FFFFFFF)}


def _fits(src: int, dst: int) -> bool:
    """Every value of integer type ``src`` is a value of integer type ``dst``."""
    if src not in _INT_RANGES or dst not in _INT_RANGES:
        return False
    (lo, hi), (dlo, dhi) = _INT_RANGES[src], _INT_RANGES[dst]
    return dlo <= lo and hi <= dhi


def _index_fault(k: int, s: int, arr: Any) -> None:
    raise _Fault(f"INDEX: index {k} is outside the array at dataspace entry {s} "
                 f"({len(arr)} elements)")


def _raiser(message: str) -> Op:
    def f() -> int:
        raise _Fault(message)
    return f


def _same_type(a: DType, b: DType) -> bool:
    """``cCmdCompareDSType``."""
    if a.tc != b.tc:
        return False
    if a.tc == TC.CLUSTER:
        return len(a.members) == len(b.members) and all(
            _same_type(x, y) for x, y in zip(a.members, b.members))
    if a.tc == TC.ARRAY:
        assert a.elem is not None and b.elem is not None
        return _same_type(a.elem, b.elem)
    return True


def _format_float(v: float) -> str:
    """``OP_NUMTOSTRING`` of a float: ``%.2f`` without trailing zeros, ``%.6g`` when wide."""
    if math.isnan(v) or math.isinf(v) or v > 9999999999999.99 or v < -999999999999.99:
        return _c_format("g", v)
    text = f"{v:.2f}"
    if text.endswith("0"):
        text = f"{v:.0f}" if text.endswith("00") else f"{v:.1f}"
    return text


def _c_format(kind: str, v: float) -> str:
    """C's ``%.6g`` (``inf``/``nan`` spelled as C does)."""
    if math.isnan(v):
        return "nan" if math.copysign(1.0, v) > 0 else "-nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:.6g}"

