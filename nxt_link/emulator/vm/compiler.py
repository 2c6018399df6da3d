"""Instructions into closures: the decode step, once per program, at load.

:meth:`Compiler._compile_clump` decodes a clump (:func:`nxt_link.emulator.vm.rxe.decode_clump`)
and compiles each instruction by dispatching on its opcode to the compiler of
its family (the mixins this class combines); the result is one closure per
word offset plus the :class:`~nxt_link.emulator.vm.fuse.Step` list the fuser builds
blocks from. An instruction that can never run (unknown opcode, bad operand)
compiles to a closure that faults with the reason, so the error comes only if
it is executed, as on the firmware.
"""
from __future__ import annotations

from nxt_link.emulator.vm.core import Fault, Op, raiser
from nxt_link.emulator.vm.fuse import Step
from nxt_link.emulator.vm.opcodes import OPCODE_NAMES, SHORT_OPCODE_NAMES
from nxt_link.emulator.vm.ops_arith import ArithOps
from nxt_link.emulator.vm.ops_compare import CompareOps
from nxt_link.emulator.vm.ops_control import ControlOps
from nxt_link.emulator.vm.ops_data import DataOps
from nxt_link.emulator.vm.ops_io import PortOps
from nxt_link.emulator.vm.ops_strings import StringOps
from nxt_link.emulator.vm.rxe import Instruction, decode_clump, expected_size

__all__ = ["Compiler"]

# instructions that may not fall through to the next one (they end a fused block):
# JMP, BRCMP, BRTST, STOP, FINCLUMP, FINCLUMPIMMED, ACQUIRE, SUBCALL, SUBRET, WAIT
_LONG_ENDS = frozenset((0x25, 0x26, 0x27, 0x29, 0x2A, 0x2B, 0x2C, 0x2E, 0x2F, 0x34))
_SHORT_ENDS = frozenset((1, 3))  # short ACQUIRE, SUBCALL


def _signed16(v: int) -> int:
    return v - 0x10000 if v & 0x8000 else v


class Compiler(ArithOps, CompareOps, DataOps, StringOps, ControlOps, PortOps):
    """The instruction families together, and the dispatch from opcode to family."""

    def _compile_clump(self, c: int) -> tuple[list[Op], list[Step]]:
        """The clump's closures by word offset, and its instructions in order."""
        clump = self.exe.clumps[c]
        length = clump.code_end - clump.code_start + 1
        ops: list[Op] = [raiser("jump into the middle of an instruction")] * (length + 1)
        ops[length] = raiser(f"ran past the end of clump {c}")
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
            except Fault as f:
                ops[local] = raiser(f.args[0])
                ends, goto = True, None
            except Exception as exc:  # operands no check foresaw: the same, when it runs
                ops[local] = raiser(f"{self._opname(ins.pc)}: the interpreter cannot compile it "
                                    f"({type(exc).__name__}: {exc})")
                ends, goto = True, None
            steps.append(Step(local, local + ins.words, ops[local], ends, targets, goto))
        return ops, steps

    def _target(self, local: int, offset: int, length: int, name: str) -> int:
        t = local + _signed16(offset)
        if not 0 <= t < length:
            raise Fault(f"{name}: jump by {_signed16(offset)} words leaves the clump")
        return t

    def _compile(self, ins: Instruction, local: int, length: int, c: int) -> Op:
        if ins.error:
            raise Fault(ins.error)
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
            raise Fault(f"unknown opcode 0x{op:02X}")
        name = OPCODE_NAMES[op]
        size = expected_size(op)
        if size is False or (size is not None and size != 2 * ins.words):
            raise Fault(f"opcode 0x{op:02X} ({name}) is not an instruction of firmware 1.28 "
                        f"with {ins.words - 1} argument words")
        a = ins.args
        if size is None and len(a) < 2:
            raise Fault(f"{name}: a variable-size instruction of {2 * ins.words} bytes, without "
                        f"its first operand")
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
        raise Fault(f"opcode 0x{op:02X} ({name}) is not implemented by firmware 1.28")
