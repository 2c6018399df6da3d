"""Clause templates for the rigid part, step 0, and one transition.

Template variable space (the same for the three templates):

* ``1..R``: rigid atoms;
* ``R+1..R+N``: every non-rigid atom at the template's first step (slot 0);
* ``R+N+1..R+2N``: the same atoms at the next step (slot 1, transitions only);
* above ``R+2N``: auxiliary variables of this template.

:class:`~cplus.sat.horizon.Horizon` maps them to solver variables per step by adding
offsets, so a longer horizon only appends clauses.
"""
from __future__ import annotations

import gc as _gc
import operator
import sys
from collections.abc import Callable, Sequence
from itertools import chain

from cplus.ground.pf import PF, mk_and
from cplus.ground.theory import GroundTheory, initially_free
from cplus.record import Record
from cplus.sat.cnf import CONFLICT, ClauseBuilder, compact
from cplus.sat.factor import rewrite
from cplus.sat.intervals import factor_intervals
from cplus.sat.products import factor_products
from cplus.sat.tables import TABLE_LIMIT, TABLE_SMALL, encode_full_rows, encode_table
from cplus.signature import GroundConst

__all__ = ["Layout", "Template", "build_templates", "check_sums", "sum_size"]


class Template(Record):
    _fields = ("clauses", "top", "name", "extra", "_literals")

    clauses: list[list[int]]
    top: int                      # highest template id used
    name: str
    extra: list[tuple[Template, int]]
    """Templates over slot 0 that come with this one, each placed at the given slot of every
    instance (the part that is the same at every step is built once and placed at step 0
    by the initial template, at the next step by the transition)."""
    _literals: int | None

    def __init__(
            self,
            clauses: list[list[int]],
            top: int,
            name: str,
            extra: list[tuple[Template, int]] | None = None,
            _literals: int | None = None) -> None:
        self.clauses = clauses
        self.top = top
        self.name = name
        self.extra = [] if extra is None else extra
        self._literals = _literals

    def size(self, base: int) -> tuple[int, int, int]:
        """(clauses, literals, auxiliary variables) of one instance, extras included."""
        if self._literals is None:
            self._literals = sum(map(len, self.clauses))
        n, lits, aux = len(self.clauses), self._literals, self.top - base
        for part, _ in self.extra:
            pn, pl, pa = part.size(base)
            n, lits, aux = n + pn, lits + pl, aux + pa
        return n, lits, aux


class _Memo(dict):
    """A dict that computes a missing entry with ``fn`` and keeps it: lookups through its
    ``__getitem__`` (and ``map`` over it) stay in C once an entry is there, which is what the
    hot loops of template building need (a literal is met once per rule that mentions it)."""
    __slots__ = ("fn",)

    def __init__(self, fn: Callable) -> None:
        super().__init__()
        self.fn = fn

    def __missing__(self, key):
        value = self[key] = self.fn(key)
        return value


