"""The state every instruction family works on, and how instructions reach it.

:class:`VMCore` is the base of the interpreter's mixins (:mod:`nxt_link.emulator.vm.machine`
says why the interpreter is cut into mixins): it declares the attributes the
:class:`~nxt_link.emulator.vm.machine.VM` constructor sets, holds the dataspace values
(:meth:`VMCore.get`, :meth:`VMCore.set`) with the 32 KB pool accounting of the
arrays, and checks the operands of an instruction while it is compiled
(``_arg``, ``_scalar_arg``, ``_array_arg``, ``_mutex_arg``) and makes their
readers and writers (``_int_reader``, ``_int_src``, ``_getter``, ``_setter``).

An instruction compiles to a closure (:data:`Op`) that returns the offset of the
next instruction, or ``~resume`` (a negative number) after setting
``vm._event`` to one of :data:`DONE`, :data:`SUSPEND`, :data:`ROTATE`,
:data:`STOP`; a fatal error inside it raises :class:`Fault`, to which the run
loop adds the program counter and the clump.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from nxt_link.emulator.vm.errors import VMError
from nxt_link.emulator.vm.iomap import BrickIO
from nxt_link.emulator.vm.opcodes import OPCODE_NAMES, SHORT_OPCODE_NAMES, TC
from nxt_link.emulator.vm.rxe import POOL_SIZE, Executable
from nxt_link.emulator.vm.values import DType, int_of, pool_bytes

if TYPE_CHECKING:
    from nxt_link.emulator.vm.fuse import Fuser

__all__ = ["VMCore", "Fault", "Op", "NOT_A_DS_ID", "DONE", "SUSPEND", "ROTATE", "STOP",
           "NEVER", "index_fault", "port_fault", "raiser", "out_of_memory"]

NOT_A_DS_ID = 0xFFFF
#: a time no clump waits for (an empty rest queue's next wake-up)
NEVER = 1 << 62
# events a closure signals by returning ~resume_index (a negative number)
DONE, SUSPEND, ROTATE, STOP = 1, 2, 3, 4
Op = Callable[[], int]


class Fault(Exception):
    """A fatal error inside an instruction; the run loop adds pc and clump."""


class SpinCheck(Protocol):
    """What the scheduler asks of its busy-wait detector
    (:class:`~nxt_link.emulator.vm.spin.SpinDetector`, which builds on this module)."""

    def reset(self) -> None: ...

    def check(self, vm: VMCore, executed: int, budget: int) -> int: ...


class VMCore:
    """The interpreter's state and the operand access shared by every instruction family.

    Only attributes are declared here; :class:`~nxt_link.emulator.vm.machine.VM` sets them.
    """

    exe: Executable
    io: BrickIO
    types: list[DType]
    mem: list[Any]
    start_tick: int
    tick: int
    budget: int
    fire: list[int]
    pcs: list[int]
    runq: list[int]
    restq: list[int]
    awaken: list[int]
    io_epoch: int
    instructions: int
    skipped: int
    finished: bool
    error: VMError | None
    array_bytes: dict[int, int]
    memory_used: int
    ops: list[list[Op]]
    fused: bool
    _addressable: set[int]
    _fire_counts: tuple[int, ...]
    _next_wake: int
    _polled: bool
    _spin: SpinCheck
    _skip_busy_waits: bool
    _spent: bool
    _fixed_bytes: int
    _event: int
    _fuser: Fuser
    _solo_ok: bool
    _code: list[tuple[list[Op], list[int], list[Op]]]

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
        """Pool bytes of the top-level arrays, with the arrays their elements hold; beyond
        the 32 KB pool: ERR_MEM. Counting the nested arrays too bounds what a program
        can make the interpreter allocate, whatever it does."""
        t = self.types[i]
        size = len(v) * t.elem_size
        size += (-size) % 4
        if t.nested:
            size = pool_bytes(t, v)
        old = self.array_bytes.get(i, 0)
        if size != old:
            used = self.memory_used - old + size
            if used + self._fixed_bytes > POOL_SIZE and size > old:
                raise Fault(out_of_memory(used + self._fixed_bytes, f"array at dataspace entry "
                                          f"{i}, {len(v)} elements"))
            self.array_bytes[i] = size
            self.memory_used = used

    def variables(self) -> dict[int, Any]:
        """Current values of every storage slot (inspection, tests)."""
        return {i: self.mem[i] for i in self.exe.slots}

    # -- operands -------------------------------------------------------------------------

    def _arg(self, i: int, name: str, what: str = "argument") -> int:
        if i >= len(self.types):
            raise Fault(f"{name}: {what} refers to dataspace entry {i}, the program has "
                        f"{len(self.types)}")
        if i not in self._addressable:
            raise Fault(f"{name}: {what} refers to dataspace entry {i}, which is part of an "
                        f"array element type")
        return i

    def _scalar_arg(self, i: int, name: str) -> int:
        self._arg(i, name)
        t = self.types[i]
        if not t.is_scalar:
            raise Fault(f"{name}: dataspace entry {i} is a {t.name}, a scalar is needed")
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

    def _array_arg(self, i: int, name: str, string: bool = False) -> DType:
        self._arg(i, name)
        t = self.types[i]
        if t.tc != TC.ARRAY or (string and not t.string):
            raise Fault(f"{name}: dataspace entry {i} is a {t.name}, "
                        f"{'a string' if string else 'an array'} is needed")
        return t

    def _mutex_arg(self, i: int, name: str) -> int:
        self._arg(i, name)
        if self.types[i].tc != TC.MUTEX:
            raise Fault(f"{name}: dataspace entry {i} is a {self.types[i].name}, not a mutex")
        return i

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

    def _opname(self, pc: int) -> str:
        """The name of the instruction at codespace word ``pc``."""
        if not 0 <= pc < len(self.exe.code):
            return "the instruction past the end of the code"
        w = self.exe.code[pc]
        if w & 0x0800:
            return SHORT_OPCODE_NAMES.get((w >> 8) & 0x07, "short instruction")
        return OPCODE_NAMES.get(w & 0xFF, f"opcode 0x{w & 0xFF:02X}")


def out_of_memory(needed: int, what: str) -> str:
    """The message of the firmware's ERR_MEM."""
    return f"out of memory: {needed} bytes needed, the brick's pool has {POOL_SIZE} ({what})"


def port_fault(what: str, p: int) -> None:
    raise Fault(f"{what} port {p} does not exist")


def index_fault(k: int, s: int, arr: Any) -> None:
    raise Fault(f"INDEX: index {k} is outside the array at dataspace entry {s} "
                f"({len(arr)} elements)")


def raiser(message: str) -> Op:
    def f() -> int:
        raise Fault(message)
    return f
