"""Errors of the NXT executable loader and interpreter.

Both are one line a user can act on: which file, which byte offset or which
instruction (program counter, clump, opcode name), and what is wrong with it.
Both are :class:`~nxt_link.wire.errors.LinkError` s, so that a caller catching the
package's errors catches these too: whatever bytes a file holds, loading it
raises nothing else than :class:`RxeError`, and running it nothing else than
:class:`VMError`.
"""
from __future__ import annotations

from nxt_link.wire.errors import LinkError

__all__ = ["RxeError", "VMError"]


class RxeError(LinkError, ValueError):
    """An ``.rxe`` file the firmware would refuse to activate (malformed, truncated,
    wrong version), with the file name and, where it helps, the byte offset."""


class VMError(LinkError, RuntimeError):
    """A fatal run-time error: the firmware would abort the program.

    Attributes:
        pc: word index of the failing instruction in the codespace (None when the
            error is not tied to one instruction).
        clump: the clump that executed it.
    """

    def __init__(self, message: str, *, pc: int | None = None, clump: int | None = None) -> None:
        where = []
        if pc is not None:
            where.append(f"pc {pc} (0x{pc:04X})")
        if clump is not None:
            where.append(f"clump {clump}")
        super().__init__(f"{message} at {', '.join(where)}" if where else message)
        self.detail = message
        self.pc = pc
        self.clump = clump