class Layout:
    """Dense numbering of atoms: rigid ones 1..R, the others by position 0..N-1."""

    def __init__(self, theory: GroundTheory) -> None:
        atoms = theory.atoms
        self.theory = theory
        self.ridx: dict[int, int] = {}
        self.pos: dict[int, int] = {}
        self.rigid_atoms: list[int] = []
        self.step_atoms: list[int] = []
        for aid in range(1, len(atoms) + 1):
            gc = atoms.gc_of[aid]
            assert gc is not None
            if gc.decl.kind == "rigid":
                self.ridx[aid] = len(self.rigid_atoms)
                self.rigid_atoms.append(aid)
            else:
                self.pos[aid] = len(self.step_atoms)
                self.step_atoms.append(aid)
        self.R = len(self.rigid_atoms)
        self.N = len(self.step_atoms)
        self.dead: frozenset[int] = frozenset()
        self.tables: dict = {}        # decision diagrams built for these templates (tables.encode_table)
        # memos by template literal (see _Memo): the template id of a code (True and False stay),
        # ((constant, slot), value) of a literal that may be in a cube (_cube),
        # the same by constant id (_atom_key) and its (constant id, slot) alone (_constant_key)
        self.tids = _Memo(self._tid_of)
        self.tid: Callable[[int], int] = self.tids.__getitem__
        self.shifted_tids = _Memo(self._shifted_tid_of)   # the same after _shift_static
        self.dead_codes: frozenset[int] = frozenset()      # template codes of dead atoms, see dead
        self.cube_atoms = _Memo(lambda lit: _cube_atom(self, lit) if type(lit) is int else None)
        self.cube_keys = _Memo(lambda lit: self.cube_atoms[lit][0])
        self.atom_keys = _Memo(lambda lit: _keyed(self.cube_atoms[lit]))
        self.constant_keys = _Memo(lambda lit: None if (a := self.atom_keys[lit]) is None else a[0])

    def _tid_of(self, f: int | bool) -> int | bool:
        return self._tid(f) if type(f) is int else f

    def _shifted_tid_of(self, f: int | bool) -> int | bool:
        return self.tids[_shift_code(f)] if type(f) is int else f

    def set_dead(self, dead: set[int] | frozenset[int]) -> None:
        """Atoms false at every step (see :func:`build_templates`)."""
        self.dead = frozenset(dead)
        self.dead_codes = frozenset(3 * a + s for a in dead for s in (1, 2, 3))

    def _tid(self, code: int) -> int:
        a = code if code > 0 else -code
        aid, slot = divmod(a - 1, 3)
        if slot == 2:
            t = self.ridx[aid] + 1
        else:
            t = self.R + slot * self.N + self.pos[aid] + 1
        return t if code > 0 else -t

    def atom_of_tid(self, t: int) -> tuple[int, int]:
        """The (atom, slot) behind a template id of an atom."""
        if t <= self.R:
            return self.rigid_atoms[t - 1], 2
        if t <= self.R + self.N:
            return self.step_atoms[t - self.R - 1], 0
        return self.step_atoms[t - self.R - self.N - 1], 1

    def tid_atom(self, aid: int, slot: int) -> int:
        if slot == 2:
            return self.ridx[aid] + 1
        return self.R + slot * self.N + self.pos[aid] + 1

    @property
    def base_top(self) -> int:
        return self.R + 2 * self.N


def _to_tids(layout: Layout, f: PF) -> PF:
    """A formula over template literal codes, renamed to template ids."""
    return _renamed(layout.tids, f)


def _renamed(memo: _Memo, f: PF) -> PF:
    """``f`` renamed through a memo of :class:`Layout`, which holds literals only (the hot
    path of template building; a plain loop is faster here than ``map`` after a check that
    every item is a literal, and hashing nested formulas for a memo costs more than it saves).
    Codes start at 4 (atom ids at 1), so ``True == 1`` and ``False == 0`` never meet a code's entry."""
    if type(f) is not tuple:
        return memo[f]
    out = []
    for g in f[1]:
        out.append(_renamed(memo, g) if type(g) is tuple else memo[g])
    return (f[0], tuple(out))


def _shift_code(code: int) -> int:
    """A template literal code with slot 0 moved to slot 1 (static laws in the transition)."""
    a = code if code > 0 else -code
    if (a - 1) % 3 == 0:
        a += 1
    return a if code > 0 else -a


