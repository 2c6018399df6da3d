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

import functools
import sys
from collections.abc import Callable

__all__ = ["encode_table", "encode_full_rows", "TABLE_LIMIT", "TABLE_SMALL"]

TABLE_LIMIT = 1_000_000     # cells (assignments of the body constants) we are willing to build
NONE = -1                   # no value: the assignment is impossible
CONFLICT = -2               # two strong rules with different values fire: impossible


def encode_table(domains: list[tuple], value_lits: list[dict], head_lits: list[int],
                 strong: list[tuple[int, tuple]], weak: list[tuple[int, tuple]],
                 add_clause: Callable[[list[int]], None], new_var: Callable[[], int],
                 at_most_one: Callable[[list[int]], None], cache: dict | None = None) -> bool:
    """Write the table of a constant; False (nothing written) when it does not fit, or when
    weak cubes leave a choice between values somewhere (then it is not a table).
    ``add_clause([])`` means false.

    ``domains[k]`` are the values of body constant k and ``value_lits[k][w]`` the literal of
    ``k=w``; ``head_lits[h]`` is the literal of the constant's h-th value; ``strong`` and
    ``weak`` are cubes ``(h, ((k, w), ...))``.  Small tables are built with lists (numpy's import
    costs more than a small domain's whole run), large ones with numpy arrays.

    ``cache``: the diagrams built so far, by the table's content (domains, cubes); constants
    whose laws are alike (a physics law per axis, a speed rule per car, the same static law
    at the first step and in the transition) share one diagram with their own literals.
    """
    def build(shape: tuple, cells: int):
        index = [{w: i for i, w in enumerate(d)} for d in domains]
        if cells > _SMALL and ("numpy" in sys.modules or cells > _COLD):
            return _build_large(shape, index, strong, weak)
        return _build_small(shape, index, [(h, dict(c)) for h, c in strong], [(h, dict(c)) for h, c in weak])
    return _encode(domains, value_lits, head_lits, lambda: (tuple(domains), len(head_lits), tuple(strong), tuple(weak)),
                   build, add_clause, new_var, at_most_one, cache)


def _encode(domains: list[tuple], value_lits: list[dict], head_lits: list[int], key_of: Callable[[], tuple],
            build: Callable[[tuple, int], tuple | None], add_clause, new_var, at_most_one, cache: dict | None) -> bool:
    """What :func:`encode_table` and :func:`encode_full_rows` share: the size limit, the cache
    of diagrams by the table's content (``key_of()``), ``build(shape, cells)`` on a miss (None:
    not a table), and the clauses."""
    shape = tuple(len(d) for d in domains)
    cells = 1
    for n in shape:
        cells *= n
    if cells > TABLE_LIMIT or not shape:
        return False
    key = key_of() if cache is not None else None
    built: tuple | None | bool = cache.get(key, False) if cache is not None else False
    if built is False:
        built = build(shape, cells)
        if cache is not None:
            cache[key] = built
    if built is None:
        return False
    flat, order, levels = built  # type: ignore[misc]
    _write(flat, levels, [value_lits[k] for k in order], [domains[k] for k in order], head_lits,
           add_clause, new_var, at_most_one)
    return True


def encode_full_rows(domains: list[tuple], value_lits: list[dict], head_lits: list[int], cells, hs,
                     add_clause: Callable[[list[int]], None], new_var: Callable[[], int],
                     at_most_one: Callable[[list[int]], None], cache: dict | None = None) -> bool:
    """:func:`encode_table` for strong cubes that all fix every body constant, given as arrays:
    ``cells[i]`` the flat (row-major) cell of cube i over ``domains``, ``hs[i]`` its value's
    head index.  The array grounder's rules arrive in this shape by the tens of thousands (a
    physics law), and a Python step per cube was most of their template time; the table, and
    so the clauses, are the ones :func:`encode_table` writes for the same cubes."""
    def build(shape: tuple, _cells: int):
        import numpy as np
        table = np.full(shape, NONE, dtype=np.int32)
        _fill(table, cells, hs)
        return _diagram(table)
    return _encode(domains, value_lits, head_lits, lambda: ("full", tuple(domains), len(head_lits), cells.tobytes(),
                                                           hs.tobytes()),
                   build, add_clause, new_var, at_most_one, cache)


