"""Clauses from propositional formulas: Tseitin definitions, literal completion, exactly-one.

A :class:`ClauseBuilder` works in any integer variable space; ``new_var`` allocates fresh
variables.  Every auxiliary variable gets a *full* definition (``v <-> formula``), so it is a
function of the atoms: the models of the clauses correspond one to one to the models of
the causal theory, which is what model counting (``-n 0``) and DIMACS export rely on.

Literal completion (NMCT): for every head literal h with bodies B1..Bk,
``h <-> B1 | ... | Bk``.  A body that contains h itself (``default``, ``exogenous``,
inertia) adds nothing to the "<-" direction, and in the "->" direction h may be dropped from
it; a body that is just h makes h free.
"""
from __future__ import annotations

import sys
from collections.abc import Callable, Iterable

from cplus.ground.pf import PF, mk_and, mk_or, neg

__all__ = ["ClauseBuilder", "simplify_units", "compact", "CONFLICT"]

_PAIRWISE_MAX = 24
"""At most one of up to this many literals is written pairwise (at most 276 binary clauses),
of more with a ladder of defined variables.  Glucose propagates binary clauses in watch
lists of their own and never branches on the ladder's variables: hanoi-6-3 (10 values per
move) solves in 0.67 s instead of 0.79, bw-20 (21 locations) in 0.27 instead of 0.32
(medians over shuffled clause orders)."""
_UNIT_PASSES = 100


class ClauseBuilder:
    def __init__(self, new_var: Callable[[], int], sink: Callable[[list[int]], None] | None = None) -> None:
        self.new_var = new_var
        self.clauses: list[list[int]] = []
        self.add_clause = sink if sink is not None else self.clauses.append
        self._defs: dict[tuple, int] = {}
        self._false: int | None = None

    # ------------------------------------------------------------------ Tseitin
    def lit(self, f: PF) -> int:
        """A literal equivalent to ``f`` (introducing defined variables as needed)."""
        if type(f) is int:
            return f
        if f is True or f is False:
            z = self._false_var()
            return -z if f is True else z
        op, items = f  # type: ignore[misc]
        key = (op, frozenset(items))
        v = self._defs.get(key)
        if v is not None:
            return v
        nested = [g for g in items if type(g) is not int]
        lits = [g if type(g) is int else self.lit(g) for g in items] if nested else list(items)
        negated = [-c for c in lits]
        v = self.new_var()
        add = self.add_clause
        if op == "&":
            for c in lits:
                add([-v, c])
            add([v, *negated])
        else:
            add([-v, *lits])
            for c in negated:
                add([v, c])
        self._defs[key] = v
        other = "|" if op == "&" else "&"
        if nested:
            self._defs.setdefault((other, frozenset(-g if type(g) is int else neg(g) for g in items)), -v)
        else:
            self._defs.setdefault((other, frozenset(negated)), -v)
        return v

    def _false_var(self) -> int:
        if self._false is None:
            self._false = self.new_var()
            self.add_clause([-self._false])
        return self._false

    def _clause_lits(self, f: PF) -> list[int] | None:
        """Literals of a clause equivalent to ``f`` (None when f is True)."""
        if f is True:
            return None
        if f is False:
            return []
        if type(f) is int:
            return [f]
        op, items = f  # type: ignore[misc]
        if op == "|":
            return [g if type(g) is int else self.lit(g) for g in items]
        return [self.lit(f)]

    def add(self, f: PF, guard: int = 0) -> None:
        """Assert ``f`` (only when ``guard`` holds, if a guard literal is given).

        A disjunction with one conjunction among its items is distributed over it, which
        costs no variable and no more clauses than the conjunction has items: ``-move(b) |
        (-dest(b)=l1 | -loc(c)=l1) & (-dest(b)=l2 | -loc(c)=l2) & ...`` (a constraint whose
        atom compares two constants) becomes one short clause per value instead of a defined
        variable per value and one for their conjunction."""
        if f is True:
            return
        if type(f) is tuple:
            if f[0] == "&":
                for g in f[1]:
                    self.add(g, guard)
                return
            conj = [g for g in f[1] if type(g) is tuple and g[0] == "&"]
            if len(conj) == 1:
                rest = tuple(g for g in f[1] if g is not conj[0])
                if tuple in map(type, rest):
                    for g in conj[0][1]:
                        self.add(mk_or(rest + (g,)), guard)
                else:
                    self._distribute(rest, conj[0][1], guard)
                return
        lits = self._clause_lits(f)
        assert lits is not None
        if guard:
            lits = lits + [-guard]
        if not lits:
            z = self._false_var()
            self.add_clause([z])
            return
        self.add_clause(lits)

    def _distribute(self, rest: tuple[int, ...], items: tuple, guard: int) -> None:
        """``rest | item`` asserted for each item of a conjunction, ``rest`` literals: what
        :meth:`add` does with ``mk_or(rest + (item,))`` (the same clauses, literals in the same
        order), with no formula built per item where the item is a literal or a clause (a
        blocks world's constraints give tens of thousands of them)."""
        base = list(rest)
        have = set(base)
        if len(have) != len(base) or any(-x in have for x in base):
            for g in items:       # repeated or complementary literals: the general way
                self.add(mk_or(rest + (g,)), guard)
            return
        add_clause = self.add_clause
        for g in items:
            if type(g) is int:
                lits: tuple = (g,)
            elif g[0] == "|" and tuple not in map(type, g[1]):
                lits = g[1]
            else:
                self.add(mk_or(rest + (g,)), guard)
                continue
            clause = base.copy()
            added: set = set()
            for x in lits:
                if x in have or x in added:
                    continue
                if -x in have or -x in added:
                    break                 # a tautology: nothing to assert
                added.add(x)
                clause.append(x)
            else:
                if guard:
                    clause.append(-guard)
                add_clause(clause)

    # ------------------------------------------------------------------ completion
    def complete(self, head: int, bodies: Iterable[PF], free: bool = False) -> None:
        """Literal completion of ``head`` with the bodies of the rules that cause it."""
        alternatives: list[PF] = []
        add = self.add_clause
        for b in bodies:
            if b is False:
                continue
            if type(b) is int:                    # the common shapes first: b -> head directly
                if b == head:
                    free = True
                    alternatives.append(True)
                else:
                    add([head] if b == -head else [-b, head])
                    alternatives.append(b)
                continue
            if (type(b) is tuple and b[0] == "&" and head not in b[1]
                    and not [g for g in b[1] if type(g) is not int]):
                clause = [-g for g in b[1]]
                if -head not in b[1]:
                    clause.append(head)
                add(clause)
                alternatives.append(b)
                continue
            rest = _without(b, head)
            if rest is None:                      # b does not mention head: b -> head
                self.add(mk_or((neg(b), head)))
                alternatives.append(b)
            else:                                 # self-supporting: h -> rest suffices
                if rest is True:
                    free = True
                alternatives.append(rest)
        if free:
            return
        clause = [-head]
        for alt in alternatives:
            if alt is True:
                return
            if type(alt) is int:
                clause.append(alt)
            elif alt[0] == "|":  # type: ignore[index]
                clause.extend(g if type(g) is int else self.lit(g) for g in alt[1])  # type: ignore[index]
            else:
                clause.append(self.lit(alt))
        add(clause)

    # ------------------------------------------------------------------ cardinality
    def exactly_one(self, lits: list[int]) -> None:
        if not lits:          # none to choose from: no model
            self.add(False)
            return
        self.add_clause(list(lits))
        self.at_most_one(lits)  # type: ignore[arg-type]

    def at_most_one(self, lits: list[PF]) -> None:
        ls = [x if type(x) is int else self.lit(x) for x in lits]
        n = len(ls)
        if n <= 1:
            return
        if n <= _PAIRWISE_MAX:
            for i in range(n):
                for j in range(i + 1, n):
                    self.add_clause([-ls[i], -ls[j]])
            return
        # ladder: y_i <-> y_{i-1} | x_i (defined), and not (y_{i-1} & x_i)
        add = self.add_clause
        prev = ls[0]
        for i in range(1, n):
            x = ls[i]
            add([-prev, -x])
            if i == n - 1:
                break
            y = self.new_var()
            add([-y, prev, x])
            add([y, -prev])
            add([y, -x])
            prev = y