def build_templates(theory: GroundTheory, dead: set[int] | frozenset[int] = frozenset()
                    ) -> tuple[Layout, Template, Template, Template]:
    """The three templates; ``dead`` atoms (fluent values no history can take, see
    :mod:`cplus.sat.reach`) are false at every step, and every rule, constraint and table
    row that needs one of them is left out.

    The cyclic garbage collector is paused meanwhile: building allocates hundreds of
    thousands of tuples and lists that reference counting frees, and the collector's passes
    over them and over the ground theory took a sixth of ferryman-30-4's template time."""
    check_sums(theory)
    collecting = _gc.isenabled()
    _gc.disable()
    at: list = [None]
    try:
        layout = Layout(theory)
        layout.set_dead(dead)
        static = _static(layout)
        return layout, _rigid(layout), _initial(layout, static), _transition(layout, static, at)
    except MemoryError:
        pass        # the exception, and what the frames it holds built, are released here
    finally:
        if collecting:
            _gc.enable()
    from cplus.errors import OutOfMemoryError
    from cplus.limits import out_of_memory
    sum_ = at[0]
    if sum_ is None:
        raise OutOfMemoryError(out_of_memory("encoding the domain's laws"))
    raise OutOfMemoryError(out_of_memory(f"encoding the additive constant '{sum_.target.text}'"), sum_.target.decl.loc)


def _needs_dead(dead: frozenset[int], body: PF) -> bool:
    """Whether a body (over template codes) has a positive top-level atom that is dead."""
    items = body[1] if type(body) is tuple and body[0] == "&" else (body,)
    for g in items:
        if type(g) is int and g > 0 and (g - 1) // 3 in dead:
            return True
    return False


def _needs_dead_code(dead_codes: frozenset[int], body: PF) -> bool:
    """:func:`_needs_dead` by the codes of the dead atoms (:attr:`Layout.dead_codes`): one
    set operation per body."""
    if type(body) is tuple and body[0] == "&":
        return not dead_codes.isdisjoint(body[1])
    return body in dead_codes


class _Builder:
    def __init__(self, layout: Layout, name: str) -> None:
        self.layout = layout
        self.name = name
        self.top = layout.base_top
        self.cb = ClauseBuilder(self._new)

    def _new(self) -> int:
        self.top += 1
        return self.top

    def done(self, extra: list[tuple[Template, int]] | None = None) -> Template:
        """The simplified clauses, with the auxiliary variables that survived renumbered
        densely (every instance of the template allocates that many solver variables);
        ``extra``: other templates instantiated with it (see :attr:`Template.extra`)."""
        base = self.layout.base_top
        clauses, top = compact(self.cb.clauses, base, self.top)
        if clauses is CONFLICT:   # no model at all: say so with a variable of this template's own
            clauses, top = [[base + 1], [-(base + 1)]], base + 1
        return Template(clauses, top, self.name, extra=extra or [])


def _heads(theory: GroundTheory, layout: Layout, rules: list[tuple[int, PF]], shift: bool = False,
           only: set[int] | None = None, but: set[int] | frozenset[int] = frozenset()) -> dict:
    """The bodies of the rules by head (template ids), for the heads of atoms in ``only``
    (every atom when None) and not in ``but``."""
    out: dict[int, list[PF]] = {}
    dead = layout.dead_codes
    memo = layout.shifted_tids if shift else layout.tids
    for code, body in rules:
        if dead and (code in dead or _needs_dead_code(dead, body)):
            continue
        if only is not None or but:
            aid = ((code if code > 0 else -code) - 1) // 3
            if (only is not None and aid not in only) or aid in but:
                continue
        out.setdefault(memo[code], []).append(_renamed(memo, body))
    return out


def _complete_atoms(b: _Builder, gcs: list[GroundConst], slot: int, heads: dict, free_fn=None) -> None:
    layout = b.layout
    atoms = layout.theory.atoms
    for gc in gcs:
        free = bool(free_fn and free_fn(gc))
        if not free and _table_completion(b, gc, slot, heads):
            continue
        if gc.boolean:
            aid = atoms.lit(gc, "true")
            t = layout.tid_atom(aid, slot)
            b.cb.complete(t, heads.get(t, ()), free)
            b.cb.complete(-t, heads.get(-t, ()), free)
        else:
            dead = layout.dead    # false at every step (their unit clauses are written once)
            ts = [layout.tid_atom(aid, slot) for aid in atoms.atoms(gc) if aid not in dead]
            bodies = heads if free else _factored(b, ts, heads)
            for t in ts:
                b.cb.complete(t, bodies.get(t, ()), free)
            b.cb.exactly_one(ts)


