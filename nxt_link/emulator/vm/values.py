"""Dataspace types and the values the interpreter keeps in them.

The firmware keeps a program's data as bytes in a 32 KB pool, arrays behind
dope vectors. This interpreter keeps the same data as Python values, one slot
per dataspace entry that has storage of its own, because that is what makes
it fast enough: a scalar is an ``int`` (its *typed* value: ``-1`` in an
``sbyte``, ``255`` in a ``ubyte``) or a ``float`` (always a representable
float32), an array of ``ubyte`` is a ``bytearray`` (strings are such arrays,
NUL included), any other array a ``list``, and a cluster inside an array
element a ``list`` of its members. The semantics that depend on bytes are kept
exactly: every store wraps to the destination's width and signedness, float
results are rounded to float32, conversions between floats and integers follow
the firmware (``cCmdSetValFlt`` truncates, ``cCmdGetFloat`` rounds half away
from zero), flattening produces the firmware's little-endian byte layout.

:class:`DType` is one node of the dataspace table of contents (DSTOC): a
scalar, an array (``elem``) or a cluster (``members``), with the TOC index it
was read from.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field
from typing import Any

from nxt_link.emulator.vm.opcodes import TC

__all__ = ["DType", "Mutex", "wrap", "to_f32", "int_of", "float_of", "store",
           "default_value", "copy_value", "flatten", "unflatten", "flat_size", "pool_bytes",
           "held_bytes",
           "is_string_type", "UNSIGNED", "SIGNED", "INT_TYPES"]

M32 = 0xFFFFFFFF
_F32 = struct.Struct("<f")
INT_TYPES = frozenset((TC.UBYTE, TC.SBYTE, TC.UWORD, TC.SWORD, TC.ULONG, TC.SLONG))
#: the firmware's QUICK_UNSIGNED_TEST: odd type codes compare unsigned
UNSIGNED = frozenset((TC.UBYTE, TC.UWORD, TC.ULONG))
SIGNED = frozenset((TC.SBYTE, TC.SWORD, TC.SLONG))
_FMT = {TC.UBYTE: "B", TC.SBYTE: "b", TC.UWORD: "H", TC.SWORD: "h", TC.ULONG: "I",
        TC.SLONG: "i", TC.FLOAT: "f"}


@dataclass(eq=False)
class DType:
    """One DSTOC entry and what it describes."""

    tc: int
    index: int
    elem: DType | None = None
    members: tuple[DType, ...] = ()
    #: bytes one element takes in the pool (arrays only; the firmware's layout)
    elem_size: int = 0
    string: bool = field(default=False)
    #: arrays only: the elements hold arrays, whose contents take pool bytes of their own
    nested: bool = False

    @property
    def is_scalar(self) -> bool:
        return self.tc in INT_TYPES or self.tc == TC.FLOAT

    @property
    def name(self) -> str:
        if self.tc == TC.ARRAY:
            assert self.elem is not None
            return f"{self.elem.name}[]"
        if self.tc == TC.CLUSTER:
            return "{" + ", ".join(m.name for m in self.members) + "}"
        return TC.NAMES.get(self.tc, f"type {self.tc}")


class Mutex:
    """A mutex record: the owning clump and the clumps waiting, in order."""

    __slots__ = ("owner", "waiting")

    def __init__(self, owner: int | None = None) -> None:
        self.owner = owner
        self.waiting: list[int] = []


def is_string_type(t: DType) -> bool:
    return t.tc == TC.ARRAY and t.elem is not None and t.elem.tc == TC.UBYTE


# -- scalars -----------------------------------------------------------------------


def wrap(tc: int, v: int) -> int:
    """An integer stored into a scalar of type ``tc`` (two's complement truncation)."""
    if tc == TC.SLONG:
        v &= M32
        return v - 0x100000000 if v & 0x80000000 else v
    if tc == TC.ULONG:
        return v & M32
    if tc == TC.UBYTE:
        return v & 0xFF
    if tc == TC.SWORD:
        v &= 0xFFFF
        return v - 0x10000 if v & 0x8000 else v
    if tc == TC.UWORD:
        return v & 0xFFFF
    if tc == TC.SBYTE:
        v &= 0xFF
        return v - 0x100 if v & 0x80 else v
    raise TypeError(f"not an integer type: {tc}")


def to_f32(x: float) -> float:
    """Round to the nearest float32 (overflow gives an infinity, as on the brick)."""
    try:
        return float(_F32.unpack(_F32.pack(x))[0])
    except OverflowError:
        return math.copysign(math.inf, x)


def _trunc_to_int(x: float) -> int:
    """C's float-to-integer conversion: toward zero. Undefined in C for NaN and
    out-of-range values; here NaN gives 0 and infinities saturate."""
    if x != x:
        return 0
    if math.isinf(x):
        return 0x7FFFFFFF if x > 0 else -0x80000000
    return int(x)


def int_of(tc: int, v: Any) -> int:
    """The firmware's ``cCmdGetVal``: a scalar read as a 32-bit integer.

    Integers read as their value; a float is rounded half away from zero
    (``cCmdGetFloat``)."""
    if tc == TC.FLOAT:
        r = to_f32(v + 0.5) if v >= 0.0 else to_f32(v - 0.5)
        return _trunc_to_int(r)
    return int(v)


def float_of(tc: int, v: Any) -> float:
    """The firmware's ``cCmdGetValFlt``: a scalar converted to float32."""
    if tc == TC.FLOAT:
        return float(v)
    return to_f32(float(v))


def store(tc: int, v: Any) -> Any:
    """A value (int or float) stored into a scalar of type ``tc``.

    An integer wraps; a float stored into an integer truncates toward zero
    (``cCmdSetValFlt``) and then wraps; anything stored into a float is
    rounded to float32."""
    if tc == TC.FLOAT:
        return to_f32(float(v))
    if isinstance(v, float):
        return wrap(tc, _trunc_to_int(v))
    return wrap(tc, v)


# -- aggregates ----------------------------------------------------------------------


def default_value(t: DType) -> Any:
    """A zero value of type ``t`` (new array elements, cleared memory)."""
    if t.tc == TC.FLOAT:
        return 0.0
    if t.tc in INT_TYPES:
        return 0
    if t.tc == TC.ARRAY:
        return bytearray() if t.string else []
    if t.tc == TC.CLUSTER:
        return [default_value(m) for m in t.members]
    if t.tc == TC.MUTEX:
        return Mutex()
    raise TypeError(f"no value for type code {t.tc}")


def copy_value(t: DType, v: Any) -> Any:
    """A deep copy (aggregates are copied by value, like the firmware's moves)."""
    if t.tc == TC.ARRAY:
        assert t.elem is not None
        if t.string:
            return bytearray(v)
        if t.elem.is_scalar:
            return list(v)
        return [copy_value(t.elem, e) for e in v]
    if t.tc == TC.CLUSTER:
        return [copy_value(m, e) for m, e in zip(t.members, v)]
    return v


def pool_bytes(t: DType, v: Any) -> int:
    """Bytes the array value ``v`` of array type ``t`` takes in the firmware's pool: its
    elements, rounded up to 4, and the contents of the arrays they hold (each nested
    array is an array of its own there, behind its own dope vector)."""
    size = len(v) * t.elem_size
    size += (-size) % 4
    if t.nested:
        assert t.elem is not None
        size += sum(held_bytes(t.elem, e) for e in v)
    return size


def held_bytes(t: DType, v: Any) -> int:
    """Pool bytes of the arrays held in a value of type ``t`` (0 for a scalar)."""
    if t.tc == TC.ARRAY:
        return pool_bytes(t, v)
    if t.tc == TC.CLUSTER:
        return sum(held_bytes(m, e) for m, e in zip(t.members, v))
    return 0


def flat_size(t: DType, v: Any) -> int:
    """``cCmdCalcFlattenedSize``: bytes of the flattened value."""
    if t.tc == TC.ARRAY:
        assert t.elem is not None
        if t.elem.is_scalar:
            return TC.SIZE[t.elem.tc] * len(v)
        return sum(flat_size(t.elem, e) for e in v)
    if t.tc == TC.CLUSTER:
        return sum(flat_size(m, e) for m, e in zip(t.members, v))
    return TC.SIZE[t.tc]


def flatten(t: DType, v: Any, out: bytearray) -> None:
    """``cCmdFlattenToByteArray``: scalars little-endian, aggregates in order."""
    if t.tc == TC.ARRAY:
        assert t.elem is not None
        if t.string:
            out += v
        elif t.elem.is_scalar:
            out += struct.pack(f"<{len(v)}{_FMT[t.elem.tc]}", *v)
        else:
            for e in v:
                flatten(t.elem, e, out)
    elif t.tc == TC.CLUSTER:
        for m, e in zip(t.members, v):
            flatten(m, e, out)
    elif t.tc in _FMT:
        out += struct.pack("<" + _FMT[t.tc], v)
    else:
        out += bytes(TC.SIZE[t.tc])


def unflatten(t: DType, template: Any, data: bytes, pos: int) -> tuple[Any, int]:
    """``cCmdUnflattenFromByteArray`` into the shape of ``template``."""
    if t.tc == TC.ARRAY:
        assert t.elem is not None
        n = len(template)
        if t.string:
            return bytearray(data[pos:pos + n]), pos + n
        if t.elem.is_scalar:
            size = TC.SIZE[t.elem.tc]
            vals = list(struct.unpack_from(f"<{n}{_FMT[t.elem.tc]}", data, pos))
            if t.elem.tc == TC.FLOAT:
                vals = [float(x) for x in vals]
            return vals, pos + n * size
        out = []
        for e in template:
            val, pos = unflatten(t.elem, e, data, pos)
            out.append(val)
        return out, pos
    if t.tc == TC.CLUSTER:
        out = []
        for m, e in zip(t.members, template):
            val, pos = unflatten(m, e, data, pos)
            out.append(val)
        return out, pos
    if t.tc in _FMT:
        val = struct.unpack_from("<" + _FMT[t.tc], data, pos)[0]
        return (float(val) if t.tc == TC.FLOAT else val), pos + TC.SIZE[t.tc]
    return template, pos + TC.SIZE[t.tc]
