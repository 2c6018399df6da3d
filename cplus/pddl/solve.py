"""Planning for a PDDL problem through its C+ translation, and the plans it gives: each step's
actions linearized, every plan checked by unified-planning's validator before it is returned.
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from cplus.errors import CPlusError
from cplus.pddl.derived import check_plan, rules_of
from cplus.pddl.errors import PddlError
from cplus.pddl.translate import COST_FLUENT, QUERY_LABEL, Translation, action_cost, changed_atoms, translate

__all__ = ["PddlPlan", "PlanInvalidError", "plan_problem", "ipc_text", "plan_json", "PROOF_ATOMS", "FORMAT"]

FORMAT = "cplus.pddl-plan/1"

PROOF_ATOMS = 16
"""A problem whose actions change at most this many ground atoms has at most 2^n states, so no
plan of 2^n - 1 steps or fewer means no plan at all: its search range is closed there and a
failure is a proof.  Beyond it the range is open (``--max-horizon`` bounds it)."""


class PlanInvalidError(CPlusError):
    """An internal error: a plan found that unified-planning's validator refuses (never printed)."""


class PddlPlan:
    """The answer to a PDDL problem.

    ``status``: ``"found"``, ``"no_plan"`` (the whole range searched: ``proved`` says whether the
    range covered every plan, see :data:`PROOF_ATOMS`) or ``"horizon_limit"`` (``max_horizon``
    reached); ``steps``: the parallel steps, each a list of unified-planning ``ActionInstance``
    in a valid order; ``plan``: their linearization (a ``SequentialPlan``, validated);
    ``cost``: its total cost (unit costs without :action-costs); ``optimal``: what is proved
    optimal (``"length"``, ``"cost"`` or None)."""

    def __init__(self, problem: Any, status: str, steps: list[list[Any]], maxstep: int | None, proved: bool,
                 cost: int | None, action_costs: bool, optimal: str | None, sequential: bool) -> None:
        self.problem = problem
        self.status = status
        self.steps = steps
        self.maxstep = maxstep
        self.proved = proved
        self.cost = cost
        self.action_costs = action_costs
        self.optimal = optimal
        self.sequential = sequential

    @property
    def plan(self) -> Any:
        from unified_planning.plans import SequentialPlan
        return SequentialPlan([a for step in self.steps for a in step], self.problem.environment)


def _instance_text(a: Any) -> str:
    args = " ".join(str(o.object().name) for o in a.actual_parameters)
    return f"({a.action.name}{' ' + args if args else ''})".lower()


def _steps(tr: Translation, history: Any) -> list[list[Any]]:
    from cplus.history import executed_actions
    steps = []
    for table in history.actions:
        done = sorted(executed_actions(table), key=lambda gc: gc.text)
        steps.append([tr.action_instance(gc.decl.name, gc.args) for gc in done if gc.decl.name in tr.actions])
    return steps


def validate(problem: Any, steps: list[list[Any]]) -> None:
    """Raise :class:`PlanInvalidError` unless unified-planning's sequential validator accepts
    the linearized plan; for a problem with derived predicates, which unified-planning cannot
    represent, unless :func:`cplus.pddl.derived.check_plan` does (an explicit-state simulation
    with the least fixpoint of the rules, independent of the translation)."""
    if rules_of(problem):
        try:
            reason = check_plan(problem, steps)
        except Exception as exc:  # noqa: BLE001 - whatever stops the check, the plan is not printed
            raise PlanInvalidError(f"internal error: the plan found for {problem.name} could not be validated "
                                   f"({type(exc).__name__}: {exc}); not printed") from None
        if reason:
            raise PlanInvalidError(f"internal error: the plan found for {problem.name} is not valid "
                                   f"({reason}); not printed")
        return
    from unified_planning.engines import SequentialPlanValidator, ValidationResultStatus
    from unified_planning.plans import SequentialPlan
    try:
        with SequentialPlanValidator(environment=problem.environment) as validator:
            target = problem if validator.supports(problem.kind) else _without_costs(problem)
            plan = SequentialPlan([a for step in steps for a in step], problem.environment)
            result = validator.validate(target, plan)
    except Exception as exc:  # noqa: BLE001 - whatever stops the validator, the plan is not printed
        raise PlanInvalidError(f"internal error: the plan found for {problem.name} could not be validated "
                               f"({type(exc).__name__}: {exc}); not printed") from None
    if result.status is not ValidationResultStatus.VALID:
        raise PlanInvalidError(f"internal error: the plan found for {problem.name} is not valid "
                               f"({result.reason or 'refused by the validator'}); not printed")


def _without_costs(problem: Any) -> Any:
    """The problem as the validator takes it when static cost functions are left undefined for
    some arguments (IPC 2008's transport): without its cost metric, the undefined values set to 0.
    What they stood for, that such an instance is not applicable, the translation enforces and
    :func:`plan_cost` checks."""
    import itertools
    clone = problem.clone()
    clone.clear_quality_metrics()
    for f in clone.fluents:
        if f.type.is_bool_type():
            continue
        pools = [list(clone.objects(q.type)) for q in f.signature]
        for args in itertools.product(*pools):
            if clone.initial_value(f(*args)) is None:
                clone.set_initial_value(f(*args), 0)
    return clone


