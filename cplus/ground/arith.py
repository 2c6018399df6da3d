"""Integer arithmetic with CCALC's rounding: ``//`` truncates toward zero and ``mod``
takes the sign of the divisor (Prolog's ``//`` and ``mod``; Python's ``//`` floors).

>>> apply_arith("//", [-7, 2]), apply_arith("mod", [-7, 2])
(-3, 1)
"""
from __future__ import annotations

__all__ = ["apply_arith", "ARITH_FUNCTIONS"]


def _div(a: int, b: int) -> int:
    if b == 0:
        raise ZeroDivisionError
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def _mod(a: int, b: int) -> int:
    if b == 0:
        raise ZeroDivisionError
    return a % b


ARITH_FUNCTIONS = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "//": _div,
    "mod": _mod,
    "neg": lambda a: -a,
    "abs": abs,
    "min": min,
    "max": max,
}


def apply_arith(op: str, args: list) -> int:
    """Apply an arithmetic operator to integers (callers check the operands are ints)."""
    return ARITH_FUNCTIONS[op](*args)  # type: ignore[operator]
