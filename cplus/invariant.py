"""``maxstep :: any`` with ``invariant: F``: CCALC's proof that no plan of any length exists.

Searching horizon after horizon can only say that there is no plan *up to* some length.  A
query whose maxstep is ``any`` instead names an invariant ``F``, a formula over the domain's
fluents (and rigid constants), and three checks on one live solver prove that no history of
any length satisfies the query:

* **init**: every state that satisfies the query's step-0 conditions ``I`` satisfies ``F``
  (``I & -(0: F)`` has no model at maxstep 0);
* **goal**: no state that satisfies ``F`` satisfies the goal ``G``, the query's ``maxstep:``
  conditions (``0: F & G`` has no model at maxstep 0);
* **transition**: every transition preserves ``F`` (``0: F & -(1: F)`` has no model at
  maxstep 1).

By induction every state of a history from ``I`` satisfies ``F``, so its last state is never
a goal state.  When a check fails its model is the counterexample (a state, or a transition)
and the invariant is wrong: nothing is proved either way.

CCALC's init check, as the project's issue reports it, asks that ``I & 0: F`` be
*satisfiable*; that alone would let an invariant that only some initial states satisfy
"prove" a goal unreachable that one of the others reaches at maxstep 0 (docs/language.md
has the example).  Here the init check is the sound one above, and whether ``I`` has a state
at all is reported beside it (when it has none, the proof holds trivially and says so).

The checks run on the domain's whole grounding (not the one restricted to what the query's
initial state reaches, which would have to be trusted to contain every state ``F`` speaks
about), in one solver extended from maxstep 0 to 1, each check's formulas behind an
activation literal.  This module is imported only for such queries: planning does not pay
for it.
"""
from __future__ import annotations

import time
from collections.abc import Iterable
from enum import Enum

from cplus import ir
from cplus.errors import Location, QueryError
from cplus.history import History
from cplus.record import Record

__all__ = ["InvariantStatus", "Check", "InvariantResult", "check_query_shape", "prove", "format_proof",
           "proof_json", "CHECKS"]

CHECKS = ("init", "goal", "transition")


class InvariantStatus(Enum):
    NO_PLAN_PROVED = "no_plan_proved"     # all three checks hold: no plan of any length
    INVARIANT_WRONG = "invariant_wrong"   # a check failed; its model is the counterexample


class Check(Record):
    """One of the three checks: does it hold, what it says, and its counterexample if not."""

    _fields = ("name", "holds", "text", "counterexample", "seconds")

    name: str
    holds: bool
    text: str
    counterexample: History | None
    seconds: float

    def __init__(self, name: str, holds: bool, text: str, counterexample: History | None = None,
                 seconds: float = 0.0) -> None:
        self.name = name
        self.holds = holds
        self.text = text
        self.counterexample = counterexample
        self.seconds = seconds


class InvariantResult(Record):
    """What :func:`prove` found for a ``maxstep :: any`` query."""

    _fields = ("label", "status", "invariant", "checks", "initial_states")

    label: str
    status: InvariantStatus
    invariant: str               # the invariant as written
    checks: list[Check]          # in CCALC's order, up to the first that fails
    initial_states: bool         # does any state satisfy the query's step-0 conditions?

    def __init__(self, label: str, status: InvariantStatus, invariant: str, checks: list[Check],
                 initial_states: bool) -> None:
        self.label = label
        self.status = status
        self.invariant = invariant
        self.checks = checks
        self.initial_states = initial_states

    @property
    def failed(self) -> Check | None:
        return next((c for c in self.checks if not c.holds), None)


# ---------------------------------------------------------------------------- the query's shape

def _step_of(node, loc: Location) -> set:
    """The steps a condition speaks of: ``0``, ``"maxstep"``, or none (rigid constants only).
    Anything else is refused, located: the proof is about the first and the last state."""
    out: set = set()
    _walk(node, None, loc, out)
    return out