def simplify_units(clauses: list[list[int]], keep: int | None = None) -> list[list[int]]:
    """Unit propagation: drop satisfied clauses and false literals, keep the units found.

    The result is equivalent to the input, usually much smaller: a law like
    ``nonexecutable cross(S,W) where S+W > 4`` makes most of an action's ground instances
    false, and every rule and constraint about them disappears.  With ``keep``, units on
    variables above ``keep`` (auxiliary variables, which nothing else mentions once the
    propagation is complete) are dropped too, and their variables with them.

    Large clause sets are propagated with numpy, every clause at once per round (a round
    per level of the propagation), small ones in Python (numpy's import costs more than
    it saves there).
    """
    if not any(len(c) == 1 for c in clauses):
        return clauses
    if len(clauses) >= _NUMPY_FROM and ("numpy" in sys.modules or len(clauses) >= _NUMPY_COLD):
        return _simplify_numpy(clauses, keep)
    return _simplify_python(clauses, keep)


def compact(clauses: list[list[int]], base: int, top: int) -> tuple[list[list[int]], int]:
    """:func:`simplify_units` with ``keep=base``, then the variables above ``base`` still in
    use renumbered densely from ``base + 1``: ``(clauses, new top)``.  ``clauses`` may use
    variables up to ``top``; the result's clauses are :data:`CONFLICT` when there is no model.
    Nothing to propagate: the clauses as they are (every variable above base is in use)."""
    if not any(len(c) == 1 for c in clauses):
        return clauses, top
    if len(clauses) >= _NUMPY_FROM and ("numpy" in sys.modules or len(clauses) >= _NUMPY_COLD):
        out = _simplify_numpy(clauses, base, renumber=True)
        return (out, top) if out is CONFLICT else out
    simple = _simplify_python(clauses, base)
    if simple is CONFLICT:
        return simple, top
    used = sorted({abs(x) for c in simple for x in c if abs(x) > base})
    if len(used) == top - base:
        return simple, top
    renumber = {v: base + i for i, v in enumerate(used, start=1)}
    return ([[x if abs(x) <= base else (renumber[x] if x > 0 else -renumber[-x]) for x in c] for c in simple],
            base + len(used))


