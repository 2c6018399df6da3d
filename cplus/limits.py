"""How large an input may get, in one place: what the front end accepts, and what grounding and
the horizons may build in the memory the process has.

Hostile or mistaken input (a range of a billion objects, a macro that doubles at every level,
a formula nested a thousand parentheses deep, ``/dev/zero`` given as a domain) must end in a
located error that names the number that was too large, not in a traceback, a hang or the
machine's memory running out.  Sizes are therefore estimated *before* anything is built and
compared with these limits.  They are far above what real domains need (the largest corpus
domain declares a few hundred objects) and low enough that everything below them fits in a
few hundred megabytes.
"""
from __future__ import annotations

import os

__all__ = ["MAX_FILE_BYTES", "MAX_INT", "MAX_NESTING", "MAX_EXPANSION", "MAX_EXPANDED", "MAX_OBJECTS", "MAX_RANGE",
           "MAX_GROUND_CONSTANTS", "MAX_TRIES", "count", "memory_budget", "ATOM_BYTES", "INSTANCE_BYTES", "RULE_BYTES",
           "SUM_PAIR_BYTES", "SUM_VALUE_BYTES",
           "clause_bytes", "MAX_SOLVER_VARS", "too_large", "out_of_memory"]

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

MAX_TRIES = 20_000_000
"""Values grounding may try for one law's variables, whether they pass its conditions or not:
twenty million are five to fifteen seconds of one core (``where X * Y < 0`` tries about three
million a second; ``X * Y * Z = 7`` over ``0..2000`` tries 8 million in five seconds, Z
solved for and X, Y not).  The largest law of the corpus and ``bench/data`` that grounding
does not do with arrays tries 46,000."""


def count(n: int) -> str:
    """A number for an error message: ``27,000,000``, or its magnitude when it is enormous
    (``about 10^300``: printing every digit of a huge integer is itself an error in Python)."""
    if n.bit_length() > 64:
        return f"about {'-' if n < 0 else ''}10^{int(n.bit_length() * 0.30103)}"
    return f"{n:,}"


# --------------------------------------------------------------------------- memory
# A domain can ask for far more than a machine has: ``maxstep :: 100000000000`` is that many
# copies of the transition clauses, a law over three variables of 2,000 values eight billion
# rules.  Grounding and the horizons *estimate* what they are about to build from counts they
# already know and refuse, with the number that was too large, what cannot fit in the memory
# the process may use: the soft address-space limit (``ulimit -v``) when one is set, else the
# machine's physical memory, halved (the SAT solver's learned clauses, Python's own overhead and
# the rest of the pipeline need the other half).  The byte costs are measured averages on
# CPython 3.11; they only need to be right within a factor of two or so to turn "killed after a
# minute" into "refused at once".

INSTANCE_BYTES = 400      # a GroundConst with its text, argument tuple and table entries
ATOM_BYTES = 160          # an atom's entries in the atom table and the template layout
RULE_BYTES = 600          # a grounded rule (head literal, body formula), its template form and clauses
SUM_PAIR_BYTES = 1800     # a partial sum of an additive constant's encoding with one more contribution
SUM_VALUE_BYTES = 2400    # a value of an additive constant (its partial sum, completion and choice)
MAX_SOLVER_VARS = 2**31 - 2   # solver variables are C ints


def clause_bytes(clauses: int, literals: int) -> int:
    """Memory of clauses inside the solver (clause headers, literals, two watches each)."""
    return 64 * clauses + 8 * literals


def memory_budget() -> int:
    """Bytes a planning run may use for what it builds (half of what the process may have)."""
    return _process_limit() // 2


def _process_limit() -> int:
    """What the process may have: its soft address-space limit, else the physical memory."""
    limit = _physical()
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY and soft > 0:
            limit = min(limit, soft)
    except (ImportError, ValueError, OSError):  # pragma: no cover - not on this platform
        pass
    return limit


def _physical() -> int:
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not on this platform
        return 8 << 30


def out_of_memory(doing: str) -> str:
    """The message of a :class:`MemoryError` met while ``doing`` something (``grounding this
    law``): the address-space limit (``ulimit -v``) was reached before any estimate said so."""
    return f"too large: {doing} ran out of memory, more than the {_gib(_process_limit())} this run may use"


def too_large(what: str, needed_bytes: int) -> str:
    """The common tail of a refusal: what was too large and how much memory it would need."""
    return (f"{what}: that needs about {_gib(needed_bytes)} of memory, more than the "
            f"{_gib(memory_budget())} this run may use")


def _gib(n: int) -> str:
    if n >= 1 << 40:
        return f"{n / (1 << 40):,.0f} TiB"
    if n < 1 << 30:
        return f"{n / (1 << 20):.0f} MiB"
    return f"{n / (1 << 30):.1f} GiB"
