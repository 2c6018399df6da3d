"""Ground a law over all its bindings at once, with arrays.

The closures of :mod:`cplus.ground.compile` cost a few microseconds per binding; a physics
law over three integer fluents of a few hundred values has tens of thousands of bindings per
instance, and an ASP grounder does the same joins in C.  Most such laws have one shape:

    caused c(args) = E  if  d1(args1) = X1 & ...  after  e1(...) = Y1 & ...  where W

with atoms whose arguments and values are variables or objects, a head value ``E`` and
conditions ``W`` that are integer arithmetic and comparisons over the variables.  For that
shape every binding is a cell of an array with one axis per variable, taken in the order
:func:`~cplus.ground.compile.bind` would bind them; conditions and arithmetic are evaluated
on whole arrays (CCALC's rounding: ``//`` truncates, ``mod`` takes the divisor's sign), atom
ids are gathered from small lookup tables, and the rules come out in exactly the order, and
with exactly the bodies, the closures would have produced — the rest of the pipeline cannot
tell the difference.  Any other shape (negated or nested atoms, constants inside terms,
externals, time stamps) returns None and goes the ordinary way.
"""
from __future__ import annotations

import sys
from itertools import product, repeat

from cplus import ir
from cplus.ground.compile import binding_levels, domain_of
from cplus.signature import KindSort, StepSort, order_key

__all__ = ["ground_vectorized", "MIN_CELLS", "MAX_CELLS"]

MIN_CELLS = 2048          # fewer bindings: the closures are as fast as setting up arrays
COLD_CELLS = 30000        # ... and while numpy is not loaded yet, its import (70 ms) must pay too
MAX_CELLS = 4_000_000     # more: the arrays themselves get large


class _Unsupported(Exception):
    """This law (or one of its bindings) needs the ordinary path."""


_CMP = {"=": "eq", "==": "eq", "\\=": "ne", "\\==": "ne", "<": "lt", ">": "gt", "=<": "le", ">=": "ge",
        "@<": "lt", "@>": "gt", "@=<": "le", "@>=": "ge"}


def ground_vectorized(grounder, law, variables: dict[str, ir.Var], filters: list,
                      head_slot: int, joins: list | None = None) -> tuple[list, list] | None:
    """``(rules, constraints)`` of a law as :meth:`_Grounder._law` would append them, or
    None when the law does not have the vectorisable shape.

    ``joins`` (restricted grounding, :mod:`cplus.ground.restrict`): ``(atom, pattern, rows)``
    per body atom whose instances are limited to ``rows``, the ``(*args, value)`` of the atoms
    allowed.  The first one, and every later one that shares no variable with those before,
    becomes one axis of its own (its rows bind its variables together); the others filter
    the cells.  Only the bindings where every such atom is allowed are ground."""
    try:
        return _Law(grounder, law, variables, filters, head_slot, joins or ()).run()
    except _Unsupported:
        return None


