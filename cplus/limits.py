"""How large an input the front end accepts, in one place.

Hostile or mistaken input (a range of a billion objects, a macro that doubles at every level,
a formula nested a thousand parentheses deep, ``/dev/zero`` given as a domain) must end in a
located error that names the number that was too large, not in a traceback, a hang or the
machine's memory running out.  Sizes are therefore estimated *before* anything is built and
compared with these limits.  They are far above what real domains need (the largest corpus
domain declares a few hundred objects) and low enough that everything below them fits in a
few hundred megabytes.
"""
from __future__ import annotations

__all__ = ["MAX_FILE_BYTES", "MAX_INT", "MAX_NESTING", "MAX_EXPANSION", "MAX_EXPANDED", "MAX_OBJECTS", "MAX_RANGE",
           "MAX_GROUND_CONSTANTS", "count"]

MAX_FILE_BYTES = 1024 * 1024
"""A C+ source file (or standard input): 1 MB, eighty times the largest corpus domain.  The
parser reads 40-80 KB a second, so this bounds parsing to about half a minute and 500 MB."""

MAX_INT = 2**63 - 1
"""Integers (literals and arithmetic folded while resolving) are 64-bit signed."""

MAX_NESTING = 100
"""Nesting depth of one expression after macro expansion: parentheses, negations,
implications, function applications, macro calls.  Long chains of one associative operator
(``a & b & ...``, ``1 + 2 + ...``) are regrouped and do not count against it."""

MAX_EXPANSION = 50_000
"""Nodes of one expression after macro expansion (the corpus's largest: under 300 for a whole
domain; 50,000 take about a second to resolve and ground)."""

MAX_EXPANDED = 4 * MAX_EXPANSION
"""Nodes produced by macro expansion in a whole domain (every use of every macro)."""

MAX_OBJECTS = 1_000_000
"""Objects declared in a domain, all sorts together."""

MAX_RANGE = 1_000_000
"""Integers in one range used as a sort (a constant's domain or argument, a variable's sort)."""

MAX_GROUND_CONSTANTS = 1_000_000
"""Ground instances of all constants together (``c(s1,s2)`` has |s1|*|s2| of them)."""


def count(n: int) -> str:
    """A number for an error message: ``27,000,000``, or its magnitude when it is enormous
    (``about 10^300``: printing every digit of a huge integer is itself an error in Python)."""
    if n.bit_length() > 64:
        return f"about 10^{int(n.bit_length() * 0.30103)}"
    return f"{n:,}"
