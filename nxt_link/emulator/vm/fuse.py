"""Fused blocks: straight-line runs of instructions compiled into one Python function.

The interpreter's unit of work is one closure per instruction (see
:mod:`nxt_link.emulator.vm.compiler`); calling it and checking what it returned costs more
than most instructions themselves (a ``mov`` is one list store). A *block* is
the run of instructions from a *leader* (a clump's first instruction, a jump
target, the instruction after a branch, a call, a wait...) up to and including
the next instruction that may not fall through (a branch, a scheduling
instruction, one that always faults), at most :data:`MAX_BLOCK` long; an
unconditional jump does not end it, the block goes on at the jump's target
(unless that is already in the block: a loop). It
becomes one generated function that does the work of all its instructions and
returns the next program counter (or the negative event code of its last
instruction), so the run loop dispatches once per block instead of once per
instruction.

Exactness: a block function does exactly what calling its instructions'
functions one after the other does. The common instructions (moves, integer
arithmetic and comparisons, branches, array element access) are defined once,
as a source template (:meth:`Fuser.template`): the fuser compiles each into
the instruction's own function *and* writes it out inline in the blocks, so
the two cannot differ; every other instruction is a call of its closure. The
run loop runs a block only when the turn has room for all of it, and
single-steps otherwise, so turns, time slices and instruction counts are
unchanged. A fault inside a block is located through the traceback: each
generated line belongs to one instruction (:meth:`Fuser.locate`), which gives
the faulting program counter and how many instructions of the block ran.

The generated source of a program depends only on its executable, so its code
object is cached (:func:`_code_for`, the last 16 programs) and a second
activation of the same program only binds fresh closures.
"""
from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import CodeType, TracebackType
from typing import Any

__all__ = ["Fuser", "Step", "MAX_BLOCK"]

#: longest block, in instructions: a turn is 20 instructions, and a block only runs
#: when it fits in what is left of the turn
MAX_BLOCK = 20
_FILENAME = "<nxt-vm fused block>"

Op = Callable[[], int]


@dataclass(frozen=True, slots=True)
class Step:
    """One decoded instruction of a clump, as the fuser needs it.

    Attributes:
        local: its word offset in the clump.
        nxt: the offset of the next instruction (fall-through).
        op: its compiled closure.
        ends_block: it may not fall through (jump, branch, scheduling, fault).
        targets: the offsets it may jump to.
        goto: the target of an unconditional jump (a block follows it).
    """

    local: int
    nxt: int
    op: Op
    ends_block: bool
    targets: tuple[int, ...] = ()
    goto: int | None = None


@dataclass(frozen=True, slots=True)
class _Block:
    clump: int
    start: int
    locals: tuple[int, ...]  # offset of each instruction in the block
    first_line: int
    line_index: tuple[int, ...]  # instruction index of each line from first_line on


