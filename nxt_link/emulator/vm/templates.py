"""Pieces of the instruction templates shared by the instruction families.

The common instructions are written as Python source (:meth:`nxt_link.emulator.vm.fuse.Fuser.template`)
so that the fuser can inline them into blocks; these helpers spell the
firmware's integer semantics in that source: storing with the wrap to a
type's width and signedness (:func:`wrap_src`, :func:`wrap_expr`, the same as
:func:`nxt_link.emulator.vm.values.wrap`), whether a wrap is needed at all
(:func:`fits`), and the Python operators of the integer binary operations and
condition codes.
"""
from __future__ import annotations

from nxt_link.emulator.vm import poly
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.values import M32

__all__ = ["wrap_src", "wrap_expr", "fits", "indent", "BINOP_SYMBOLS", "CC_SYMBOLS"]

# Python operators of the integer binops and the condition codes (for templates)
BINOP_SYMBOLS = {poly.OP_ADD: "+", poly.OP_SUB: "-", poly.OP_MUL: "*", poly.OP_AND: "&",
                 poly.OP_OR: "|", poly.OP_XOR: "^"}
CC_SYMBOLS = {0: "<", 1: ">", 2: "<=", 3: ">=", 4: "==", 5: "!="}

#: wrap()'s mask and sign bit per integer type (None: unsigned)
_WRAP_MASKS = {TC.UBYTE: (0xFF, None), TC.SBYTE: (0xFF, 0x80), TC.UWORD: (0xFFFF, None),
               TC.SWORD: (0xFFFF, 0x8000), TC.ULONG: (M32, None),
               TC.SLONG: (M32, 0x80000000)}

_INT_RANGES = {TC.UBYTE: (0, 0xFF), TC.SBYTE: (-0x80, 0x7F), TC.UWORD: (0, 0xFFFF),
               TC.SWORD: (-0x8000, 0x7FFF), TC.ULONG: (0, M32),
               TC.SLONG: (-0x80000000, 0x7FFFFFFF)}


def wrap_src(tc: int, expr: str, dest: str) -> str:
    """Statements of a template storing ``wrap(tc, expr)`` into ``dest``."""
    mask, sign = _WRAP_MASKS[tc]
    if sign is None:
        return f"{dest} = ({expr}) & {mask:#x}"
    return f"v = ({expr}) & {mask:#x}\n{dest} = v - {2 * sign:#x} if v & {sign:#x} else v"


def wrap_expr(tc: int, expr: str) -> str:
    """An expression of ``wrap(tc, expr)``."""
    mask, sign = _WRAP_MASKS[tc]
    if sign is None:
        return f"(({expr}) & {mask:#x})"
    return f"((({expr}) + {sign:#x} & {mask:#x}) - {sign:#x})"


def indent(src: str) -> str:
    return "\n".join("    " + line for line in src.split("\n"))


def fits(src: int, dst: int) -> bool:
    """Every value of integer type ``src`` is a value of integer type ``dst``."""
    if src not in _INT_RANGES or dst not in _INT_RANGES:
        return False
    (lo, hi), (dlo, dhi) = _INT_RANGES[src], _INT_RANGES[dst]
    return dlo <= lo and hi <= dhi
