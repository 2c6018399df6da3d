"""Values a fluent can never take, given the state a query fixes at step 0.

Templates are the same for every step, so they hold every value of every fluent; an ASP
grounder instead builds step by step only what can be derived.  This closes most of the gap
for domains whose integers move in steps from a known start (three tanks of 200, 125 and
75 litres poured into each other from 200/0/0 only ever hold multiples of 25): starting from
the values the query fixes at step 0 (and every value of a fluent it leaves free, C.3), a
value becomes *possible* when some rule with that head has a body whose positive top-level
atoms are all possible (for a self-supporting rule, its rest: inertia keeps what was
possible, ``exogenous`` makes everything possible; a fluent on a loop of same-step support
has every value possible, see :func:`cplus.ground.restrict.cyclic_fluents`).  This is a
sound over-approximation of the values taken at *any* step, so the others are false in
every history and the templates drop them with every rule that needs them.  Non-Boolean
fluents other than additive ones are pruned; actions, rigid and Boolean constants never are.

Values unreachable only at the first steps stay in the shared templates, for two measured
reasons.  The solver drops, as they are added, the clauses that what it has derived at
level 0 (the fixed start and its forward consequences) satisfies, so leaving them out step
by step saved nothing: car-300's 191,620 clauses became 150,794 with the same encoding and
solving time (bench/bench_grounding.py, processor time).  And a template per step costs
nearly a whole template's building each (car-300 reaches its last new value at step 10:
about 0.7 s for its first nine against 0.17 s for the shared one).  On bw-20, spacecraft,
ferryman and hanoi every value is possible from step 1 on, so there is nothing to gain.

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

from cplus.ground.restrict import Reachability
from cplus.ground.theory import GroundTheory

__all__ = ["unreachable"]


def unreachable(theory: GroundTheory, fixed: set[int]) -> set[int]:
    """Atom ids of fluent values no history can take, when the positive atoms ``fixed`` hold
    at step 0 (an atom of a non-Boolean fluent fixes its value there)."""
    reach = Reachability(theory.sig, theory.atoms, fixed)
    if not reach.trivial:
        reach.add_rules(theory.rules["static"])
        reach.add_rules(theory.rules["dynamic"])
    return set(reach.closed)