def _factored(b: _Builder, ts: list[int], heads: dict) -> dict[int, Sequence[PF]]:
    """The bodies of the rules for the values ``ts`` of a constant, rewritten through the
    rests they share where that saves clauses (see :mod:`cplus.sat.factor`)."""
    return rewrite({t: heads.get(t, ()) for t in ts}, _constant_key(b.layout), b.cb.lit)


def _constant_key(layout: Layout) -> Callable[[int], tuple | None]:
    """``key_of(lit)``: the (constant, slot) whose value the template literal ``lit`` states;
    None for a negated value or an auxiliary variable (:func:`_atom_key` without the value).
    Constants are given by their ids, so that keys sort."""
    return layout.constant_keys.__getitem__


def _atom_key(layout: Layout) -> Callable[[int], tuple | None]:
    """``atom_of(lit)``: ``((constant id, slot), value)`` of a template literal stating a
    constant's value, else None (:func:`_cube_atom`, memoized on the layout)."""
    return layout.atom_keys.__getitem__


def _keyed(atom: tuple | None) -> tuple | None:
    """A cube atom ``((constant, slot), value)`` with the constant by its id."""
    return None if atom is None else ((atom[0][0].id, atom[0][1]), atom[1])


def _integer_values(layout: Layout) -> Callable[[tuple], dict]:
    """``values_of((constant id, slot))``: the template literal of each value that is not
    dead, in increasing order, for a constant whose values are all integers; empty
    otherwise.  Dead values are false at every step, so a run of forbidden values may
    step over them."""
    sig = layout.theory.sig

    def values_of(key: tuple) -> dict:
        gc = sig.ground[key[0]]
        if gc.boolean or not all(type(v) is int for v in gc.domain):
            return {}
        lits = _value_lits(layout, (gc, key[1]))
        return {v: lits[v] for v in sorted(_live_values(layout, gc))}
    return values_of


def _table_completion(b: _Builder, gc: GroundConst, slot: int, heads: dict) -> bool:
    """Completion of a constant whose rules are tables over other constants (see
    :mod:`cplus.sat.tables`): every rule for ``gc`` at this slot has a body that is a
    conjunction of atoms ``d=w`` of other constants (at most one atom per constant).  Returns
    False when the rules do not have that shape (a self-supporting rule, inertia or a default,
    among them) or the table is too large; the caller then writes the ordinary completion."""
    layout = b.layout
    atoms = layout.theory.atoms
    lits = atoms.head_lits(gc)
    head_tids = []
    for aid, _ in lits:
        t = layout.tid_atom(abs(aid), slot)
        head_tids.append(t if aid > 0 else -t)
    rows: list[tuple[int, tuple]] = []      # (head index, the literals of a body)
    for hi, h in enumerate(head_tids):
        for body in heads.get(h, ()):
            if type(body) is tuple:
                if body[0] != "&" or h in body[1]:
                    # self-supporting rules (inertia) as weak table rows give the same models but
                    # propagate badly backwards from a goal (hanoi-6-3 solved 12x slower): the
                    # ordinary completion keeps them
                    return False
                rows.append((hi, body[1]))
            elif body is True:
                rows.append((hi, ()))
            elif body is not False:
                if body == h:
                    return False
                rows.append((hi, (body,)))
    if not rows:
        return False
    if len(rows) >= FULL_ROWS_FROM and "numpy" in sys.modules:
        done = _full_rows_completion(b, gc, slot, lits, head_tids, rows)
        if done is not None:
            return done
    used = set(chain.from_iterable(items for _, items in rows))
    if not _cubes(layout, used, rows, gc, slot):
        return False
    atom_of = layout.cube_atoms
    order = sorted({atom_of[lit][0] for lit in used}, key=lambda k: (k[0].id, k[1]))
    size = 1
    for key in order:
        size *= len(_live_values(layout, key[0]))
        if size > TABLE_LIMIT:
            return False
    pos = {k: i for i, k in enumerate(order)}
    placed = {lit: (pos[atom_of[lit][0]], atom_of[lit][1]) for lit in used}
    strong = [(hi, tuple(map(placed.__getitem__, items))) for hi, items in rows]
    cb = b.cb
    domains = [_live_values(layout, k[0]) for k in order]
    if not encode_table(domains, [_value_lits(layout, k) for k in order], head_tids,
                        strong, [],
                        _nonempty(cb), b._new, cb.at_most_one, layout.tables):  # type: ignore[arg-type]
        return False
    if not gc.boolean:
        dead = layout.dead
        cb.exactly_one([t for (aid, _), t in zip(lits, head_tids) if aid not in dead])
    return True