def _walk(node, stamp, loc: Location, out: set) -> None:
    if isinstance(node, ir.StampF) or isinstance(node, ir.StampT):
        t = node.time
        if isinstance(t, ir.MaxStepT):
            step: object = "maxstep"
        elif isinstance(t, ir.Lit) and t.value == 0:
            step = 0
        else:
            raise QueryError("with 'maxstep :: any' a condition speaks of step 0 or of maxstep only (the invariant "
                             "proof relates the first state to the last)", node.loc)
        out.add(step)
        _walk(node.body if isinstance(node, ir.StampF) else node.term, step, loc, out)
        return
    if isinstance(node, ir.MaxStepT):
        raise QueryError("with 'maxstep :: any' there is no maxstep to compute with; write 'maxstep: F' for the "
                         "goal", node.loc)
    if isinstance(node, ir.Var) and _is_step_sort(node.sort):
        raise QueryError(f"with 'maxstep :: any' a condition cannot range over steps (variable {node.name})", node.loc)
    if isinstance(node, ir.Quant) and _is_step_sort(node.var.sort):
        raise QueryError(f"with 'maxstep :: any' a condition cannot range over steps (variable {node.var.name})",
                         node.var.loc)
    if isinstance(node, ir.Cst) and node.decl.is_action:
        raise QueryError(f"with 'maxstep :: any' the conditions and the invariant are about states; "
                         f"'{node.decl.name}' is an action", node.loc)
    if isinstance(node, ir.Atom) and isinstance(node.cst, ir.Var) and _is_action_kind(node.cst.sort):
        raise QueryError(f"with 'maxstep :: any' the conditions and the invariant are about states; "
                         f"{node.cst.name} ranges over actions", node.loc)
    for child in ir.children(node):
        _walk(child, stamp, loc, out)


def _is_action_kind(sort) -> bool:
    from cplus.signature import ACTION_KINDS, KindSort
    return isinstance(sort, KindSort) and sort.kind in ACTION_KINDS


def _is_step_sort(sort) -> bool:
    from cplus.signature import StepSort
    return isinstance(sort, StepSort)


def check_query_shape(items: Iterable[tuple[ir.Formula, Location]], invariant: tuple[ir.Formula, Location] | None,
                      any_length: Location | None, loc: Location) -> None:
    """Refuse, located, a ``maxstep :: any`` query the three checks cannot prove anything
    about: one without an invariant, an invariant without ``maxstep :: any``, a condition
    about steps other than 0 and maxstep or about actions, an invariant with time stamps."""
    if any_length is None:
        assert invariant is not None
        raise QueryError("an invariant belongs to a query with 'maxstep :: any' (the proof that no plan of any "
                         "length exists)", invariant[1])
    if invariant is None:
        raise QueryError("'maxstep :: any' needs an 'invariant: F' item: the formula the proof that no plan "
                         "exists rests on", any_length)
    formula, inv_loc = invariant
    if _step_of(formula, inv_loc):
        raise QueryError("an invariant is a formula about one state, without time stamps", inv_loc)
    goals = 0
    for f, item_loc in items:
        steps = _step_of(f, item_loc)
        if steps == {0, "maxstep"}:
            raise QueryError("with 'maxstep :: any' a condition speaks of step 0 or of maxstep, not both",
                             item_loc)
        goals += "maxstep" in steps
    if not goals:
        raise QueryError("with 'maxstep :: any' the query needs a goal ('maxstep: F') for the invariant to "
                         "exclude", loc)


# ---------------------------------------------------------------------------- the proof

