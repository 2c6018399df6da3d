"""Comparisons and conditional branches: ``cmp``, ``brcmp``, ``brtst``.

A comparison between integers compares the typed values, unsigned as soon as
one side is unsigned (``brtst`` compares the value as a signed 32-bit integer
against 0); floats and aggregates (element-wise into an array, or
lexicographically into a scalar) go through :mod:`nxt_link.emulator.vm.poly`. A branch
returns its target or the next instruction; ``jmp`` is a one-line template of
the compiler.
"""
from __future__ import annotations

from nxt_link.emulator.vm import poly
from nxt_link.emulator.vm.core import NOT_A_DS_ID, Fault, Op, VMCore
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.templates import CC_SYMBOLS
from nxt_link.emulator.vm.values import INT_TYPES, UNSIGNED, store

__all__ = ["CompareOps"]


class CompareOps(VMCore):
    """Compilers of the comparison and branch instructions."""

    def _cmp(self, cc: int, d: int, a: int, b: int, nxt: int) -> Op:
        for x in (d, a, b):
            self._arg(x, "CMP")
        td, ta, tb = self.types[d], self.types[a], self.types[b]
        if td.tc in INT_TYPES and ta.tc in INT_TYPES and tb.tc in INT_TYPES:
            # typed values compare as they are, except that an unsigned comparison
            # reads a signed side as its 32-bit pattern; 1 and 0 fit every type
            sym = CC_SYMBOLS.get(cc)
            if sym is None:
                return self._fuser.template(f"m[{d}] = 0")
            if ta.tc in UNSIGNED or tb.tc in UNSIGNED:
                return self._fuser.template(
                    f"m[{d}] = 1 if (m[{a}] & 0xFFFFFFFF) {sym} (m[{b}] & 0xFFFFFFFF) else 0")
            return self._fuser.template(f"m[{d}] = 1 if m[{a}] {sym} m[{b}] else 0")
        get_a, get_b = self._getter(a), self._getter(b)
        set_d = self._setter(d)
        agg = not ta.is_scalar and not tb.is_scalar and td.is_scalar

        def g() -> int:
            try:
                if agg:
                    set_d(store(td.tc, poly.compare_aggregates(cc, ta, tb, get_a(), get_b())))
                else:
                    set_d(poly.poly_binop(poly.OP_CMP, cc, td, ta, tb, get_a(), get_b()))
            except poly.PolyError as exc:
                raise Fault(f"CMP: {exc}") from None
            return nxt
        return g

    def _brtst(self, cc: int, target: int, s: int, nxt: int) -> Op:
        if s == NOT_A_DS_ID:
            taken = cc in (4, 2, 3)
            return self._fuser.template(f"return {target if taken else nxt}")
        self._scalar_arg(s, "BRTST")
        ts = self.types[s].tc
        if ts in INT_TYPES:
            # the value as a signed 32-bit integer against 0 (the typed value itself,
            # except for an ulong)
            sym = CC_SYMBOLS.get(cc)
            if sym is None:
                return self._fuser.template(f"return {nxt}")
            v = f"s32(m[{s}])" if ts == TC.ULONG else f"m[{s}]"
            return self._fuser.template(f"return {target} if {v} {sym} 0 else {nxt}")
        rd = self._int_reader(s, "BRTST")

        def g() -> int:
            v = poly.s32(rd())
            return target if poly._cc(cc, v, 0) else nxt
        return g

    def _brcmp(self, cc: int, target: int, a: int, b: int, nxt: int) -> Op:
        self._arg(a, "BRCMP")
        self._arg(b, "BRCMP")
        ta, tb = self.types[a], self.types[b]
        if ta.tc in INT_TYPES and tb.tc in INT_TYPES:
            # poly.compare_int: unsigned as soon as one side is unsigned
            sym = CC_SYMBOLS.get(cc)
            if sym is None:
                return self._fuser.template(f"return {nxt}")
            if ta.tc in UNSIGNED or tb.tc in UNSIGNED:
                cond = f"(m[{a}] & 0xFFFFFFFF) {sym} (m[{b}] & 0xFFFFFFFF)"
            else:
                cond = f"m[{a}] {sym} m[{b}]"
            return self._fuser.template(f"return {target} if {cond} else {nxt}")
        if ta.is_scalar and tb.is_scalar:
            ra, rb = self._int_reader(a, "BRCMP"), self._int_reader(b, "BRCMP")
            tat, tbt = ta.tc, tb.tc

            def f() -> int:
                return target if poly.compare_int(cc, ra(), rb(), tat, tbt) else nxt
            return f
        get_a, get_b = self._getter(a), self._getter(b)

        def g() -> int:
            try:
                r = poly.compare_aggregates(cc, ta, tb, get_a(), get_b())
            except poly.PolyError as exc:
                raise Fault(f"BRCMP: {exc}") from None
            return target if r else nxt
        return g