FULL_ROWS_FROM = 2048     # rows; fewer, and the list path is as fast as setting up arrays


def _full_rows_completion(b: _Builder, gc: GroundConst, slot: int, lits: list, head_tids: list[int],
                          rows: list[tuple[int, tuple]]) -> bool | None:
    """:func:`_table_completion`'s table written from arrays when every body is a cube over all
    the body constants (a physics law's rules: ``pos'=p+(v+v')/2 <= vel'=v' & vel=v & pos=p``),
    with no Python step per rule; None when the rows have another shape, or the table is small
    enough that the list path builds it without numpy: the caller goes on as before.  Same
    answer, same clauses: the cubes are checked as :func:`_cubes` checks them and the cells are
    the ones :func:`~cplus.sat.tables.encode_table` would fill."""
    import numpy as np
    width = len(rows[0][1])
    if width == 0 or any(len(items) != width for _, items in rows):
        return None
    layout = b.layout
    body = np.array([items for _, items in rows], dtype=np.int64)
    used = np.unique(body)
    atom_of = layout.cube_atoms
    own = (gc, slot)
    found = [atom_of[lit] for lit in used.tolist()]
    if any(a is None or a[0] == own for a in found):
        return False                     # as _cubes: a literal that is no atom d=w of another constant
    order = sorted({a[0] for a in found}, key=lambda k: (k[0].id, k[1]))
    if len(order) != width:
        return None                      # some cubes leave a constant open, or repeat one
    domains = [_live_values(layout, k[0]) for k in order]
    cells = 1
    for d in domains:
        cells *= len(d)
    if cells > TABLE_LIMIT:
        return False
    if cells <= TABLE_SMALL:
        return None
    pos = {k: i for i, k in enumerate(order)}
    index = [{w: i for i, w in enumerate(d)} for d in domains]
    axis = np.array([pos[a[0]] for a in found], dtype=np.int64)
    value = np.array([index[pos[a[0]]].get(a[1], -1) for a in found], dtype=np.int64)
    if (value < 0).any():
        return None
    at = np.searchsorted(used, body)
    axes = axis[at]
    for j in range(width):               # a constant twice in one cube: not a table (_cubes)
        for i in range(j):
            if (axes[:, i] == axes[:, j]).any():
                return False
    stride = np.ones(width, dtype=np.int64)
    for k in range(width - 2, -1, -1):
        stride[k] = stride[k + 1] * len(domains[k + 1])
    flat = (value[at] * stride[axes]).sum(axis=1)
    hs = np.array([hi for hi, _ in rows], dtype=np.int32)
    cb = b.cb
    if not encode_full_rows(domains, [_value_lits(layout, k) for k in order], head_tids, flat, hs,
                            _nonempty(cb), b._new, cb.at_most_one, layout.tables):  # type: ignore[arg-type]
        return False
    if not gc.boolean:
        dead = layout.dead
        cb.exactly_one([t for (aid, _), t in zip(lits, head_tids) if aid not in dead])
    return True


def _nonempty(cb: ClauseBuilder):
    def add(clause: list[int]) -> None:
        if clause:
            cb.add_clause(clause)
        else:
            cb.add(False)
    return add


