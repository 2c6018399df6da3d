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
slice that provably goes round in circles is cut short (:mod:`nxt_link.emulator.vm.spin`).

Instructions are compiled once, at load: into closures specialised on their
operands' types (each returns the offset of the next instruction, or a
negative event code), the common ones from source templates; straight-line
runs of them are then fused into one generated function each
(:mod:`nxt_link.emulator.vm.fuse`), so that a typical instruction costs a few tens of
nanoseconds. None of this changes what a program does: instruction counts,
turns and slices are the firmware's (tests compare the fused and the plain
interpreter, millisecond by millisecond). Fatal errors the firmware would
abort the program for — an unknown opcode or system call, an array index out
of range, a jump outside the clump, running out of memory — raise
:class:`~nxt_link.emulator.vm.errors.VMError` naming the opcode, the program counter
and the clump; nothing is ever skipped silently.

The interpreter is one class, :class:`VM`, put together from one mixin per
instruction family, each in a file of its own that can be read in one
sitting: :mod:`~nxt_link.emulator.vm.ops_arith` (arithmetic and logic),
:mod:`~nxt_link.emulator.vm.ops_compare` (comparisons and branches),
:mod:`~nxt_link.emulator.vm.ops_data` (moves and arrays), :mod:`~nxt_link.emulator.vm.ops_strings`
(strings and conversions), :mod:`~nxt_link.emulator.vm.ops_control` (clumps, calls,
mutexes, waits), :mod:`~nxt_link.emulator.vm.ops_io` (ports and system calls), combined
by :mod:`~nxt_link.emulator.vm.compiler` (decode and dispatch) and run by
:mod:`~nxt_link.emulator.vm.scheduler` (the time slice); :mod:`~nxt_link.emulator.vm.core` holds
the state they share. Mixins rather than handler tables because every
instruction compiler needs the same state and operand checks (``self.mem``,
``self.types``, ``self._arg``...), and because the split must cost nothing at
run time: the families only build closures, at load; what runs per
instruction is those closures and the one loop in the scheduler, exactly as
before (a method looked up through the mixins is found in the type's
attribute cache, as in one class).
"""
from __future__ import annotations

from nxt_link.emulator.vm import poly
from nxt_link.emulator.vm.compiler import Compiler
from nxt_link.emulator.vm.core import NEVER, Fault, index_fault, port_fault
from nxt_link.emulator.vm.errors import VMError
from nxt_link.emulator.vm.fuse import Fuser
from nxt_link.emulator.vm.iomap import BrickIO
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.rxe import CLUMP_RECORD_POOL_BYTES, Executable, decode_clump
from nxt_link.emulator.vm.scheduler import INSTRUCTIONS_PER_TURN, Scheduler
from nxt_link.emulator.vm.spin import SPIN_AFTER, SpinDetector
from nxt_link.emulator.vm.values import DType, int_of, store, wrap

__all__ = ["VM", "DEFAULT_INSTRUCTIONS_PER_MS", "INSTRUCTIONS_PER_TURN"]

#: instructions the emulated ARM7 gets through in one millisecond slice (an estimate)
DEFAULT_INSTRUCTIONS_PER_MS = 500


class VM(Scheduler, Compiler):
    """One activation of a program.

    Args:
        exe: the loaded executable.
        io: the brick around the VM (:class:`~nxt_link.emulator.vm.iomap.BrickIO`).
        start_tick: the millisecond tick the program starts at.
        instructions_per_ms: size of the millisecond time slice; ``None``: run
            until every clump waits (an infinitely fast CPU, for comparing the
            program with a model that takes no time), at most
            ``1_000_000`` instructions per slice.
        fused: run straight-line code as fused blocks (:mod:`nxt_link.emulator.vm.fuse`);
            False: one instruction at a time. The results are the same.
        skip_busy_waits: count the whole cycles of a slice that provably goes
            round in circles without running them (:mod:`nxt_link.emulator.vm.spin`);
            the results are the same.

    Raises:
        VMError: the initial arrays do not fit the brick's memory (``load_rxe``
            refuses such files already), or the program cannot be compiled (an
            instruction that cannot be is compiled to a fault, raised if it runs).

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
        self.mem = [None] * len(exe.types)
        for i, v in exe.initial_values().items():
            self.mem[i] = v
        self._addressable = set(exe.slots) | {i for i in exe.top_level
                                              if exe.types[i].tc == TC.CLUSTER}
        self._add_cluster_members()
        n = len(exe.clumps)
        self.fire = [c.fire_count for c in exe.clumps]
        self._fire_counts = tuple(self.fire)
        self.pcs = [0] * n
        self.runq = [c.index for c in exe.clumps if c.fire_count == 0]
        self.restq = []
        self.awaken = [0] * n
        self._next_wake = NEVER  # earliest wake-up time in the rest queue
        #: counts the instructions that changed something outside the VM's memory
        self.io_epoch = 0
        self._polled = False  # this slice read the tick, a port or a read-only syscall
        self._spin = SpinDetector()
        self._skip_busy_waits = skip_busy_waits and self.budget > SPIN_AFTER
        self._spent = False  # the last slice used up its budget
        self.skipped = 0
        self.instructions = 0
        self.finished = False
        self.error = None
        self.array_bytes = {}
        pool = n * CLUMP_RECORD_POOL_BYTES
        pool += (-pool) % 4
        self._fixed_bytes = pool + exe.static_size
        self.memory_used = 0
        try:
            for i in exe.slots:
                if exe.types[i].tc == TC.ARRAY:
                    self._account(i, self.mem[i])
        except Fault as f:  # the loader refuses such files; an Executable made otherwise
            raise VMError(f"cannot start: {f.args[0]}") from None
        self._event = 0
        self._fuser = Fuser({"m": self.mem, "vm": self, "wrap": wrap, "store": store,
                             "s32": poly.s32, "int_of": int_of, "index_fault": index_fault,
                             "port_fault": port_fault, "io_get": io.output_get,
                             "io_set": io.output_set})
        compiled = [self._compile_clump(c.index) for c in exe.clumps]
        self.ops = [ops for ops, _ in compiled]
        self.fused = fused
        # only RELEASE adds a clump to the run queue in the middle of a turn; without
        # it, a clump alone in the queue stays alone until its turn ends with an event
        self._solo_ok = not any(ins.opcode == (2 if ins.short else 0x2D)
                                for c in exe.clumps for ins in decode_clump(exe.code, c))
        try:
            fns, lens = self._fuser.build(compiled, blocks=fused)
        except Exception as exc:  # a template the operands broke: refuse, never crash
            raise VMError(f"cannot start: the interpreter cannot compile the program "
                          f"({type(exc).__name__}: {exc})") from exc
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
