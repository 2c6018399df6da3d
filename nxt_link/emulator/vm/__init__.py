"""An NXT bytecode interpreter: the emulated brick runs the compiled ``.rxe`` itself.

* :func:`load_rxe` — parse and validate an executable (``RxeError`` if the
  firmware would refuse it);
* :class:`VM` — one activation: dataspace, clumps, the millisecond time slice;
* :class:`VMProgram` — a VM as the firmware runs a program;
* :class:`Flash` — the brick's flash file system (system commands, file syscalls);
* :func:`cached_compile` / :func:`compile_nxc` — nbc, once per source change;
* :func:`disassemble` — the decoded instructions, for error reports and tests.

After the "LEGO MINDSTORMS NXT Executable File Specification" (v2.0, firmware
1.28) and, where it is silent, the firmware's ``c_cmd.c``; see
``docs/nxt-link.md`` (section "The bytecode interpreter") for what is modelled.
"""
from __future__ import annotations

from nxt_link.emulator.vm.errors import RxeError, VMError
from nxt_link.emulator.vm.flash import Flash
from nxt_link.emulator.vm.machine import DEFAULT_INSTRUCTIONS_PER_MS, VM
from nxt_link.emulator.vm.nbc import (
    Compiled,
    NbcError,
    NbcMissingError,
    cached_compile,
    compile_nxc,
    follower_source,
)
from nxt_link.emulator.vm.opcodes import CC_NAMES, OPCODE_NAMES, SHORT_OPCODE_NAMES
from nxt_link.emulator.vm.program import FollowerView, Symbols, VMProgram
from nxt_link.emulator.vm.rxe import Executable, Instruction, decode_clump, load_rxe

__all__ = ["RxeError", "VMError", "Flash", "VM", "DEFAULT_INSTRUCTIONS_PER_MS", "VMProgram",
           "Symbols", "FollowerView", "Executable", "Instruction", "load_rxe", "decode_clump",
           "Compiled", "NbcError", "NbcMissingError", "cached_compile", "compile_nxc",
           "follower_source", "disassemble"]


def disassemble(exe: Executable) -> list[str]:
    """One line per instruction: ``clump pc: NAME[.cc] args`` (hex words)."""
    out = []
    for clump in exe.clumps:
        for ins in decode_clump(exe.code, clump):
            if ins.short:
                name = SHORT_OPCODE_NAMES.get(ins.opcode, f"short{ins.opcode}")
            else:
                name = OPCODE_NAMES.get(ins.opcode, f"op{ins.opcode:02X}")
                if ins.opcode in (0x11, 0x12, 0x26, 0x27):
                    name += "." + CC_NAMES.get(ins.cc, str(ins.cc))
            args = " ".join(f"{a:04X}" for a in ins.args)
            line = f"{clump.index:3d} {ins.pc:5d}: {name} {args}".rstrip()
            out.append(line + (f"  ; {ins.error}" if ins.error else ""))
    return out