def plan_cost(problem: Any, steps: list[list[Any]]) -> int:
    metrics = [m for m in problem.quality_metrics if m.is_minimize_action_costs()]
    if not metrics:
        return sum(len(s) for s in steps)
    total = 0
    values = problem.initial_values
    for step in steps:
        for a in step:
            args = {q.name: o.object() for q, o in zip(a.action.parameters, a.actual_parameters)}
            k = action_cost(problem, metrics[0].get_action_cost(a.action), args, values)
            if k is None:
                raise PlanInvalidError(f"internal error: the plan found for {problem.name} has {a}, whose cost "
                                       "is undefined; not printed")
            total += k
    return total


def plan_problem(problem: Any, sequential: bool = False, minimize: bool = False, over_lengths: bool = False,
                 max_horizon: int | None = None, solver: str | None = None,
                 time_limit: float | None = None, name: str = "<pddl>") -> PddlPlan:
    """Plan for a unified-planning problem (read and checked by :func:`cplus.pddl.read_problem`,
    or built in Python and checked by :func:`cplus.pddl.check_kind`): the plan of fewest steps
    (forall-step, or one action a step with ``sequential``); with ``minimize`` (a problem with
    action costs) the cheapest plan of that length, or of any length with ``over_lengths``."""
    from cplus.api import Domain
    from cplus.sat.solver import DEFAULT_SOLVER
    solver = solver or DEFAULT_SOLVER
    action_costs = any(m.is_minimize_action_costs() for m in problem.quality_metrics)
    if minimize and not action_costs:
        raise PddlError(f"problem {problem.name} has no action costs to minimize (its domain does not declare "
                        ":action-costs, or it has no total-cost metric)")
    atoms = changed_atoms(problem)
    bound = 2 ** atoms - 1 if atoms <= PROOF_ATOMS else None
    horizon = bound if max_horizon is None else max_horizon if bound is None else min(bound, max_horizon)
    proved_range = bound is not None and horizon == bound
    tr = translate(problem, sequential, None, horizon)
    with _translation_errors(problem, name):
        domain = Domain.from_text(tr.text, name)
        result = domain.solve(QUERY_LABEL, 1, solver, None if horizon is not None else max_horizon)
    status = result.status.value
    if status == "no_plan" and not proved_range:
        status = "horizon_limit"           # the range was closed by max_horizon, not by the proof bound
    if status != "found":
        return PddlPlan(problem, status, [], None, status == "no_plan", None, action_costs, None, sequential)
    steps = _steps(tr, result.histories[0])
    validate(problem, steps)
    cost = plan_cost(problem, steps)
    optimal = "length" if sequential and not action_costs else None
    if minimize and cost > 0:
        tr2 = translate(problem, sequential, cost, horizon)
        with _translation_errors(problem, name):
            d2 = Domain.from_text(tr2.text, name)
        limit = max_horizon if horizon is None else None
        if over_lengths and horizon is None and limit is None:
            raise CPlusError("--over-lengths needs a bounded range: give --max-horizon")
        with _translation_errors(problem, name):
            best = d2.minimize(QUERY_LABEL, COST_FLUENT, 1, over_lengths, time_limit, solver, limit)
        if best.histories:
            steps = _steps(tr2, best.histories[0])
            validate(problem, steps)
            cost = plan_cost(problem, steps)
        proved = best.optimum is not None and best.optimum.proved
        optimal = "cost" if proved and over_lengths and proved_range else None
    elif minimize and over_lengths:
        optimal = "cost"                       # cost 0: nothing is cheaper
    return PddlPlan(problem, "found", steps, len(steps), False, cost, action_costs, optimal, sequential)


@contextmanager
def _translation_errors(problem: Any, name: str) -> Iterator[None]:
    """An error of the C+ front end, grounder or encoder located in the translation (a problem
    beyond cplus's size limits: an action declared over a million argument tuples) as one line
    about the PDDL problem, naming the line of the C+ that ``cplus translate`` prints."""
    try:
        yield
    except CPlusError as exc:
        if exc.loc is None or exc.loc.path != name:
            raise
        law = exc.loc.source.line_text(exc.loc.line)
        hint = "; --sequential has no such laws" if law.startswith("nonexecutable") and " & " in law else ""
        raise PddlError(f"problem {problem.name} is beyond cplus's limits once translated to C+: {exc.message} "
                        f"(line {exc.loc.line} of what cplus translate prints{hint})") from None


def ipc_text(plan: PddlPlan) -> str:
    """The IPC plan format: one ``(action arg ...)`` a line, then the cost line."""
    lines = [_instance_text(a) for step in plan.steps for a in step]
    kind = "general cost" if plan.action_costs else "unit cost"
    lines.append(f"; cost = {plan.cost} ({kind})")
    return "\n".join(lines) + "\n"


def plan_json(plan: PddlPlan, domain: str, problem: str) -> dict:
    """The ``cplus.pddl-plan/1`` document of a plan (docs/pddl.md has the schema)."""
    return {"format": FORMAT, "domain": domain, "problem": problem,
            "semantics": "sequential" if plan.sequential else "forall-step",
            "status": plan.status, "proved": plan.proved,
            "steps": [[_instance_text(a) for a in step] for step in plan.steps] if plan.status == "found" else None,
            "plan": [_instance_text(a) for step in plan.steps for a in step] if plan.status == "found" else None,
            "cost": plan.cost, "cost_kind": "action-costs" if plan.action_costs else "unit",
            "optimal": plan.optimal, "validated": plan.status == "found"}
