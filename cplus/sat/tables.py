"""Completion of a constant whose rules are tables, as a decision diagram.

When every rule for a constant ``c`` (at one slot) has a body that is a conjunction of
atoms ``d=w`` of *other* constants — a *cube* — the causal laws for ``c`` define a table:
for each assignment of the body constants, the value ``c`` must take, or none (the
assignment is impossible).  Self-supporting rules (inertia: ``c=v <= c=v & c@0=v``) take part
as *weak* cubes: they give the value when no other rule fires.  Given the exactly-one axiom
of ``c`` this table *is* the literal completion together with the rules themselves.

The table is built as an array and written as a multi-valued decision diagram: the body
constants are taken in an order that keeps it small (chosen greedily, by counting the
distinct sub-tables after each prefix), equal sub-tables share one node, and each node is
a solver variable with one clause per outgoing edge (``node & d=w -> child``) plus an
at-most-one over the nodes of each level, so every node variable is a function of the
atoms (model counts do not move).  A physics law ``pos' = pos + (vel + vel')/2`` over 31
values each becomes about two thousand short clauses through one node per sum, where the
plain table needs a clause per cell (30,000).
"""
from __future__ import annotations

from collections.abc import Callable

__all__ = ["encode_table", "TABLE_LIMIT"]

TABLE_LIMIT = 1_000_000     # cells (assignments of the body constants) we are willing to build
NONE = -1                   # no value: the assignment is impossible
CONFLICT = -2               # two strong rules with different values fire: impossible


def encode_table(domains: list[tuple], value_lits: list[dict], head_lits: list[int],
                 strong: list[tuple[int, dict]], weak: list[tuple[int, dict]],
                 add_clause: Callable[[list[int]], None], new_var: Callable[[], int],
                 at_most_one: Callable[[list[int]], None]) -> bool:
    """Write the table of a constant; False (nothing written) when it does not fit, or when
    weak cubes leave a choice between values somewhere (then it is not a table).
    ``add_clause([])`` means false.

    ``domains[k]`` are the values of body constant k and ``value_lits[k][w]`` the literal of
    ``k=w``; ``head_lits[h]`` is the literal of the constant's h-th value; ``strong`` and
    ``weak`` are cubes ``(h, {k: w})``.
    """
    import numpy as np
    shape = tuple(len(d) for d in domains)
    cells = 1
    for n in shape:
        cells *= n
    if cells > TABLE_LIMIT or not shape:
        return False
    index = [{w: i for i, w in enumerate(d)} for d in domains]
    table = np.full(shape, NONE, dtype=np.int32)
    for h, cube in strong:
        region = table[_where(cube, index, len(shape))]       # a view: written in place
        region[(region != h) & (region != NONE)] = CONFLICT
        region[region == NONE] = h
    if weak:
        soft = np.full(shape, NONE, dtype=np.int32)
        for h, cube in weak:
            region = soft[_where(cube, index, len(shape))]
            if ((region != NONE) & (region != h)).any():
                return False        # a choice between weak values: not a table
            region[...] = h
        table = np.where(table == NONE, soft, table)
    table[table == CONFLICT] = NONE
    order = _order(table)
    _write(table.transpose(order), [value_lits[k] for k in order], [domains[k] for k in order], head_lits,
           add_clause, new_var, at_most_one)
    return True


def _where(cube: dict, index: list[dict], n: int) -> tuple:
    """The cells of a cube, as a view (fixed axes are slices of width one)."""
    out = []
    for k in range(n):
        if k in cube:
            i = index[k][cube[k]]
            out.append(slice(i, i + 1))
        else:
            out.append(slice(None))
    return tuple(out)


def _distinct(table, prefix: int):
    """Ids of the distinct sub-tables after fixing the first ``prefix`` axes (row-major).

    Rows are grouped by a 64-bit hash (a random linear form, wrapping), then checked
    against their group's first row; only on a collision is the exact (slow) row sort used.
    """
    import numpy as np
    rows = np.ascontiguousarray(table.reshape(int(np.prod(table.shape[:prefix], dtype=np.int64)), -1))
    weights = np.random.default_rng(len(rows[0])).integers(1, 2**63, size=rows.shape[1], dtype=np.uint64)
    with np.errstate(over="ignore"):
        keys = ((rows.astype(np.uint64) + np.uint64(3)) * weights).sum(axis=1, dtype=np.uint64)
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    if not (rows == rows[first[inverse]]).all():      # a hash collision: sort the rows themselves
        _, inverse = np.unique(rows, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
    return inverse


def _order(table) -> list[int]:
    """Axes in the order that keeps the diagram small: greedily, the axis after which the
    fewest distinct sub-tables remain."""
    n = table.ndim
    chosen: list[int] = []
    while len(chosen) < n - 1:
        best, best_count = -1, None
        for k in range(n):
            if k in chosen:
                continue
            perm = chosen + [k] + [j for j in range(n) if j not in chosen and j != k]
            count = int(_distinct(table.transpose(perm), len(chosen) + 1).max()) + 1
            if best_count is None or count < best_count:
                best, best_count = k, count
        chosen.append(best)
    chosen.extend(k for k in range(n) if k not in chosen)
    return chosen


def _write(table, value_lits: list[dict], domains: list[tuple], head_lits: list[int],
           add_clause, new_var, at_most_one) -> None:
    import numpy as np
    n = table.ndim
    # node ids per prefix, for every level 0..n-1 (level 0: the root, one prefix)
    levels = [np.zeros(1, dtype=np.int64)] + [_distinct(table, i) for i in range(1, n)]
    # a node whose sub-table is all NONE is "impossible": no variable for it
    flat = table.reshape(-1)
    dead: list[set[int]] = []
    for i in range(n):
        ids = levels[i]
        width = flat.size // ids.size
        alive = (flat.reshape(ids.size, width) != NONE).any(axis=1)
        dead.append(set(np.unique(ids[~alive]).tolist()))
    lit_of: list[dict[int, int]] = [{} for _ in range(n)]   # node id -> solver literal (level >= 1)
    for i in range(1, n):
        ids = np.unique(levels[i]).tolist()
        live = [j for j in ids if j not in dead[i]]
        for j in live:
            lit_of[i][j] = new_var()
        at_most_one([lit_of[i][j] for j in live])
    for i in range(n):
        ids = levels[i]
        first = _first_prefix(ids)
        d = len(domains[i])
        for node, prefix in first.items():
            if node in dead[i]:
                if i == 0:             # no assignment of the body constants has a value
                    add_clause([])
                continue
            parent = [] if i == 0 else [-lit_of[i][node]]
            if i + 1 < n:
                children = [int(c) for c in levels[i + 1][prefix * d:(prefix + 1) * d]]
                targets = [None if c in dead[i + 1] else lit_of[i + 1][c] for c in children]
            else:
                cells = flat[prefix * d:(prefix + 1) * d].tolist()
                targets = [None if c == NONE else head_lits[c] for c in cells]
            if len(set(targets)) == 1:          # the value of this constant does not matter here
                t = targets[0]
                add_clause(parent + ([t] if t is not None else []))
                continue
            for w, t in zip(domains[i], targets):
                clause = parent + [-value_lits[i][w]]
                if t is not None:
                    clause.append(t)
                add_clause(clause)


def _first_prefix(ids) -> dict[int, int]:
    """For each node id, the first prefix (row) that reaches it."""
    import numpy as np
    uniq, first = np.unique(ids, return_index=True)
    return dict(zip(uniq.tolist(), first.tolist()))
