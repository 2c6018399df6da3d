"""Rules that differ only in one body atom's value, written through their shared rest.

An arithmetic law grounds to many rules whose bodies share all but one atom:
``drive(D) causes pos = P + S*D if pos = P & spd = S`` gives, for each pair
``drive(D) & spd=S`` (the *rest*), one rule per position ``P``, and the completion of
``pos'`` needs a defined variable per rule body.  Pairs that lead from each ``P`` to the same
head (every pair with the same product ``S*D``) behave alike, so one variable ``m`` defined as
the disjunction of their rests stands for all of them, and the rules become
``m & pos=P -> pos'=P+k`` once per position instead of once per pair and position (car-300:
8,100 rules of five clauses to 3,273 of four).

The rewriting is exact: ``m & x -> h`` for every ``(x, h)`` of the group is the conjunction of
the group's rules, and the disjunction of the new bodies with head ``h`` is that of the old
ones; every new variable is fully defined, so the models (and their count) do not move.  It is
used only where it saves clauses (see :func:`plan`); elsewhere the rules stay as they are.

Constraints (``nonexecutable``) could be grouped the same way, a binary clause per group and
value, but are not: on hanoi-6-3 the shared variables made the search 7% slower although
the clauses shrank, for constraints of three or more atoms only ferryman-15-4 was 6% slower,
and written through the groups of the rules (no new variable) car-300 gained nothing
measurable (1,900 fewer clauses a step); car-300 gained 3% at best.
"""
from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Hashable, Sequence
from itertools import chain

from cplus.ground.pf import PF, mk_and, mk_or

__all__ = ["rewrite", "plan", "Group"]

Group = tuple[list[tuple[int, ...]], list[tuple[int, int]]]
"""The rests of a group (flat conjunctions of literals) and the (atom literal, head) pairs
that each of them leads to."""

_FROM = 64      # rules; below, the rewriting cannot save enough to pay for trying
_GAIN = 0.8     # the rewriting must cost at most this share of the clauses it replaces


def rewrite(heads: dict[int, Sequence[PF]], key_of: Callable[[int], Hashable | None],
            lit: Callable[[PF], int]) -> dict[int, Sequence[PF]]:
    """The bodies by head literal, with the rules :func:`plan` groups replaced by rules over
    their group's variable (``lit`` of the disjunction of the group's rests: a defined
    variable); ``heads`` itself when nothing is worth rewriting."""
    flat: dict[int, list[tuple[int, ...]]] = {}
    for h, bodies in heads.items():
        for body in bodies:
            if type(body) is tuple and body[0] == "&":
                items = body[1]
                if h not in items and -h not in items and tuple not in map(type, items):   # literals only
                    flat.setdefault(h, []).append(items)
    if sum(map(len, flat.values())) < _FROM:
        return heads
    found = plan(flat, key_of)
    if found is None:
        return heads
    groups, replaced = found
    out: dict[int, list[PF]] = {
        h: [b for b in bodies if not (type(b) is tuple and (h, b[1]) in replaced)] for h, bodies in heads.items()}
    for rests, pairs in groups:
        m = lit(mk_or([mk_and(rest) for rest in rests]))
        for x, h in pairs:
            out[h].append(("&", (m, x)))
    return out  # type: ignore[return-value]


def plan(bodies: dict[int, list[tuple[int, ...]]], key_of: Callable[[int], Hashable | None]
         ) -> tuple[list[Group], set[tuple[int, tuple[int, ...]]]] | None:
    """The groups to write, and the ``(head, body)`` rules they replace; None when factoring
    does not save at least a fifth of the clauses.

    ``bodies``: head literal -> flat bodies (tuples of two or more literals, none of them the
    head); ``key_of(lit)``: the constant (with its slot) whose value the literal states, or
    None for a literal that cannot be factored out.  A rule is counted at the cost of the
    ordinary completion: its clause and the definition of its conjunction."""
    count: dict[Hashable, int] = {}          # occurrences by constant, in the order first met
    values: dict[Hashable, set[int]] = {}
    for x, n in Counter(chain.from_iterable(b for bs in bodies.values() for b in bs)).items():
        key = key_of(x)
        if key is not None:
            count[key] = count.get(key, 0) + n
            values.setdefault(key, set()).add(x)
    if not count:
        return None
    # the constant in most bodies, and among those the one with the most values: the rest
    # then varies least (the position, not the speed, in ``pos' = pos + spd * dur``)
    key = max(count, key=lambda k: (count[k], len(values[k])))
    of_key = dict.fromkeys(values[key], True).get     # a literal of that constant?
    once: list[tuple[int, tuple[int, ...], int]] = []   # (head, body, where the constant is) if there once
    for h, bs in bodies.items():
        for b in bs:
            flags = list(map(of_key, b))
            if flags.count(True) == 1:
                once.append((h, b, flags.index(True)))
    best = _plan_for(once)
    if best is None:
        return None
    return best, {(h, b) for h, b, _ in once}


def _plan_for(once: list[tuple[int, tuple[int, ...], int]]) -> list[Group] | None:
    """The groups when the constant at ``i`` of each ``(head, body, i)`` is factored out (a
    body with two literals of that constant is not among them), or None if it does not pay."""
    relation: dict[tuple[int, ...], set[tuple[int, int]]] = {}
    old = 0
    for h, b, i in once:
        rest = b[:i] + b[i + 1:]     # the laws' ground rules list their atoms in one order
        pairs = relation.get(rest)
        if pairs is None:
            pairs = relation[rest] = set()
        pairs.add((b[i], h))
        old += len(b) + 2
    by_pairs: dict[frozenset, list[tuple[int, ...]]] = {}
    for rest, pairs in relation.items():
        by_pairs.setdefault(frozenset(pairs), []).append(rest)
    new = sum(len(r) + 1 for r in relation if len(r) > 1)
    new += sum(len(rs) + 1 for rs in by_pairs.values() if len(rs) > 1)
    new += sum(4 * len(pairs) for pairs in by_pairs)
    if new > _GAIN * old:
        return None
    return [(rests, sorted(pairs)) for pairs, rests in by_pairs.items()]