def _live_values(layout: Layout, gc: GroundConst) -> tuple:
    """The values of a constant that are not dead."""
    if not layout.dead or gc.boolean:
        return gc.domain
    lit = layout.theory.atoms.lit
    return tuple(v for v in gc.domain if lit(gc, v) not in layout.dead)


def _dead_units(b: _Builder, slots: tuple[int, ...]) -> None:
    for aid in sorted(b.layout.dead):
        for slot in slots:
            b.cb.add_clause([-b.layout.tid_atom(aid, slot)])


def _value_lits(layout: Layout, key: tuple) -> dict:
    """Template literal of ``constant=value`` at a slot, for every value."""
    other, s = key
    atoms = layout.theory.atoms
    if other.boolean:
        t = layout.tid_atom(atoms.lit(other, "true"), s)
        return {"true": t, "false": -t}
    return {v: layout.tid_atom(atoms.lit(other, v), s) for v in other.domain}


def _cubes(layout: Layout, used: set, rows: list[tuple[int, tuple]], gc: GroundConst, slot: int) -> bool:
    """Whether every body is a *cube*: a conjunction of atoms ``d=w`` (``used``: their
    literals) of constants other than gc@slot, each constant at most once per body."""
    atom_of = layout.cube_atoms
    own = (gc, slot)
    for lit in used:
        atom = atom_of[lit]
        if atom is None or atom[0] == own:
            return False
    key_of = layout.cube_keys.__getitem__
    return all(len(set(map(key_of, items))) == len(items) for _, items in rows)


def _cube_atom(layout: Layout, lit: int) -> tuple | None:
    """``((constant, slot), value)`` of a template literal that may be in a cube."""
    atoms = layout.theory.atoms
    t = lit if lit > 0 else -lit
    if t > layout.base_top:
        return None
    aid, s = layout.atom_of_tid(t)
    value = atoms.value_of[aid]
    if value is None:
        value = "true" if lit > 0 else "false"
    elif lit < 0:
        return None
    return (atoms.gc_of[aid], s), value


def _constraints(b: _Builder, bodies: list[PF], shift: bool = False) -> None:
    """``not body`` for every constraint, once: a law over two variables of the same sort
    (``nonexecutable move(D)=L & move(D1)=L1 where D \\= D1``) grounds each pair twice."""
    from cplus.ground.pf import neg
    layout = b.layout
    dead = layout.dead_codes
    memo = layout.shifted_tids if shift else layout.tids
    add_clause = b.cb.add_clause
    seen: set = set()
    flats: list[tuple[int, ...]] = []
    for body in bodies:
        if dead and _needs_dead_code(dead, body):
            continue
        flat = type(body) is tuple and body[0] == "&"
        key = frozenset(body[1]) if flat else body   # type: ignore[index]
        if key in seen:
            continue
        seen.add(key)
        if flat and not shift and tuple not in map(type, body[1]):  # type: ignore[index]  # literals only: one clause
            flats.append(tuple(map(memo.__getitem__, body[1])))  # type: ignore[index]
            continue
        b.cb.add(neg(_renamed(memo, body)))
    rest = factor_products(flats, _constant_key(layout), add_clause, b._new)
    for items in factor_intervals(rest, _atom_key(layout), _integer_values(layout), add_clause, b._new):
        add_clause(list(map(operator.neg, items)))


def _rigid(layout: Layout) -> Template:
    th = layout.theory
    b = _Builder(layout, "rigid")
    gcs = [gc for gc in th.sig.ground if gc.decl.kind == "rigid"]
    _complete_atoms(b, gcs, 2, _heads(th, layout, th.rules["rigid"]))
    _constraints(b, th.constraints["rigid"])
    return b.done()


def _fluents(th: GroundTheory, additive: bool) -> list[GroundConst]:
    return [gc for gc in th.sig.ground if gc.decl.is_fluent and (gc.decl.kind == "additiveFluent") == additive]