class Fuser:
    """Compiles the templated instructions and the blocks of one VM's program.

    The VM's instruction compilers define the common instructions with
    :meth:`template`; :meth:`build` compiles them, in place in the clumps'
    ``ops`` lists, and makes per clump a list ``fns`` (the block function at a
    leader, the instruction's function elsewhere) and a list ``lens`` (how many
    instructions each entry runs).

    Args:
        namespace: the names templates use (``m``: the VM's memory, helpers).
    """

    def __init__(self, namespace: dict[str, Any]) -> None:
        self._src: dict[Op, str] = {}
        self._ns = namespace
        self._blocks: dict[str, _Block] = {}

    def template(self, src: str) -> Op:
        """An instruction written as Python statements on the memory list ``m``: a
        fall-through instruction's, or a block-ending one's that returns the next
        offset. Returns a stand-in for its function until :meth:`build`."""
        def pending() -> int:
            raise AssertionError("instruction template used before the fuser built it")
        self._src[pending] = src
        return pending

    def build(self, clumps: Sequence[tuple[list[Op], list[Step]]], *,
              blocks: bool = True) -> tuple[list[list[Op]], list[list[int]]]:
        """Compile each clump's ``(ops, steps)``: the templated instructions (their
        functions replace the stand-ins in ``ops``) and, with ``blocks``, the fused
        blocks; returns ``fns`` and ``lens`` per clump."""
        parts: list[str] = []
        plan: list[tuple[int, int, int]] = []  # (clump, start, length)
        line = 1
        for c, (_ops, steps) in enumerate(clumps):
            for s in steps:
                src = self._src.get(s.op)
                name = f"o_{c}_{s.local}"
                if src is None:
                    self._ns[name] = s.op
                    continue
                text = f"def {name}(m=m):\n" + _indent(src)
                if not s.ends_block:
                    text += f"    return {s.nxt}\n"
                parts.append(text)
                line += text.count("\n")
        for c, (_ops, steps) in enumerate(clumps):
            if not blocks:
                break
            by_local = {s.local: k for k, s in enumerate(steps)}
            for k in self._leaders(steps):
                text, locs, index = self._block_source(c, steps, k, by_local)
                if len(locs) < 2:
                    continue
                name = f"b_{c}_{steps[k].local}"
                self._blocks[name] = _Block(c, steps[k].local, tuple(locs), line + 1,
                                            tuple(index))
                parts.append(text)
                line += text.count("\n")
                plan.append((c, steps[k].local, len(locs)))
        if parts:
            exec(_code_for("".join(parts)), self._ns)  # noqa: S102 - our own generated code
        for c, (ops, steps) in enumerate(clumps):
            for s in steps:
                if s.op in self._src:
                    ops[s.local] = self._ns[f"o_{c}_{s.local}"]
        fns = [list(ops) for ops, _ in clumps]
        lens = [[1] * len(ops) for ops, _ in clumps]
        for c, start, length in plan:
            fns[c][start] = self._ns[f"b_{c}_{start}"]
            lens[c][start] = length
        return fns, lens

    @staticmethod
    def _leaders(steps: Sequence[Step]) -> list[int]:
        """Indices of the steps that start a block."""
        if not steps:
            return []
        starts = {0}
        by_local = {s.local: k for k, s in enumerate(steps)}
        run = 0
        for k, s in enumerate(steps):
            run += 1
            for t in s.targets:
                if t in by_local:
                    starts.add(by_local[t])
            if (s.ends_block or run >= MAX_BLOCK) and k + 1 < len(steps):
                starts.add(k + 1)
                run = 0
        return sorted(starts)

    def _block_source(self, c: int, steps: Sequence[Step], k: int,
                      by_local: dict[int, int]) -> tuple[str, list[int], list[int]]:
        head = steps[k].local
        lines = [f"def b_{c}_{head}(m=m):"]
        index: list[int] = []
        locs: list[int] = []
        visited: set[int] = set()
        j = k
        while True:
            s = steps[j]
            visited.add(j)
            locs.append(s.local)
            if (s.goto is not None and s.goto in by_local and by_local[s.goto] not in visited
                    and len(locs) < MAX_BLOCK):
                j = by_local[s.goto]  # an unconditional jump does nothing but go on there
                continue
            src = self._src.get(s.op)
            if src is None:
                name = f"o_{c}_{s.local}"
                body = [f"return {name}()" if s.ends_block else f"{name}()"]
            else:
                body = src.split("\n")
            for b in body:
                lines.append("    " + b)
                index.append(len(locs) - 1)
            if s.ends_block or len(locs) >= MAX_BLOCK:
                break
            j += 1
            if j >= len(steps) or steps[j].local != s.nxt:
                break
        last = steps[by_local[locs[-1]]]
        if not last.ends_block:
            lines.append(f"    return {last.nxt}")
            index.append(len(locs) - 1)
        return "\n".join(lines) + "\n", locs, index

    def locate(self, tb: TracebackType | None) -> tuple[int, int] | None:
        """For a fault raised inside a block: (offset of the faulting instruction,
        instructions of the block that ran, the faulting one included)."""
        while tb is not None:
            code = tb.tb_frame.f_code
            if code.co_filename == _FILENAME and code.co_name in self._blocks:
                b = self._blocks[code.co_name]
                j = b.line_index[tb.tb_lineno - b.first_line]
                return b.locals[j], j + 1
            tb = tb.tb_next
        return None


def _indent(src: str) -> str:
    return "".join("    " + line + "\n" for line in src.split("\n"))


@functools.lru_cache(maxsize=16)
def _code_for(source: str) -> CodeType:
    """The compiled generated source (a program started again is not compiled again)."""
    return compile(source, _FILENAME, "exec")