class _Law:
    def __init__(self, grounder, law, variables, filters, head_slot: int, joins=()) -> None:
        self.g = grounder
        self.law = law
        self.sig = grounder.sig
        self.head_slot = head_slot
        if law.frame is not None:
            raise _Unsupported
        self.head = None
        if law.head is not None:
            heads = list(ir.conjuncts(law.head))
            if len(heads) != 1 or not _plain_atom(heads[0], head=True):
                raise _Unsupported
            self.head = heads[0]
        self.conds: list = []
        self.atoms: list[tuple[ir.Atom, int]] = []      # body atoms, then after atoms (the closures' order)
        for formula, slot in ((law.where, head_slot), (law.body, head_slot), (law.after, 0)):
            for c in ir.conjuncts(formula):
                if isinstance(c, ir.Truth):
                    if not c.value:
                        self.conds.append(False)
                    continue
                if isinstance(c, ir.Cmp) and not ir.constants_in(c):
                    self.conds.append(c)
                elif isinstance(c, ir.Not) and isinstance(c.arg, ir.Cmp) and not ir.constants_in(c):
                    self.conds.append(c)
                elif isinstance(c, ir.Atom) and _plain_atom(c, head=False):
                    self.atoms.append((c, slot))
                else:
                    raise _Unsupported
        for v in variables.values():
            if isinstance(v.sort, (KindSort, StepSort)):
                raise _Unsupported
        if "numpy" not in sys.modules or joins:      # too few cells, known before any axis is built
            most = 1
            joined: set[str] = set()
            for _, pattern, rows in joins:
                most *= len(rows)
                joined.update(x for is_var, x in pattern if is_var)
            for n, v in variables.items():
                if n not in joined:
                    most *= len(domain_of(self.sig, v, {}))
            if most < MIN_CELLS or (most < COLD_CELLS and "numpy" not in sys.modules):
                raise _Unsupported
        # axes: (variable names, rows of their values); a plain variable has one per value
        self.axes: list[tuple[list[str], list[tuple]]] = []
        self.masks: list[tuple[object, list]] = []      # joined atoms that filter cells
        bound: set[str] = set()
        for node, pattern, rows in joins:
            names = list(dict.fromkeys(x for is_var, x in pattern if is_var))
            if bound.intersection(names):
                self.masks.append((node, rows))
                continue
            self.axes.append((names, _relation(self.sig, variables, pattern, names, rows)))
            bound.update(names)
        rest = {n: v for n, v in variables.items() if n not in bound}
        for name, dom, _ in binding_levels(self.sig, rest, filters):
            self.axes.append(([name], [(v,) for v in dom]))
        self.where: dict[str, tuple[int, int]] = {n: (i, k) for i, (names, _) in enumerate(self.axes)
                                                 for k, n in enumerate(names)}
        cells = 1
        for _, rows in self.axes:
            cells *= len(rows)
        if not MIN_CELLS <= cells <= MAX_CELLS or (cells < COLD_CELLS and "numpy" not in sys.modules):
            raise _Unsupported
        self.shape = tuple(len(rows) for _, rows in self.axes)

    def values(self, name: str) -> list:
        """The value of a variable along its axis."""
        i, k = self.where[name]
        return [row[k] for row in self.axes[i][1]]

    # ------------------------------------------------------------------ values
    def _var(self, name: str) -> tuple:
        """(numbers, where they are integers, ranks) of a variable, shaped to broadcast."""
        import numpy as np
        i = self.where[name][0]
        shape = [1] * len(self.shape)
        shape[i] = self.shape[i]
        dom = self.values(name)
        isint = np.array([type(v) is int for v in dom]).reshape(shape)
        num = np.array([v if type(v) is int else 0 for v in dom], dtype=np.int64).reshape(shape)
        rank = np.array([self._rank(v) for v in dom], dtype=np.int64).reshape(shape)
        return num, isint, rank

    def _rank(self, v) -> int:
        ranks = self.__dict__.setdefault("_ranks", {})
        r = ranks.get(v)
        if r is None:
            raise _Unsupported
        return r

    def _prepare_ranks(self) -> None:
        """A rank for every object the law can compare, in Prolog's standard order."""
        objs: set = set()
        for _, rows in self.axes:
            for row in rows:
                objs.update(row)
        for c in self.conds:
            if c is not False:
                _literals(c, objs)
        self._ranks = {v: i for i, v in enumerate(sorted(objs, key=order_key))}

    def _term(self, t) -> tuple:
        """(numbers or None, valid mask, ranks or None) of a constant-free term."""
        import numpy as np
        if isinstance(t, ir.Lit):
            v = t.value
            num = np.int64(v) if type(v) is int else None
            return num, np.bool_(True), np.int64(self._rank(v))
        if isinstance(t, ir.Var):
            return self._var(t.name)      # numbers valid where the object is an integer
        if isinstance(t, ir.Arith):
            valid = np.bool_(True)
            nums = []
            for num, ok, _ in (self._term(a) for a in t.args):
                if num is None:           # a non-integer object: undefined arithmetic
                    return np.int64(0), np.bool_(False), None
                valid = valid & ok
                nums.append(num)
            return _arith(t.op, nums, valid), valid, None
        raise _Unsupported

    def _condition(self, c):
        import numpy as np
        if c is False:
            return np.bool_(False)
        if isinstance(c, ir.Not):
            return ~self._condition(c.arg)
        op = _CMP.get(c.op)
        if op is None:
            raise _Unsupported
        (na, va, ra), (nb, vb, rb) = self._term(c.left), self._term(c.right)
        fn = getattr(np, {"eq": "equal", "ne": "not_equal", "lt": "less", "gt": "greater", "le": "less_equal",
                          "ge": "greater_equal"}[op])
        if ra is not None and rb is not None:      # objects: standard order (numeric on integers)
            return fn(ra, rb)
        # arithmetic on a side: integers compare as numbers, undefined arithmetic is false; an
        # object that is not an integer would compare by standard order: not handled here
        if na is None or nb is None or not (_all_int(c.left, self) and _all_int(c.right, self)):
            raise _Unsupported
        return fn(na, nb) & va & vb

    # ------------------------------------------------------------------ atoms
    def _atom_ids(self, atom: ir.Atom, slot: int, head: bool):
        """Signed template literal codes of an atom per cell (0: no such atom)."""
        import numpy as np
        cst = atom.cst
        assert isinstance(cst, ir.Cst)
        args_of: list = list(cst.args)
        instances = cst.decl.instances
        lit_of = self.g.atoms.lit
        rigid = self.g.rigid
        arg_vars = [a.name for a in args_of if isinstance(a, ir.Var)]
        value_var = atom.value.name if isinstance(atom.value, ir.Var) else None
        computed = head and not isinstance(atom.value, (ir.Var, ir.Lit))
        used = arg_vars + ([value_var] if value_var and not computed else [])
        axes = sorted({self.where[n][0] for n in used})
        sub = [self.axes[i][1] for i in axes]
        pos = {n: (axes.index(self.where[n][0]), self.where[n][1]) for n in used}

        def code(aid: int) -> int:
            if aid == 0:
                return 0
            a = aid if aid > 0 else -aid
            c = a * 3 + (2 if rigid[a] else slot) + 1
            return c if aid > 0 else -c
        if not computed:
            table = np.zeros([len(d) for d in sub] or [1], dtype=np.int64)
            for ix, vals in zip(product(*(range(len(d)) for d in sub)), product(*sub)):
                args = tuple(_at(vals, pos[a.name]) if isinstance(a, ir.Var) else a.value for a in args_of)
                gc = instances.get(args)
                if gc is None:
                    continue
                value = _at(vals, pos[value_var]) if value_var else atom.value.value  # type: ignore[union-attr]
                table[ix or (0,)] = code(lit_of(gc, value))
            return self._spread(table, axes), None
        # a head whose value is computed: one lookup row per ground instance
        gcs: list = []
        gidx = np.zeros([len(d) for d in sub] or [1], dtype=np.int64)
        for ix, vals in zip(product(*(range(len(d)) for d in sub)), product(*sub)):
            args = tuple(_at(vals, pos[a.name]) if isinstance(a, ir.Var) else a.value for a in args_of)
            gc = instances.get(args)
            gidx[ix or (0,)] = len(gcs)
            gcs.append(gc)
        num, valid, _ = self._term(atom.value)
        ints = sorted({v for gc in gcs if gc is not None for v in gc.domain if type(v) is int})
        lo = ints[0] if ints else 0
        width = (ints[-1] - lo + 1) if ints else 1
        if width > 10 * (len(ints) + 1000):
            raise _Unsupported
        lookup = np.zeros((len(gcs), width), dtype=np.int64)
        for gi, gc in enumerate(gcs):
            if gc is None:
                continue
            for v in gc.domain:
                if type(v) is int:
                    lookup[gi, v - lo] = code(lit_of(gc, v))
        g = self._spread(gidx, axes)
        off = np.broadcast_to(num, self.shape) - lo
        inside = np.broadcast_to(valid, self.shape) & (off >= 0) & (off < width)
        out = np.where(inside, lookup[np.broadcast_to(g, self.shape), np.clip(off, 0, width - 1)], 0)
        return out, (gcs, g, num, valid)

    def _allowed(self, atom: ir.Atom, rows: list):
        """A flag per atom id: whether a joined atom may be that one."""
        import numpy as np
        atoms = self.g.atoms
        flags = np.zeros(len(atoms) + 2, dtype=bool)      # index -1 (no atom) stays False
        instances = atom.cst.decl.instances  # type: ignore[union-attr]
        for *args, value in rows:
            gc = instances.get(tuple(args))
            if gc is not None:
                flags[atoms.lit(gc, value)] = True
        return flags

    def _spread(self, table, axes: list[int]):
        """A table over some axes, shaped to broadcast over all of them."""
        shape = [1] * len(self.shape)
        for i in axes:
            shape[i] = self.shape[i]
        return table.reshape(shape)

    # ------------------------------------------------------------------ run
    def run(self) -> tuple[list, list]:
        import numpy as np
        self._prepare_ranks()
        mask = np.ones(self.shape, dtype=bool)
        for c in self.conds:
            mask &= self._condition(c)
        lits = []
        for atom, slot in self.atoms:
            ids = np.broadcast_to(self._atom_ids(atom, slot, head=False)[0], self.shape)
            mask &= ids != 0
            for node, rows in self.masks:
                if node is atom:
                    mask &= self._allowed(atom, rows)[(np.abs(ids) - 1) // 3]
            lits.append(ids)
        head_ids = info = None
        if self.head is not None:
            head_ids, info = self._atom_ids(self.head, self.head_slot, head=True)
            head_ids = np.broadcast_to(head_ids, self.shape)
        cells = np.flatnonzero(mask)
        cols = [lit.reshape(-1)[cells] for lit in lits]
        # mk_and: first occurrences kept; a literal and its complement make the body false
        clash = np.zeros(len(cells), dtype=bool)
        dup = np.zeros(len(cells), dtype=bool)
        for j in range(len(cols)):
            for i in range(j):
                clash |= cols[j] == -cols[i]
                dup |= cols[j] == cols[i]
        if dup.any() or clash.any():
            raise _Unsupported        # rare: the closures handle it
        if not cols:
            bodies: list = [True] * len(cells)
        elif len(cols) == 1:
            bodies = cols[0].tolist()
        else:
            bodies = list(zip(repeat("&"), zip(*(c.tolist() for c in cols))))   # ("&", literals), built in C
        if self.head is None:
            return [], bodies
        heads = head_ids.reshape(-1)[cells]  # type: ignore[union-attr]
        if not (heads == 0).any():
            return list(zip(heads.tolist(), bodies)), []
        if info is None:
            raise _Unsupported       # no instance, or a value outside the domain: the closures tell which
        rules, constraints = [], []
        missing = heads == 0
        gcs, g, _, _ = info
        no_instance = np.array([gc is None for gc in gcs])[np.broadcast_to(g, self.shape).reshape(-1)[cells]]
        if (missing & no_instance).any():
            raise _Unsupported
        first = int(np.flatnonzero(missing)[0])
        self._warn(info, int(cells[first]))
        for h, body, miss in zip(heads.tolist(), bodies, missing.tolist()):
            if miss:
                constraints.append(body)
            else:
                rules.append((h, body))
        return rules, constraints

    def _warn(self, info, cell: int) -> None:
        """The ordinary path's warning for a head value outside the domain (or a head
        constant with no instance there: the closures skip those, so we must too)."""
        from cplus.ground.compile import UNDEF
        gcs, g, num, valid = info
        import numpy as np
        gi = int(np.broadcast_to(g, self.shape).reshape(-1)[cell])
        gc = gcs[gi]
        if gc is None:
            raise _Unsupported
        ok = bool(np.broadcast_to(valid, self.shape).reshape(-1)[cell])
        val = int(np.broadcast_to(num, self.shape).reshape(-1)[cell]) if ok else UNDEF
        self.g._warn_domain(self.head.loc, gc, val)  # type: ignore[union-attr]


def _at(vals: tuple, where: tuple[int, int]):
    """The value of a variable in one combination of axis rows."""
    return vals[where[0]][where[1]]


def _relation(sig, variables: dict, pattern: tuple, names: list[str], rows: list) -> list[tuple]:
    """The rows of a joined atom as an axis (:func:`matching`, over the variables' sorts)."""
    from cplus.ground.compile import domain_of
    return matching(pattern, names, {n: set(domain_of(sig, variables[n], {})) for n in names}, rows)


def matching(pattern: tuple, names: list[str], doms: dict, rows) -> list[tuple]:
    """The values of an atom's variables (in ``names`` order) in every row (its arguments
    and value) that matches its ``pattern`` of ``(is_var, variable or object)``: the
    objects, a variable's repeats, and each variable's values ``doms[name]``."""
    out = []
    for row in rows:
        got: dict = {}
        for (is_var, x), v in zip(pattern, row):
            if not is_var:
                if v != x:
                    break
            elif x in got:
                if got[x] != v:
                    break
            elif v in doms[x]:
                got[x] = v
            else:
                break
        else:
            out.append(tuple(got[n] for n in names))
    return out


def _plain_atom(f, head: bool) -> bool:
    """``c(args) = value`` with arguments variables or objects; the value a variable or an
    object (or, in a head, constant-free integer arithmetic)."""
    if not isinstance(f, ir.Atom) or not isinstance(f.cst, ir.Cst):
        return False
    if not all(isinstance(a, (ir.Var, ir.Lit)) for a in f.cst.args):
        return False
    if isinstance(f.value, (ir.Var, ir.Lit)):
        return True
    return head and isinstance(f.value, ir.Arith) and not ir.constants_in(f.value) and _arith_only(f.value)


def _arith_only(t) -> bool:
    if isinstance(t, (ir.Var, ir.Lit)):
        return True
    return isinstance(t, ir.Arith) and all(_arith_only(a) for a in t.args)


def _literals(f, acc: set) -> None:
    if isinstance(f, ir.Not):
        _literals(f.arg, acc)
    elif isinstance(f, ir.Lit):
        acc.add(f.value)
    elif isinstance(f, ir.Cmp):
        _literals(f.left, acc)
        _literals(f.right, acc)
    elif isinstance(f, ir.Arith):
        for a in f.args:
            _literals(a, acc)


def _all_int(t, law: _Law) -> bool:
    if isinstance(t, ir.Lit):
        return type(t.value) is int
    if isinstance(t, ir.Var):
        return all(type(v) is int for v in law.values(t.name))
    return True


def _arith(op: str, nums: list, valid):
    import numpy as np
    if op == "+":
        return nums[0] + nums[1]
    if op == "-":
        return nums[0] - nums[1]
    if op == "*":
        return nums[0] * nums[1]
    if op in ("//", "mod"):
        a, b = nums
        if (np.broadcast_to(b == 0, np.broadcast_shapes(np.shape(a), np.shape(b), np.shape(valid)))
                & valid).any():
            raise _Unsupported          # the closures report the division by zero, located
        safe = np.where(b == 0, 1, b)
        if op == "mod":
            return np.mod(a, safe)
        q = np.abs(a) // np.abs(safe)
        return np.where((a >= 0) == (safe >= 0), q, -q)
    if op == "neg":
        return -nums[0]
    if op == "abs":
        return np.abs(nums[0])
    if op == "min":
        out = nums[0]
        for x in nums[1:]:
            out = np.minimum(out, x)
        return out
    if op == "max":
        out = nums[0]
        for x in nums[1:]:
            out = np.maximum(out, x)
        return out
    raise _Unsupported
