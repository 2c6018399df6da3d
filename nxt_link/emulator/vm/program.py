"""A compiled program as the firmware runs it: one :class:`VM` per activation.

:class:`VMProgram` has the same ``step(host)`` as the Python program models,
so the firmware runs either the same way, once per millisecond.
:class:`Symbols` reads an NBC symbol table (``nbc -Y=...``) so that a running
program's variables can be inspected by their NXC names, and
:class:`FollowerView` presents the follower program's state with the
inspection methods of its Python model (reference and measured rows, ...).
"""
from __future__ import annotations

from typing import Any, Protocol

from nxt_link.emulator.vm.iomap import BrickIO
from nxt_link.emulator.vm.machine import VM
from nxt_link.emulator.vm.rxe import Executable

__all__ = ["VMProgram", "Symbols", "FollowerView"]


class _Host(Protocol):
    def current_tick(self) -> int: ...


class VMProgram:
    """One run of an executable on the interpreter."""

    def __init__(self, exe: Executable, io: BrickIO, *, start_tick: int,
                 instructions_per_ms: int | None, fused: bool = True,
                 skip_busy_waits: bool = True) -> None:
        self.exe = exe
        self.vm = VM(exe, io, start_tick=start_tick, instructions_per_ms=instructions_per_ms,
                     fused=fused, skip_busy_waits=skip_busy_waits)

    @property
    def finished(self) -> bool:
        return self.vm.finished

    def step(self, host: _Host) -> None:
        """The program's time slice of this millisecond (raises VMError if it aborts)."""
        self.vm.run_slice(host.current_tick())


class Symbols:
    """Dataspace entry names from an NBC symbol table (the ``#SYMBOLS`` section)."""

    def __init__(self, text: str) -> None:
        self.index: dict[str, int] = {}
        section = None
        for line in text.splitlines():
            if line.startswith("#"):
                section = line.strip()
                continue
            if section != "#SYMBOLS" or line.startswith("Index"):
                continue
            parts = line.split("\t")
            if len(parts) >= 2 and parts[0].isdigit():
                self.index[parts[1]] = int(parts[0])

    def __contains__(self, name: str) -> bool:
        return name in self.index

    def value(self, vm: VM, name: str) -> Any:
        """The current value of NXC variable ``name`` (KeyError if unknown)."""
        return vm.get(self.index[name])


class FollowerView:
    """``cplus_follow.rxe``'s state, read from the running VM, in the model's terms
    (:class:`nxt_link.emulator.follower_program.FollowerProgram`)."""

    def __init__(self, vm: VM, symbols: Symbols) -> None:
        self._vm = vm
        self._sym = symbols

    def _v(self, name: str) -> Any:
        return self._sym.value(self._vm, name)

    @property
    def state(self) -> int:
        return int(self._v("state"))

    @property
    def bad_messages(self) -> int:
        return int(self._v("bad_messages"))

    @property
    def rows_stored(self) -> int:
        return int(self._v("rows_stored"))

    @property
    def logged(self) -> int:
        return int(self._v("logged"))

    @property
    def session(self) -> int:
        return int(self._v("session"))

    @property
    def expected(self) -> int:
        return int(self._v("expected"))

    def reference_rows(self) -> list[tuple[int, ...]]:
        n = int(self._v("nports"))
        refs = self._v("refs")
        return [tuple(refs[r * n:(r + 1) * n]) for r in range(self.rows_stored)]

    def measured_rows(self) -> list[tuple[int, ...]]:
        n = int(self._v("nports"))
        meas = self._v("meas")
        return [tuple(meas[r * n:(r + 1) * n]) for r in range(self.logged)]