def prove(theory, query, solver: str | None = None) -> InvariantResult:
    """Run the three checks of a ``maxstep :: any`` query on the grounding ``theory`` (the
    domain's whole one) in one solver; stop at the first that fails."""
    from cplus.ground.compile import compile_formula
    from cplus.ground.pf import neg
    from cplus.history import decode_history
    from cplus.program import QuerySpec
    from cplus.sat.horizon import QuerySession
    from cplus.sat.solver import DEFAULT_SOLVER

    assert query.invariant is not None
    formula, inv_loc = query.invariant
    session = QuerySession(theory, QuerySpec(query.label, 0, 1, (), query.loc), solver or DEFAULT_SOLVER)
    session.facts_apply = False   # its step 0 is any state, not a history's first: no stamped rule applies
    h = session.horizon
    s = h.solver

    def item(f: ir.Formula, where: Location) -> list:
        return [f, where, compile_formula(f, session.ctx), False, False]

    def guarded(pf, negate: bool = False) -> int:
        act = h.new_var()
        h.builder.add(neg(pf) if negate else pf, guard=act)
        return act

    def at(step: int, m: int):
        return session._ground_item(item(ir.StampF(ir.Lit(step), formula, inv_loc), inv_loc), m)[0]

    init = [it for it in query.items if "maxstep" not in _step_of(*it)]
    goal = [it for it in query.items if "maxstep" in _step_of(*it)]
    a_init = guarded(_ground_all(session, init, 0, item))
    a_goal = guarded(_ground_all(session, goal, 0, item))
    f0 = at(0, 0)
    a_f0, a_not_f0 = guarded(f0), guarded(f0, negate=True)
    checks: list[Check] = []
    text = inv_loc.source.text[inv_loc.start:inv_loc.end] if inv_loc is not None else "?"

    def run(name: str, assumptions: list[int], holds_text: str, fails_text: str) -> bool:
        t0 = time.perf_counter()
        sat = s.solve(assumptions)
        cex = decode_history(session) if sat else None
        checks.append(Check(name, not sat, fails_text if sat else holds_text, cex, time.perf_counter() - t0))
        return not sat

    t0 = time.perf_counter()
    initial_states = s.solve([a_init])
    init_time = time.perf_counter() - t0
    ok = run("init", [a_init, a_not_f0],
             "the invariant holds in every initial state" if initial_states else
             "no state satisfies the query's conditions at step 0, so the invariant holds in all of them",
             "the invariant does not hold in this initial state")
    checks[-1].seconds += init_time
    ok = ok and run("goal", [a_f0, a_goal], "no state satisfying the invariant satisfies the goal",
                    "this state satisfies the invariant and the goal")
    if ok:
        h.extend_to(1, query.loc)
        a_f0_again = guarded(at(0, 1))
        a_not_f1 = guarded(at(1, 1), negate=True)
        ok = run("transition", [a_f0_again, a_not_f1], "every transition preserves the invariant",
                 "this transition does not preserve the invariant")
    s.delete()
    status = InvariantStatus.NO_PLAN_PROVED if ok else InvariantStatus.INVARIANT_WRONG
    return InvariantResult(query.label, status, text, checks, initial_states)


def _ground_all(session, items, m: int, item):
    from cplus.ground.pf import mk_and
    return mk_and([session._ground_item(item(f, where), m)[0] for f, where in items])


# ---------------------------------------------------------------------------- output

_ASKED = {"init": "Verifying that the invariant holds in every initial state",
          "goal": "Verifying that no state satisfying the invariant satisfies the goal",
          "transition": "Verifying that every transition preserves the invariant"}


def format_proof(display, result: InvariantResult) -> str:
    """CCALC-style text: a ``%`` line per check, the counterexample of a failed one as a
    history, and the verdict."""
    from cplus.output import format_history
    out = []
    for c in result.checks:
        out.append(f"% {_ASKED[c.name]}... {'done' if c.holds else 'failed'}.\n")
        if c.holds:
            continue
        out.append(f"\n{c.text[0].upper()}{c.text[1:]}:\n")
        assert c.counterexample is not None
        out.append(format_history(display, c.counterexample))
        out.append(f"The invariant {result.invariant} is wrong.\n\n")
        return "".join(out)
    if not result.initial_states:
        out.append("% No state satisfies the query's conditions at step 0.\n")
    out.append("\nNo solution for any maxstep.\n\n")
    return "".join(out)


def proof_json(result: InvariantResult, query) -> dict:
    """The ``cplus.plan/1`` result of a ``maxstep :: any`` query."""
    from cplus.output import history_json
    failed = result.failed
    return {
        "query": {"label": result.label, "kind": "query", "min_maxstep": 0, "max_maxstep": "any"},
        "status": result.status.value,
        "maxstep": None,
        "no_solution_with_maxstep": [],
        "histories": [],
        "stats": [],
        "invariant": {
            "formula": result.invariant,
            "initial_states": result.initial_states,
            "checks": [{"check": c.name, "holds": c.holds, "text": c.text, "seconds": round(c.seconds, 6)}
                       for c in result.checks],
            "failed": failed.name if failed else None,
            "counterexample": history_json(failed.counterexample) if failed and failed.counterexample else None,
        },
    }
