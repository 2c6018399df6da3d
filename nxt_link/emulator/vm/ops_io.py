"""The brick around the program: ports (``setin``, ``getin``, ``setout``, ``getout``)
and system calls (``syscall``).

Port fields go through :class:`~nxt_link.emulator.vm.iomap.BrickIO`; an instruction
that changes something outside the VM's memory counts in ``vm.io_epoch``, one
that only reads sets ``vm._polled`` (both for :mod:`nxt_link.emulator.vm.spin`). System
calls dispatch to :data:`nxt_link.emulator.vm.syscalls.SYSCALLS`; an unknown or
unsupported one faults naming it, at compile time already, so it never runs.
"""
from __future__ import annotations

from nxt_link.emulator.vm.core import NOT_A_DS_ID, Fault, Op, VMCore
from nxt_link.emulator.vm.iomap import (
    INPUT_FIELD_TYPES,
    NO_OF_INPUTS,
    NO_OF_OUTPUTS,
    OUTPUT_FIELD_TYPES,
    InputField,
    OutputField,
)
from nxt_link.emulator.vm.opcodes import SYSCALL_NAMES, TC
from nxt_link.emulator.vm.syscalls import SYSCALLS, SyscallError
from nxt_link.emulator.vm.templates import fits, indent, wrap_expr
from nxt_link.emulator.vm.values import INT_TYPES, M32, store, wrap

__all__ = ["PortOps"]


class PortOps(VMCore):
    """Compilers of the port instructions and of system calls."""

    def _setin(self, s: int, port: int, field: int, nxt: int) -> Op:
        src = self._int_reader(s, "SETIN")
        prt = self._int_reader(port, "SETIN")
        io = self.io
        if field >= InputField.COUNT:
            raise Fault(f"SETIN: input field {field} does not exist")
        ft = INPUT_FIELD_TYPES[field]

        def f() -> int:
            p = prt() & M32
            if p >= NO_OF_INPUTS:
                raise Fault(f"SETIN: input port {p} does not exist")
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
            raise Fault(f"GETIN: input field {field} does not exist")

        def f() -> int:
            p = prt() & M32
            if p >= NO_OF_INPUTS:
                raise Fault(f"GETIN: input port {p} does not exist")
            m[d] = store(dt, io.input_get(p, field))
            self._polled = True
            return nxt
        return f

    def _getout(self, d: int, port: int, field: int, nxt: int) -> Op:
        self._scalar_arg(d, "GETOUT")
        prt = self._int_src(port, "GETOUT")
        dt = self.types[d].tc
        if field >= OutputField.COUNT:
            raise Fault(f"GETOUT: output field {field} does not exist")
        value = f"io_get(p, {field})"
        return self._fuser.template(
            f"p = {prt} & 0xFFFFFFFF\n"
            f"if p >= {NO_OF_OUTPUTS}:\n"
            f"    port_fault('GETOUT: output', p)\n"
            f"m[{d}] = " + (wrap_expr(dt, value) if dt in INT_TYPES else f"store({dt}, {value})")
            + "\nvm._polled = True")

    def _setout(self, port: int, rest: tuple[int, ...], nxt: int) -> Op:
        self._arg(port, "SETOUT")
        if len(rest) % 2:
            raise Fault("SETOUT: odd number of field/value words")
        pairs = []
        for k in range(0, len(rest), 2):
            fld, src = rest[k], rest[k + 1]
            if fld >= OutputField.COUNT:
                raise Fault(f"SETOUT: output field {fld} does not exist")
            ft = OUTPUT_FIELD_TYPES[fld]
            value = self._int_src(src, "SETOUT")
            # a value that always fits the field needs no wrap
            st = self.types[src].tc if src != NOT_A_DS_ID else ft
            pairs.append((fld, value if fits(st, ft) else wrap_expr(ft, value)))
        # no field at all still names the ports (and counts as output): a body of "pass"
        sets = "".join(f"    io_set(p, {fld}, {value})\n" for fld, value in pairs) or "    pass\n"
        tp = self.types[port]
        if tp.tc != TC.ARRAY:
            return self._fuser.template(
                f"p = {self._int_src(port, 'SETOUT')} & 0xFFFFFFFF\n"
                f"if p < {NO_OF_OUTPUTS}:\n{sets}"
                f"vm.io_epoch += 1")
        assert tp.elem is not None
        if not tp.elem.is_scalar:
            raise Fault(f"SETOUT: port list of {tp.elem.name}")
        return self._fuser.template(
            f"for p in m[{port}]:\n"
            f"    p = int_of({tp.elem.tc}, p) & 0xFFFFFFFF\n"
            f"    if p < {NO_OF_OUTPUTS}:\n" + indent(sets.rstrip("\n")) + "\n"
            "vm.io_epoch += 1")

    def _syscall(self, sid: int, cluster: int, nxt: int) -> Op:
        name = SYSCALL_NAMES.get(sid)
        if name is None:
            raise Fault(f"unknown system call {sid}")
        impl = SYSCALLS.get(sid)
        if impl is None:
            raise Fault(f"system call {sid} ({name}) is not supported by the emulated brick")
        self._arg(cluster, f"SYSCALL {name}")
        t = self.types[cluster]
        if t.tc != TC.CLUSTER:
            raise Fault(f"SYSCALL {name}: arguments in a {t.name}, a cluster is needed")
        args = [m.index for m in t.members]
        expected = impl.arity
        if len(args) < expected:
            raise Fault(f"SYSCALL {name}: {len(args)} arguments, it takes {expected}")
        fn = impl.fn
        if impl.reads_only:
            def f() -> int:
                try:
                    fn(self, args)
                except SyscallError as exc:
                    raise Fault(f"SYSCALL {name}: {exc}") from None
                self._polled = True
                return nxt
            return f

        def g() -> int:
            try:
                fn(self, args)
            except SyscallError as exc:
                raise Fault(f"SYSCALL {name}: {exc}") from None
            self.io_epoch += 1
            return nxt
        return g