_SMALL = TABLE_SMALL = 4096      # cells; above, numpy arrays once numpy is loaded
_COLD = 30000      # ... and above this even when it must be imported for it


def _build_small(shape: tuple, index: list[dict], strong: list, weak: list):
    """(cells in the chosen axis order, the order, node ids per level) with lists."""
    n = len(shape)
    strides = [1] * n
    for k in range(n - 2, -1, -1):
        strides[k] = strides[k + 1] * shape[k + 1]

    def offsets(axes: list) -> list[int]:
        """The flat offsets of the cells ``product(*axes)`` names, in that order: built one
        axis at a time (the last varies fastest), with no Python step per cell and axis."""
        out = [0]
        for k, values in axes:
            st = strides[k]
            steps = [v * st for v in values]
            out = [o + d for o in out for d in steps]
        return out

    def cells_of(cube: dict) -> list[int]:
        return offsets([(k, (index[k][cube[k]],) if k in cube else range(shape[k])) for k in range(n)])
    table = [NONE] * (strides[0] * shape[0])
    for h, cube in strong:
        for c in cells_of(cube):
            v = table[c]
            table[c] = h if v == NONE or v == h else CONFLICT
    soft = [NONE] * len(table)
    for h, cube in weak:
        for c in cells_of(cube):
            if soft[c] not in (NONE, h):
                return None
            soft[c] = h
    table = [NONE if v == CONFLICT else (soft[i] if v == NONE else v) for i, v in enumerate(table)]

    def transposed(perm: list[int]) -> list[int]:
        return [table[c] for c in offsets([(k, range(shape[k])) for k in perm])]

    def distinct(flat: list[int], rows: int) -> list[int]:
        width = len(flat) // rows
        ids: dict[tuple, int] = {}
        return [ids.setdefault(tuple(flat[r * width:(r + 1) * width]), len(ids)) for r in range(rows)]

    def count(perm: list[int], prefix: int) -> int:
        rows = 1
        for k in perm[:prefix]:
            rows *= shape[k]
        return max(distinct(transposed(perm), rows)) + 1

    order = _greedy(n, count)
    flat = transposed(order)
    levels = [[0]]
    rows = 1
    for k in order[:-1]:
        rows *= shape[k]
        levels.append(distinct(flat, rows))
    return flat, order, levels


def _build_large(shape: tuple, index: list[dict], strong: list, weak: list):
    """The same with numpy arrays (views for cubes, hashed rows for sub-tables); the cubes
    as given to :func:`encode_table`."""
    import numpy as np
    table = np.full(shape, NONE, dtype=np.int32)
    n = len(shape)
    full = [(h, cube) for h, cube in strong if len(cube) == n]
    if full:        # rows that fix every body constant: all at once
        stride = [int(np.prod(shape[k + 1:], dtype=np.int64)) for k in range(n)]
        offset = {(k, w): i * stride[k] for k in range(n) for w, i in index[k].items()}   # a cell is their sum
        at = offset.__getitem__
        cells = np.fromiter((sum(map(at, c)) for _, c in full), dtype=np.int64, count=len(full))
        hs = np.fromiter((h for h, _ in full), dtype=np.int32, count=len(full))
        _fill(table, cells, hs)
    for h, cube in strong:
        if len(cube) == n:
            continue
        region = table[_where(dict(cube), index, len(shape))]       # a view: written in place
        region[(region != h) & (region != NONE)] = CONFLICT
        region[region == NONE] = h
    if weak:
        soft = np.full(shape, NONE, dtype=np.int32)
        for h, cube in weak:
            region = soft[_where(dict(cube), index, len(shape))]
            if ((region != NONE) & (region != h)).any():
                return None
            region[...] = h
        table = np.where(table == NONE, soft, table)
    return _diagram(table)


def _fill(table, cells, hs) -> None:
    """Write value ``hs[i]`` into flat cell ``cells[i]`` of ``table``, CONFLICT where two differ."""
    import numpy as np
    by_cell = np.lexsort((hs, cells))
    sc, sh = cells[by_cell], hs[by_cell]
    clash = sc[1:][(sc[1:] == sc[:-1]) & (sh[1:] != sh[:-1])]
    table.flat[cells] = hs
    table.flat[clash] = CONFLICT


