"""Number formatting for messages: short, and integers without decimals."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["fmt", "fmt_point"]


def fmt(value: float) -> str:
    """``3`` for 3.0, ``2.5`` for 2.5, four significant digits otherwise.

    >>> fmt(3.0), fmt(2.5), fmt(1 / 3)
    ('3', '2.5', '0.3333')
    """
    v = float(value)
    if v.is_integer() and abs(v) < 1e12:
        return str(int(v))
    return f"{v:.4g}"


def fmt_point(point: Sequence[float]) -> str:
    """``(2, 0.5)``."""
    return f"({fmt(point[0])}, {fmt(point[1])})"
