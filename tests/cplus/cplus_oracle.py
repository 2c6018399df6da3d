"""A brute-force reference for the semantics of causal theories (test oracle).

It enumerates every interpretation of a tiny ground theory of length m and keeps those
that are models in McCain and Turner's sense: I is a model iff I is the unique
interpretation satisfying the heads of the rules whose bodies I satisfies.  It shares
only the grounder with the planner; completion, Tseitin variables, exactly-one clauses,
incremental horizons and the SAT solver are all bypassed.
"""
from __future__ import annotations

from itertools import product

from cplus.ground.theory import GroundTheory, initially_free


def _eval(pf, value_of) -> bool:
    if pf is True or pf is False:
        return pf
    if type(pf) is int:
        return value_of(pf)
    op, items = pf
    if op == "&":
        return all(_eval(g, value_of) for g in items)
    return any(_eval(g, value_of) for g in items)


def models(theory: GroundTheory, m: int) -> list[dict]:
    """Every model of D_m as ``{(ground constant, step or None): value}``."""
    cells = []
    for gc in theory.sig.ground:
        d = gc.decl
        if d.kind == "rigid":
            cells.append((gc, None))
        elif d.is_action:
            cells += [(gc, t) for t in range(m)]
        else:
            cells += [(gc, t) for t in range(m + 1)]
    out = []
    for values in product(*[gc.domain for gc, _ in cells]):
        interp = dict(zip(cells, values))
        if _is_model(theory, m, interp):
            out.append(interp)
    return out


def _lit_value(atoms, interp, code: int, t: int) -> bool:
    a = abs(code)
    aid, slot = divmod(a - 1, 3)
    gc = atoms.gc_of[aid]
    when = None if slot == 2 else t + slot
    v = interp[(gc, when)]
    truth = (v == "true") if atoms.value_of[aid] is None else (v == atoms.value_of[aid])
    return truth if code > 0 else not truth


def _is_model(theory: GroundTheory, m: int, interp: dict) -> bool:
    atoms = theory.atoms
    heads: set = set()

    def fire(rules, constraints, times, shift_head: int) -> bool:
        for t in times:
            val = lambda c, t=t: _lit_value(atoms, interp, c, t)  # noqa: E731
            for body in constraints:
                if _eval(body, val):
                    return False
            for code, body in rules:
                if _eval(body, val):
                    a = abs(code)
                    aid, slot = divmod(a - 1, 3)
                    when = None if slot == 2 else t + slot
                    heads.add((aid, code > 0, when))
        return True

    R, C = theory.rules, theory.constraints
    if not fire(R["rigid"], C["rigid"], [0], 0):
        return False
    if not fire(R["static"], C["static"], range(m + 1), 0):
        return False
    if not fire(R["action"], C["action"], range(m), 0):
        return False
    if not fire(R["dynamic"], C["dynamic"], range(m), 1):
        return False
    for t in range(m):   # noconcurrency: at most one action of each group
        for group in theory.noconcurrency:
            if sum(_eval(g, lambda c, t=t: _lit_value(atoms, interp, c, t)) for g in group) > 1:
                return False
    computed: dict = {}
    for s in theory.sums:
        fluent = s.target.decl.kind == "additiveFluent"
        for t in range(m):
            base = interp[(s.target, t)] if fluent else 0
            total = base + sum(interp[(c, t)] for c in s.contributions)
            computed[(s.target.id, t + 1 if fluent else t)] = total
    for (gc, t), v in interp.items():
        d = gc.decl
        if d.kind in ("additiveFluent", "additiveAction") and not (d.kind == "additiveFluent" and t == 0):
            if computed.get((gc.id, t)) != v:
                return False
            continue
        if t == 0 and initially_free(d):
            continue
        if gc.boolean:
            aid = atoms.lit(gc, "true")
            want = (aid, v == "true", t)
            if want not in heads or (aid, v != "true", t) in heads:
                return False
        else:
            aid = atoms.lit(gc, v)
            if (aid, True, t) not in heads:
                return False
            for other in gc.domain:
                if other != v and (atoms.lit(gc, other), True, t) in heads:
                    return False
    # heads of initially free fluents at step 0 must still hold
    for aid, positive, t in heads:
        gc = atoms.gc_of[aid]
        v = interp[(gc, t)]
        holds = (v == "true") if atoms.value_of[aid] is None else (v == atoms.value_of[aid])
        if holds != positive:
            return False
    return True
