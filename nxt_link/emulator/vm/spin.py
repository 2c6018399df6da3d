"""Busy-wait detection: a time slice that provably goes round in circles is cut short.

With ``instructions_per_ms=None`` (an infinitely fast brick) every slice runs
until all clumps wait, at most a million instructions. An NXC busy-wait
(``while (CurrentTick() < t);``, ``until (ReceiveRemoteString(...) == NO_ERR);``)
never waits, so each simulated millisecond would cost a million interpreted
instructions, about 100 ms of real time. Within one slice, though, the world is
frozen: the tick, the motors' counters, the sensors and the mailboxes only
change between slices. A program that polls them without changing anything
outside its own memory is a deterministic machine, and if its whole state
(every clump's program counter, the queues, the memory) comes back to a state
it was in earlier in the slice, it will go round that cycle until the slice's
budget runs out.

:class:`SpinDetector` finds such a cycle with Brent's algorithm, comparing the
state at turn boundaries (every 20 instructions while it looks) with snapshots
taken at exponentially spaced boundaries, and returns how many whole cycles
can be skipped: the instruction counter advances by them without running
them, and the slice then runs its last cycles (and the truncated last turns)
for real. Nothing observable differs from running every instruction: the same
memory, program counters, queues, instruction count and I/O at the end of the
slice.

It is conservative: it only looks once a slice has run :data:`SPIN_AFTER`
instructions (:data:`SPIN_SOON` after a slice that used its whole budget) and
some clump has polled (read the tick, an input or output port, or a read-only
system call); a cycle only counts if no instruction with an effect outside
the VM's memory ran during it (an output or input write, a message sent or
removed, a tone, a drawing, a file operation, a random number:
:attr:`nxt_link.emulator.vm.machine.VM.io_epoch`); floats must match bit for bit. A
loop that changes its state every time round (counting its iterations,
drawing the time) is not a cycle and still costs its full slice. With a slice
of :data:`SPIN_AFTER` instructions or fewer (the default 500) it never looks.
"""
from __future__ import annotations

import copy
import math
from typing import TYPE_CHECKING, Any

from nxt_link.emulator.vm.values import Mutex

if TYPE_CHECKING:
    from nxt_link.emulator.vm.core import VMCore as VM

__all__ = ["SpinDetector", "SPIN_AFTER", "SPIN_SOON"]

#: instructions a slice runs before it is suspected of spinning
SPIN_AFTER = 2000
#: the same after a slice that used up its whole budget (it did not wait: it spun, or
#: it computes a lot)
SPIN_SOON = 100


class SpinDetector:
    """Brent's cycle detection over one slice's turn boundaries."""

    def __init__(self) -> None:
        self._key: tuple[Any, ...] | None = None
        self._mem: list[Any] = []
        self._at = 0
        self._power = 1
        self._lam = 0
        self._start_power = 1  # the previous cycle's length, in checks

    def reset(self) -> None:
        """A new slice: forget the previous one's snapshots."""
        self._key = None

    def check(self, vm: VM, executed: int, budget: int) -> int:
        """At a turn boundary after ``executed`` instructions: how many instructions
        can be skipped (whole cycles), 0 if none (yet)."""
        key = _key(vm)
        if self._key is not None and key == self._key and vm.mem == self._mem:
            period = executed - self._at
            cycles = (budget - executed - 20) // period - 2
            self._key = None
            # the next slice most likely spins the same way: look that far from the start
            self._start_power = self._lam + 1
            return cycles * period if cycles > 0 else 0
        if self._key is None or self._lam + 1 >= self._power:
            self._power = self._start_power if self._key is None else 2 * self._power
            self._key = key
            self._mem = [_snapshot(v) for v in vm.mem]
            self._at = executed
            self._lam = 0
        else:
            self._lam += 1
        return 0


def _key(vm: VM) -> tuple[Any, ...]:
    return (vm.io_epoch, tuple(vm.runq), tuple(vm.pcs), tuple(vm.restq), tuple(vm.fire),
            tuple(vm.awaken))


def _snapshot(v: Any) -> Any:
    """A copy of a memory value that compares equal to the live value only while it
    is the same: floats by their bits, mutexes by owner and waiting clumps."""
    t = type(v)
    if t is int or v is None:
        return v
    if t is float:
        return _Float(v)
    if t is bytearray:
        return bytearray(v)
    if t is Mutex:
        return _MutexState(v.owner, list(v.waiting))
    if t is list:
        if v and type(v[0]) is int:
            return v.copy()
        return [_snapshot(e) for e in v]
    return copy.deepcopy(v)


class _Float:
    """Equal to a float with the same bits (-0.0 is not 0.0; a NaN equals nothing)."""

    __slots__ = ("v",)

    def __init__(self, v: float) -> None:
        self.v = v

    def __eq__(self, other: object) -> bool:
        return (type(other) is float and other == self.v
                and math.copysign(1.0, other) == math.copysign(1.0, self.v))

    __hash__ = None  # type: ignore[assignment]


class _MutexState:
    __slots__ = ("owner", "waiting")

    def __init__(self, owner: int | None, waiting: list[int]) -> None:
        self.owner = owner
        self.waiting = waiting

    def __eq__(self, other: object) -> bool:
        return (type(other) is Mutex and other.owner == self.owner
                and other.waiting == self.waiting)

    __hash__ = None  # type: ignore[assignment]
