"""Values a fluent can never take, given the state a query fixes at step 0.

Templates are the same for every step, so they hold every value of every fluent; an ASP
grounder instead builds step by step only what can be derived.  This closes most of the gap
for domains whose integers move in steps from a known start (three tanks of 200, 125 and
75 litres poured into each other from 200/0/0 only ever hold multiples of 25): starting from
the values the query fixes at step 0 (and every value of a fluent it leaves free, C.3), a
value becomes *possible* when some rule with that head has a body whose positive top-level
atoms are all possible (for a self-supporting rule, its rest: inertia keeps what was
possible, ``exogenous`` makes everything possible).  This is a sound over-approximation of
the values taken at *any* step, so the others are false in every history and the templates
drop them with every rule that needs them.  Non-Boolean fluents other than additive ones
are pruned; actions, rigid and Boolean constants never are.

>>> from cplus.load import load_text
>>> from cplus.ground.theory import ground_program
>>> prog = load_text(':- sorts n. :- objects 0..9 :: n. :- variables X :: n. '
...                  ':- constants c :: inertialFluent(n); up :: exogenousAction. '
...                  'up causes c = X + 2 if c = X where X + 2 =< 9.')
>>> th = ground_program(prog)
>>> zero = th.atoms.lit(th.sig.ground[0], 0)
>>> sorted(th.atoms.value_of[a] for a in unreachable(th, {zero}))
[1, 3, 5, 7, 9]
"""
from __future__ import annotations

from cplus.ground.theory import GroundTheory, initially_free

__all__ = ["unreachable"]


def unreachable(theory: GroundTheory, fixed: set[int]) -> set[int]:
    """Atom ids of fluent values no history can take, when the positive atoms ``fixed`` hold
    at step 0 (an atom of a non-Boolean fluent fixes its value there)."""
    atoms = theory.atoms
    candidates: set[int] = set()
    possible: set[int] = set()
    for gc in theory.sig.ground:
        d = gc.decl
        if gc.boolean or not d.is_fluent or d.kind == "additiveFluent":
            continue
        ids = atoms.atoms(gc)
        candidates.update(ids)
        pinned = [a for a in ids if a in fixed]
        if pinned:
            possible.update(pinned)
        elif initially_free(d):
            possible.update(ids)
    if not candidates or candidates <= possible:
        return set()
    closed = candidates - possible          # not (yet) possible
    watch: dict[int, list[int]] = {}
    heads: list[int] = []
    missing: list[int] = []
    queue: list[int] = []
    for cls in ("static", "dynamic"):
        for code, body in theory.rules[cls]:
            head = (code - 1) // 3
            if code < 0 or head not in closed:
                continue
            items = body[1] if type(body) is tuple and body[0] == "&" else (body,)
            need = [a for a in [(g - 1) // 3 for g in items if type(g) is int and g > 0 and g != code]
                    if a in closed]
            if not need:
                closed.discard(head)
                queue.append(head)
                continue
            if len(need) > 1:
                need = list(set(need))
            i = len(heads)
            heads.append(head)
            missing.append(len(need))
            for a in need:
                w = watch.get(a)
                if w is None:
                    watch[a] = [i]
                else:
                    w.append(i)
    while queue:
        a = queue.pop()
        for i in watch.pop(a, ()):
            missing[i] -= 1
            if missing[i] == 0 and heads[i] in closed:
                closed.discard(heads[i])
                queue.append(heads[i])
    return closed
