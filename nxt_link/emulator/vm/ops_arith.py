"""Arithmetic and logic: ``add`` ... ``xor``, ``not``, ``neg``, ``abs``, ``sqrt``, ``tst``.

Between integer operands of any width the instruction is a source template
(wrapped to the destination's type, C division toward zero, ``x/0 = 0``);
anything else (floats, arrays element-wise, clusters member-wise) goes through
:mod:`nxt_link.emulator.vm.poly`.
"""
from __future__ import annotations

from nxt_link.emulator.vm import poly
from nxt_link.emulator.vm.core import Fault, Op, VMCore
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.templates import BINOP_SYMBOLS, CC_SYMBOLS, wrap_src
from nxt_link.emulator.vm.values import INT_TYPES, SIGNED, UNSIGNED, wrap

__all__ = ["ArithOps"]


class ArithOps(VMCore):
    """Compilers of the binary and unary arithmetic and logic instructions."""

    def _binop(self, op: int, d: int, a: int, b: int, nxt: int, name: str) -> Op:
        for x in (d, a, b):
            self._arg(x, name)
        m = self.mem
        td, ta, tb = self.types[d], self.types[a], self.types[b]
        if td.tc in INT_TYPES and ta.tc in INT_TYPES and tb.tc in INT_TYPES:
            dt = td.tc
            sym = BINOP_SYMBOLS.get(op)
            if sym is not None and dt == TC.SLONG:
                return self._fuser.template(
                    f"v = (m[{a}] {sym} m[{b}]) & 0xFFFFFFFF\n"
                    f"m[{d}] = v - 0x100000000 if v & 0x80000000 else v")
            if sym is not None:
                return self._fuser.template(wrap_src(dt, f"m[{a}] {sym} m[{b}]", f"m[{d}]"))
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
                raise Fault(f"{name}: {exc}") from None
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
                return self._fuser.template(wrap_src(dt, f"-s32(m[{s}])", f"m[{d}]"))
            if op == poly.OP_ABS:
                return self._fuser.template(wrap_src(dt, f"abs(s32(m[{s}]))", f"m[{d}]"))
            if op == poly.OP_TST:
                sym = CC_SYMBOLS.get(cc)
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
                raise Fault(f"{name}: {exc}") from None
            return nxt
        return h
