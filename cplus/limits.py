"""How large a grounding or a horizon may get before it is refused, and why.

A domain can ask for far more than a machine has: a constant over three sorts of 300
objects is 27 million ground atoms, ``maxstep :: 100000000000`` is that many copies of the
transition clauses.  Building such a thing ends with the process killed for lack of memory
(or a ``MemoryError`` deep inside), after minutes.  Instead every stage *estimates* what it
is about to build from counts it already knows (instances = product of the argument sorts,
clauses = transition clauses x steps) and refuses, with the number that was too large, what
cannot fit in the memory the process may use: the soft address-space limit (``ulimit -v``)
when one is set, else the machine's physical memory, halved (the SAT solver's learned
clauses, Python's own overhead and the rest of the pipeline need the other half).

The byte costs are measured averages on CPython 3.11 (a ground atom with its tables, a
grounded rule, a clause inside the solver); they only need to be right within a factor of
two or so to turn "killed after a minute" into "refused at once".
"""
from __future__ import annotations

import os

__all__ = ["memory_budget", "ATOM_BYTES", "INSTANCE_BYTES", "RULE_BYTES", "clause_bytes", "MAX_SOLVER_VARS",
           "fmt", "too_large"]

INSTANCE_BYTES = 400      # a GroundConst with its text, argument tuple and table entries
ATOM_BYTES = 160          # an atom's entries in the atom table and the template layout
RULE_BYTES = 600          # a grounded rule (head literal, body formula), its template form and clauses
MAX_SOLVER_VARS = 2**31 - 2   # solver variables are C ints


def clause_bytes(clauses: int, literals: int) -> int:
    """Memory of clauses inside the solver (clause headers, literals, two watches each)."""
    return 64 * clauses + 8 * literals


def memory_budget() -> int:
    """Bytes a planning run may use for what it builds (half of what the process may have)."""
    limit = _physical()
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY and soft > 0:
            limit = min(limit, soft)
    except (ImportError, ValueError, OSError):  # pragma: no cover - not on this platform
        pass
    return limit // 2


def _physical() -> int:
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not on this platform
        return 8 << 30


def fmt(n: int) -> str:
    """``27,000,000`` (and ``1.0e+17`` past a trillion, where digits stop helping)."""
    return f"{n:,}" if n < 10**12 else f"{float(n):.1e}"


def too_large(what: str, needed_bytes: int) -> str:
    """The common tail of a refusal: what was too large and how much memory it would need."""
    return (f"{what}: that needs about {_gib(needed_bytes)} of memory, more than the "
            f"{_gib(memory_budget())} this run may use")


def _gib(n: int) -> str:
    if n >= 1 << 40:
        return f"{n / (1 << 40):,.0f} TiB"
    return f"{n / (1 << 30):.1f} GiB"
