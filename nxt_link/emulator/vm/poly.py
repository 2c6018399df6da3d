"""Polymorphic arithmetic, comparison and moves on scalars, arrays and clusters.

The rules of the spec's "Polymorphic Instructions and Data Type Compatibility"
as the firmware implements them (``cCmdInterpPolyUnop2``,
``cCmdInterpPolyBinop``, ``cCmdBinop``, ``cCmdCompareAggregates``):

* scalars: if any operand (or the destination) is a float, the operation is
  done in float32 and stored with the destination's conversion; otherwise on
  32-bit integers, division and modulo signed only when *both* sources are of a
  signed type, ``x / 0 = 0`` and ``x % 0 = x``, comparisons unsigned as soon as
  one side is of an unsigned type;
* aggregates: element by element; an array destination gets as many elements
  as the shortest source array, a scalar source is used for every element, a
  cluster is processed member by member;
* comparing two aggregates into a scalar compares them lexicographically
  (elements first, then the counts).

The interpreter compiles the common scalar cases into fast closures; these
functions are the general case and the reference.
"""
from __future__ import annotations

import math
from typing import Any

from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.values import (
    INT_TYPES,
    M32,
    SIGNED,
    UNSIGNED,
    DType,
    copy_value,
    float_of,
    int_of,
    store,
    to_f32,
)

__all__ = ["int_binop", "flt_binop", "compare_int", "compare_flt", "int_unop", "flt_unop",
           "poly_binop", "poly_unop", "compare_aggregates", "convert", "s32",
           "OP_ADD", "OP_SUB", "OP_NEG", "OP_MUL", "OP_DIV", "OP_MOD", "OP_AND", "OP_OR",
           "OP_XOR", "OP_NOT", "OP_CMP", "OP_TST", "OP_MOV", "OP_SQRT", "OP_ABS"]

OP_ADD, OP_SUB, OP_NEG, OP_MUL, OP_DIV, OP_MOD, OP_AND, OP_OR, OP_XOR, OP_NOT = range(10)
OP_CMP, OP_TST, OP_MOV, OP_SQRT, OP_ABS = 0x11, 0x12, 0x1B, 0x36, 0x37


class PolyError(Exception):
    """An operand combination the firmware rejects (``ERR_ARG``)."""


def s32(v: int) -> int:
    v &= M32
    return v - 0x100000000 if v & 0x80000000 else v


def _cdiv(a: int, b: int) -> int:
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def _cmod(a: int, b: int) -> int:
    return a - b * _cdiv(a, b)


def compare_int(cc: int, a: int, b: int, ta: int, tb: int) -> int:
    """``cCmdCompare``: 1 or 0."""
    if ta in UNSIGNED or tb in UNSIGNED:
        a &= M32
        b &= M32
    else:
        a, b = s32(a), s32(b)
    return _cc(cc, a, b)


def _cc(cc: int, a: Any, b: Any) -> int:
    if cc == 0:
        return int(a < b)
    if cc == 1:
        return int(a > b)
    if cc == 2:
        return int(a <= b)
    if cc == 3:
        return int(a >= b)
    if cc == 4:
        return int(a == b)
    if cc == 5:
        return int(a != b)
    return 0


def compare_flt(cc: int, a: float, b: float) -> int:
    return _cc(cc, a, b)


def int_binop(op: int, cc: int, a: int, b: int, ta: int, tb: int) -> int:
    """``cCmdBinop`` on two integer operands (typed values); the result is a
    32-bit pattern, to be wrapped into the destination."""
    if op == OP_ADD:
        return a + b
    if op == OP_SUB:
        return a - b
    if op == OP_MUL:
        return a * b
    if op == OP_AND:
        return a & b
    if op == OP_OR:
        return a | b
    if op == OP_XOR:
        return a ^ b
    if op == OP_CMP:
        return compare_int(cc, a, b, ta, tb)
    if op in (OP_DIV, OP_MOD):
        ua, ub = a & M32, b & M32
        if ub == 0:
            return 0 if op == OP_DIV else ua
        if ta in SIGNED and tb in SIGNED:
            sa, sb = s32(a), s32(b)
            return _cdiv(sa, sb) if op == OP_DIV else _cmod(sa, sb)
        return ua // ub if op == OP_DIV else ua % ub
    return 0  # the firmware's default case (an opcode it cannot combine)