def _static(layout: Layout) -> tuple[Template, set[int]]:
    """What is the same at every step, built once at slot 0: the unit clauses of dead values,
    the static constraints, and the completion of the fluents only static laws determine
    (statically determined fluents without dynamic laws: their completion at step 0 and
    after a transition is the same).  Returns the template and those fluents' atoms."""
    th = layout.theory
    dynamic = {((code if code > 0 else -code) - 1) // 3 for code, _ in th.rules["dynamic"]}
    gcs = [gc for gc in _fluents(th, False)
           if not initially_free(gc.decl) and not any(a in dynamic for a in th.atoms.atoms(gc))]
    atoms = {a for gc in gcs for a in th.atoms.atoms(gc)}
    b = _Builder(layout, "static")
    _dead_units(b, (0,))
    _complete_atoms(b, gcs, 0, _heads(th, layout, th.rules["static"], only=atoms))
    _constraints(b, th.constraints["static"])
    return b.done(), atoms


def _initial(layout: Layout, static: tuple[Template, set[int]]) -> Template:
    th = layout.theory
    part, done = static
    b = _Builder(layout, "initial")
    heads = _heads(th, layout, th.rules["static"], but=done)
    free = lambda gc: initially_free(gc.decl)  # noqa: E731
    _complete_atoms(b, [gc for gc in _fluents(th, False) if not _among(th, gc, done)], 0, heads, free)
    for gc in _fluents(th, True):   # additive fluents: free at step 0, one value
        ts = [layout.tid_atom(aid, 0) for aid in th.atoms.atoms(gc)]
        b.cb.exactly_one(ts)
    return b.done(extra=[(part, 0)])


def _among(th: GroundTheory, gc: GroundConst, atoms: set[int]) -> bool:
    ids = th.atoms.atoms(gc)
    return bool(ids) and ids[0] in atoms


def _transition(layout: Layout, static: tuple[Template, set[int]], at: list | None = None) -> Template:
    """The transition template; ``at[0]`` is the additive sum being encoded, while one is."""
    th = layout.theory
    part, done = static
    b = _Builder(layout, "transition")
    actions = [gc for gc in th.sig.ground if gc.decl.is_action and gc.decl.kind != "additiveAction"]
    _complete_atoms(b, actions, 0, _heads(th, layout, th.rules["action"]))
    heads = _heads(th, layout, th.rules["static"], shift=True, but=done)
    for t, bodies in _heads(th, layout, th.rules["dynamic"]).items():
        heads.setdefault(t, []).extend(bodies)
    _complete_atoms(b, [gc for gc in _fluents(th, False) if not _among(th, gc, done)], 1, heads)
    _constraints(b, th.constraints["dynamic"])
    _constraints(b, th.constraints["action"])
    for group in th.noconcurrency:
        b.cb.at_most_one([_to_tids(layout, g) for g in group])
    for s in th.sums:
        if at is not None:
            at[0] = s
        _additive(b, s)
    if at is not None:
        at[0] = None
    return b.done(extra=[(part, 1)])


def sum_size(s) -> int:
    """The most (partial sum, contribution) pairs :func:`_additive` builds for one sum: at
    each contribution, every value the partial sum may have so far with every value of the
    contribution (a sum's possible values, an interval cut to what can still reach the
    target's domain, are counted, not listed: a target of a million values is common)."""
    dom = [v for v in s.target.domain if isinstance(v, int)]
    if not dom:
        return 0
    lo, hi = min(dom), max(dom)
    if s.target.decl.kind == "additiveFluent":
        n, low, high = len(dom), lo, hi
    else:
        n, low, high = 1, 0, 0
    widths = [(min(c.domain), max(c.domain), len(c.domain)) for c in s.contributions]
    rest_min, rest_max = sum(w[0] for w in widths), sum(w[1] for w in widths)
    pairs = 0
    for cmin, cmax, k in widths:
        pairs += n * k
        rest_min, rest_max = rest_min - cmin, rest_max - cmax
        low, high = max(low + cmin, lo - rest_max), min(high + cmax, hi - rest_min)
        n = min(n * k, max(0, high - low + 1))
    return pairs


def check_sums(theory: GroundTheory) -> None:
    """Refuse, at the declaration of the largest, additive constants whose encodings cannot
    fit in memory (:func:`sum_size`; the measured cost of a pair and of a target's value
    are :data:`~cplus.limits.SUM_PAIR_BYTES` and :data:`~cplus.limits.SUM_VALUE_BYTES`)."""
    from cplus.errors import GroundingError
    from cplus.limits import SUM_PAIR_BYTES, SUM_VALUE_BYTES, count, memory_budget, too_large
    if not theory.sums:
        return
    sizes = [(sum_size(s), s) for s in theory.sums]
    need = sum(SUM_PAIR_BYTES * pairs + SUM_VALUE_BYTES * len(s.target.domain) for pairs, s in sizes)
    if need <= memory_budget():
        return
    pairs, s = max(sizes, key=lambda ps: ps[0] * SUM_PAIR_BYTES + len(ps[1].target.domain) * SUM_VALUE_BYTES)
    decl = s.target.decl
    kind = "fluent" if decl.kind == "additiveFluent" else "action"
    raise GroundingError(too_large(
        f"the additive {kind} '{s.target.text}' is too large to encode: it sums {count(len(s.contributions))} "
        f"contributions over {count(len(s.target.domain))} values, about {count(pairs)} partial sums "
        f"at every step", need), decl.loc)


def _additive(b: _Builder, s) -> None:
    """``target = base + sum(contributions)`` with one-hot partial sums (exact, pruned)."""
    layout = b.layout
    atoms = layout.theory.atoms
    cb = b.cb
    target: GroundConst = s.target
    is_fluent = target.decl.kind == "additiveFluent"
    dom = [v for v in target.domain if isinstance(v, int)]
    current: dict[int, PF]
    if is_fluent:
        current = {v: layout.tid_atom(atoms.lit(target, v), 0) for v in dom}
    else:
        current = {0: True}
    contribs = [[(v, layout.tid_atom(atoms.lit(cg, v), 0)) for v in cg.domain] for cg in s.contributions]
    lo, hi = min(dom), max(dom)
    mins = [min(v for v, _ in c) for c in contribs]
    maxs = [max(v for v, _ in c) for c in contribs]
    for j, cvals in enumerate(contribs):
        rest_min, rest_max = sum(mins[j + 1:]), sum(maxs[j + 1:])
        parts: dict[int, list[PF]] = {}
        for u, lu in current.items():
            for w, lw in cvals:
                v = u + w
                if lo - rest_max <= v <= hi - rest_min:
                    # mk_and((lu, lw)) for the usual literals, without its general loop
                    both = lw if lu is True else ("&", (lu, lw)) if type(lu) is int and lu != lw and lu != -lw \
                        else mk_and((lu, lw))
                    parts.setdefault(v, []).append(both)
        current = {}
        for v, ps in parts.items():
            if len(ps) == 1:
                current[v] = cb.lit(ps[0]) if ps[0] is not True else True
            else:
                current[v] = cb.lit(("|", tuple(ps)))
    slot = 1 if is_fluent else 0
    for v in dom:
        t = layout.tid_atom(atoms.lit(target, v), slot)
        sv = current.get(v, False)
        if sv is True:
            cb.add_clause([t])
        elif sv is False:
            cb.add_clause([-t])
        else:
            cb.add_clause([-t, sv])      # type: ignore[list-item]
            cb.add_clause([t, -sv])      # type: ignore[operator]
    values = frozenset(dom)        # a set: the domain may have a million values
    for v, sv in current.items():
        if v not in values and sv is not False:
            cb.add(-sv if type(sv) is int else False)
    ts = [layout.tid_atom(atoms.lit(target, v), slot) for v in dom]
    cb.exactly_one(ts)