def _diagram(table):
    """(cells in the chosen axis order, the order, node ids per level) of a filled table."""
    import numpy as np
    table[table == CONFLICT] = NONE
    hashed = (table + 3).astype(np.uint64)      # distinct positive codes, for row hashing

    def count(perm: list[int], prefix: int) -> int:
        return int(_distinct(table.transpose(perm), prefix, hashed.transpose(perm)).max()) + 1

    order = _greedy(table.ndim, count)
    t = table.transpose(order)
    levels: list[list[int]] = [[0]] + [_first_seen(_distinct(t, i)).tolist() for i in range(1, t.ndim)]
    return t.reshape(-1).tolist(), order, levels


def _greedy(n: int, count) -> list[int]:
    """Axes in the order that keeps the diagram small: greedily, the axis after which the
    fewest distinct sub-tables remain."""
    chosen: list[int] = []
    while len(chosen) < n - 1:
        best, best_count = -1, None
        for k in range(n):
            if k in chosen:
                continue
            perm = chosen + [k] + [j for j in range(n) if j not in chosen and j != k]
            c = count(perm, len(chosen) + 1)
            if best_count is None or c < best_count:
                best, best_count = k, c
        chosen.append(best)
    chosen.extend(k for k in range(n) if k not in chosen)
    return chosen


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


def _distinct(table, prefix: int, hashed=None):
    """Ids of the distinct sub-tables after fixing the first ``prefix`` axes (row-major).

    Rows are grouped by a 64-bit hash (a random linear form, wrapping), then checked
    against their group's first row; only on a collision is the exact (slow) row sort used.
    """
    import numpy as np
    n_rows = int(np.prod(table.shape[:prefix], dtype=np.int64))
    rows = table.reshape(n_rows, -1)
    codes = (table + 3).astype(np.uint64) if hashed is None else hashed
    codes = codes.reshape(n_rows, -1)
    weights = _weights(rows.shape[1])
    with np.errstate(over="ignore"):
        keys = codes @ weights
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    if not (rows == rows[first[inverse]]).all():      # a hash collision: sort the rows themselves
        _, inverse = np.unique(rows, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
    return inverse


@functools.lru_cache(maxsize=64)
def _weights(width: int):
    """The hash's linear form for rows of ``width`` cells: splitmix64 of 1..width (the same
    every run), odd; numbers that look random without ``numpy.random``, whose import cost
    more than a spacecraft's whole table."""
    import numpy as np
    z = (np.arange(1, width + 1, dtype=np.uint64) + np.uint64(width)) * np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return (z ^ (z >> np.uint64(31))) | np.uint64(1)


def _first_seen(ids):
    """Ids renumbered in the order they first occur: the numbering the list builder gives."""
    import numpy as np
    _, first = np.unique(ids, return_index=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[ids]


def _write(flat: list[int], levels: list[list[int]], value_lits: list[dict], domains: list[tuple],
           head_lits: list[int], add_clause, new_var, at_most_one) -> None:
    """Clauses of the diagram: ``levels[i][p]`` is the node reached by prefix p of length i."""
    n = len(levels)
    dead: list[set[int]] = []
    for i in range(n):
        ids = levels[i]
        width = len(flat) // len(ids)
        alive: dict[int, bool] = {}
        for p, node in enumerate(ids):
            if not alive.get(node):
                alive[node] = any(v != NONE for v in flat[p * width:(p + 1) * width])
        dead.append({node for node, ok in alive.items() if not ok})
    lit_of: list[dict[int, int]] = [{} for _ in range(n)]   # node id -> solver literal (level >= 1)
    for i in range(1, n):
        live = sorted(set(levels[i]) - dead[i])
        for j in live:
            lit_of[i][j] = new_var()
        at_most_one([lit_of[i][j] for j in live])
    for i in range(n):
        ids = levels[i]
        first: dict[int, int] = {}
        for p, node in enumerate(ids):
            first.setdefault(node, p)
        d = len(domains[i])
        for node, prefix in first.items():
            if node in dead[i]:
                if i == 0:             # no assignment of the body constants has a value
                    add_clause([])
                continue
            parent = [] if i == 0 else [-lit_of[i][node]]
            if i + 1 < n:
                children = levels[i + 1][prefix * d:(prefix + 1) * d]
                targets = [None if c in dead[i + 1] else lit_of[i + 1][c] for c in children]
            else:
                cells = flat[prefix * d:(prefix + 1) * d]
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