def flt_binop(op: int, cc: int, a: float, b: float) -> float:
    """``cCmdBinopFlt``: float32 arithmetic (the operands are float32 values)."""
    if op == OP_ADD:
        return to_f32(a + b)
    if op == OP_SUB:
        return to_f32(a - b)
    if op == OP_MUL:
        return to_f32(a * b)
    if op == OP_DIV:
        return 0.0 if b == 0 else to_f32(a / b)
    if op == OP_CMP:
        return float(_cc(cc, a, b))
    ia, ib = _flt_int(a), _flt_int(b)
    if op == OP_MOD:
        return a if b == 0 else to_f32(float(_cmod(ia, ib))) if ib else a
    if op == OP_AND:
        return to_f32(float(s32(ia & ib)))
    if op == OP_OR:
        return to_f32(float(s32(ia | ib)))
    if op == OP_XOR:
        return to_f32(float(s32(ia ^ ib)))
    return 0.0


def _flt_int(x: float) -> int:
    """``(SLONG)x``: truncation toward zero (undefined cases: 0, saturated)."""
    if x != x:
        return 0
    if math.isinf(x):
        return 0x7FFFFFFF if x > 0 else -0x80000000
    return max(-0x80000000, min(0x7FFFFFFF, int(x)))


def int_unop(op: int, cc: int, a: int, ta: int) -> int:
    """``cCmdUnop2`` on an integer operand."""
    if op == OP_MOV:
        return a
    if op == OP_NEG:
        return -s32(a)
    if op == OP_NOT:
        return int((a & M32) == 0)
    if op == OP_TST:
        return compare_int(cc, a, 0, ta, ta)
    if op == OP_ABS:
        return abs(s32(a))
    return 0  # SQRT of an integer: the firmware's default case


def flt_unop(op: int, cc: int, a: float) -> float:
    """``cCmdUnop2Flt``."""
    if op == OP_MOV:
        return a
    if op == OP_NEG:
        return -a
    if op == OP_NOT:
        return float(not a)
    if op == OP_TST:
        return float(_cc(cc, a, 0.0))
    if op == OP_ABS:
        return abs(a)
    if op == OP_SQRT:
        return to_f32(math.sqrt(a)) if a >= 0 else math.nan
    return 0.0


def _scalar_op1(op: int, cc: int, t1: DType, t2: DType, v2: Any) -> Any:
    if t1.tc == TC.FLOAT or t2.tc == TC.FLOAT:
        return store(t1.tc, flt_unop(op, cc, float_of(t2.tc, v2)))
    return store(t1.tc, int_unop(op, cc, int_of(t2.tc, v2), t2.tc))


def convert(t1: DType, t2: DType, v2: Any) -> Any:
    """A value of type ``t2`` moved into type ``t1`` (poly MOV)."""
    if t1.is_scalar and t2.is_scalar:
        if t1.tc == t2.tc:
            return v2
        return _scalar_op1(OP_MOV, 0, t1, t2, v2)
    if t1.tc == TC.ARRAY and t2.tc == TC.ARRAY and t1.elem is not None \
            and t2.elem is not None and t1.elem.tc == t2.elem.tc and t1.elem.tc in INT_TYPES:
        return copy_value(t1, v2)
    return poly_unop(OP_MOV, 0, t1, t2, v2)


def poly_unop(op: int, cc: int, t1: DType, t2: DType, v2: Any) -> Any:
    """``cCmdInterpPolyUnop2``: the new value of the destination."""
    if TC.MUTEX in (t1.tc, t2.tc):
        raise PolyError(f"a mutex is no operand ({t1.name} destination, {t2.name} source)")
    if t2.is_scalar:
        if not t1.is_scalar:
            raise PolyError(f"{t1.name} destination for a scalar source")
        return _scalar_op1(op, cc, t1, t2, v2)
    if t1.tc == TC.ARRAY and t2.tc == TC.ARRAY:
        assert t1.elem is not None and t2.elem is not None
        if t1.elem.tc == t2.elem.tc and t1.elem.tc in INT_TYPES:
            # the firmware copies same-typed integer arrays whatever the operation
            return copy_value(t1, v2)
        out = [poly_unop(op, cc, t1.elem, t2.elem, e) for e in v2]
        return bytearray(out) if t1.string else out
    if t1.tc == TC.ARRAY:
        raise PolyError(f"array destination for a {t2.name} source")
    if t1.tc == TC.CLUSTER:
        if t2.tc == TC.CLUSTER:
            return [poly_unop(op, cc, m1, m2, e) for m1, m2, e in zip(t1.members, t2.members, v2)]
        return [poly_unop(op, cc, m1, t2, v2) for m1 in t1.members]
    raise PolyError(f"{t1.name} destination for a {t2.name} source")