_NUMPY_FROM = 20000     # clauses; numpy once it is loaded
_NUMPY_COLD = 60000     # ... and above this even when it must be imported for it
CONFLICT = [[1], [-1]]
"""What :func:`simplify_units` returns when the clauses have no model (compare by identity)."""


def _simplify_python(clauses: list[list[int]], keep: int | None) -> list[list[int]]:
    value: dict[int, bool] = {}
    for c in clauses:
        if not c:
            return CONFLICT
        if len(c) == 1:
            lit = c[0]
            if value.get(abs(lit), lit > 0) != (lit > 0):
                return CONFLICT
            value[abs(lit)] = lit > 0
    current = [c for c in clauses if len(c) > 1]
    complete = False
    for _ in range(_UNIT_PASSES):
        found = False
        rest: list[list[int]] = []
        for c in current:
            kept = []
            satisfied = False
            for lit in c:
                v = value.get(lit if lit > 0 else -lit)
                if v is None:
                    kept.append(lit)
                elif v == (lit > 0):
                    satisfied = True
                    break
            if satisfied:
                continue
            if not kept:
                return CONFLICT
            if len(kept) == 1:
                lit = kept[0]
                value[abs(lit)] = lit > 0
                found = True
                continue
            rest.append(kept if len(kept) < len(c) else c)
        current = rest
        if not found:          # a whole pass without news: no clause mentions an assigned variable
            complete = True
            break
    limit = keep if (keep is not None and complete) else None
    units = [[v if b else -v] for v, b in value.items() if limit is None or v <= limit]
    return units + current


def _simplify_numpy(clauses: list[list[int]], keep: int | None, renumber: bool = False):
    from itertools import chain

    import numpy as np
    n = len(clauses)
    lens = np.fromiter(map(len, clauses), dtype=np.int64, count=n)
    if not lens.all():
        return CONFLICT
    flat = np.fromiter(chain.from_iterable(clauses), dtype=np.int64, count=int(lens.sum()))
    starts = np.zeros(n, dtype=np.int64)
    np.cumsum(lens[:-1], out=starts[1:])
    cid = np.repeat(np.arange(n), lens)
    var = np.abs(flat)
    sign = np.where(flat > 0, 1, -1).astype(np.int8)
    val = np.zeros(int(var.max()) + 1, dtype=np.int8)     # 1 true, -1 false, 0 unassigned

    def assign(lits) -> bool:
        v, sg = np.abs(lits), np.where(lits > 0, 1, -1).astype(np.int8)
        order = np.argsort(v, kind="stable")
        v, sg = v[order], sg[order]
        same = v[1:] == v[:-1]
        if (same & (sg[1:] != sg[:-1])).any():
            return False
        val[v] = sg
        return True

    if not assign(flat[starts[lens == 1]]):
        return CONFLICT
    while True:
        lv = val[var] * sign
        sat = np.add.reduceat((lv == 1).astype(np.int32), starts) > 0
        free = np.add.reduceat((lv == 0).astype(np.int32), starts)
        open_ = ~sat
        if (open_ & (free == 0)).any():
            return CONFLICT
        unit = open_ & (free == 1)
        if not unit.any():
            break
        if not assign(flat[(lv == 0) & unit[cid]]):
            return CONFLICT
    keep_lit = (lv == 0) & (open_ & (free > 1))[cid]
    kept_arr = flat[keep_lit]
    new_top = 0
    if renumber:       # the variables above keep still in use, numbered densely after it
        assert keep is not None
        a = np.abs(kept_arr)
        aux = a > keep
        used = np.unique(a[aux])
        mapping = np.zeros(int(a.max(initial=0)) + 1, dtype=np.int64)
        mapping[used] = np.arange(keep + 1, keep + 1 + len(used))
        kept_arr = np.where(aux, np.sign(kept_arr) * mapping[a], kept_arr)
        new_top = keep + len(used)
    kept = kept_arr.tolist()
    kept_lens = free[open_ & (free > 1)].tolist()
    out: list[list[int]] = []
    assigned = np.nonzero(val)[0]
    if keep is not None:
        assigned = assigned[assigned <= keep]
    out.extend([int(v) if val[v] > 0 else -int(v)] for v in assigned.tolist())
    i = 0
    for k in kept_lens:
        out.append(kept[i:i + k])
        i += k
    return (out, new_top) if renumber else out


def _without(body: PF, head: int) -> PF | None:
    """``body`` minus the conjunct ``head``; None when head is not a conjunct of body."""
    if type(body) is int and body == head:   # (True == 1 in Python: compare ints only)
        return True
    if type(body) is tuple and body[0] == "&" and head in body[1]:
        return mk_and(g for g in body[1] if g != head)
    return None