def _scalar_op2(op: int, cc: int, t1: DType, t2: DType, t3: DType, v2: Any, v3: Any) -> Any:
    if t1.tc == TC.FLOAT or t2.tc == TC.FLOAT or t3.tc == TC.FLOAT:
        return store(t1.tc, flt_binop(op, cc, float_of(t2.tc, v2), float_of(t3.tc, v3)))
    return store(t1.tc, int_binop(op, cc, int_of(t2.tc, v2), int_of(t3.tc, v3), t2.tc, t3.tc))


def poly_binop(op: int, cc: int, t1: DType, t2: DType, t3: DType, v2: Any, v3: Any) -> Any:
    """``cCmdInterpPolyBinop``: the new value of the destination."""
    if TC.MUTEX in (t1.tc, t2.tc, t3.tc):
        raise PolyError(f"a mutex is no operand ({t1.name} destination, {t2.name} and {t3.name} "
                        f"sources)")
    agg2, agg3 = not t2.is_scalar, not t3.is_scalar
    if not agg2 and not agg3:
        if not t1.is_scalar:
            raise PolyError(f"{t1.name} destination for scalar sources")
        return _scalar_op2(op, cc, t1, t2, t3, v2, v3)
    if t1.tc == TC.ARRAY:
        assert t1.elem is not None
        counts = [len(v) for t, v in ((t2, v2), (t3, v3)) if t.tc == TC.ARRAY]
        if not counts:
            raise PolyError("array destination without an array source")
        n = min(counts)
        e2 = t2.elem if t2.tc == TC.ARRAY else t2
        e3 = t3.elem if t3.tc == TC.ARRAY else t3
        assert e2 is not None and e3 is not None
        out = [poly_binop(op, cc, t1.elem, e2, e3,
                          v2[i] if t2.tc == TC.ARRAY else v2,
                          v3[i] if t3.tc == TC.ARRAY else v3) for i in range(n)]
        return bytearray(out) if t1.string else out
    if t1.tc == TC.CLUSTER:
        out = []
        for k, m1 in enumerate(t1.members):
            m2 = t2.members[k] if t2.tc == TC.CLUSTER else t2
            m3 = t3.members[k] if t3.tc == TC.CLUSTER else t3
            out.append(poly_binop(op, cc, m1, m2, m3, v2[k] if t2.tc == TC.CLUSTER else v2,
                                  v3[k] if t3.tc == TC.CLUSTER else v3))
        return out
    raise PolyError(f"{t1.name} destination for {t2.name} and {t3.name} sources")


def compare_aggregates(cc: int, t2: DType, t3: DType, v2: Any, v3: Any) -> int:
    """``cCmdCompareAggregates``: one boolean for two whole aggregates."""
    done, result = _cmp_rec(cc, t2, t3, v2, v3)
    if not done:
        return int(cc in (4, 2, 3))  # equal: EQ, LTEQ, GTEQ hold
    return result


def _cmp_rec(cc: int, t2: DType, t3: DType, v2: Any, v3: Any) -> tuple[bool, int]:
    if not (t2.is_scalar and t3.is_scalar) and (t2.is_scalar or t3.is_scalar or TC.MUTEX in (t2.tc, t3.tc)):
        raise PolyError(f"comparing a {t2.name} with a {t3.name}")
    if t2.is_scalar:
        a, b = int_of(t2.tc, v2), int_of(t3.tc, v3)
        if compare_int(5, a, b, t2.tc, t3.tc):
            return True, compare_int(cc, a, b, t2.tc, t3.tc)
        return False, 0
    if t2.tc != t3.tc:
        raise PolyError(f"comparing a {t2.name} with a {t3.name}")
    if t2.tc == TC.ARRAY:
        assert t2.elem is not None and t3.elem is not None
        n2, n3 = len(v2), len(v3)
        if n2 != n3 and cc in (4, 5):
            return True, int(cc == 5)
        for i in range(min(n2, n3)):
            done, r = _cmp_rec(cc, t2.elem, t3.elem, v2[i], v3[i])
            if done:
                return True, r
    else:
        n2, n3 = len(t2.members), len(t3.members)
        if n2 != n3 and cc in (4, 5):
            return True, int(cc == 5)
        for i in range(min(n2, n3)):
            done, r = _cmp_rec(cc, t2.members[i], t3.members[i], v2[i], v3[i])
            if done:
                return True, r
    if n2 != n3:
        return True, compare_int(cc, n2, n3, TC.UWORD, TC.UWORD)
    return False, 0
