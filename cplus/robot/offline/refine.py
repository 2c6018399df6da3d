"""The refinement loop (the paper's Algorithm 1, learning geometry): plan, check, learn, re-plan.

After each plan the continuous checker walks *every* step; each violation depends on the
positions of a few bodies over one motion (an end-effector's two points, or the payload's
four end points; see :func:`trajectory.cause_of`).  The loop forbids exactly those positions
at consecutive steps, at every step of every horizon, as clauses over the position fluents
only, added to the same live solver (lazy clause generation).  Whatever the actions and
whatever the uninvolved robot does, that motion is never proposed again, and since every
clause only excludes plans that would fail the check, running out of plans is a proof that
none is collision-free.

Before the first solve the loop hands the solver what is cheap to know up front (the eager
pre-check): the grid points an arm cannot hold (a number linear in the grid's size) and the
payload turns too fast for its length (a number independent of it); every straight move
between grid points (the square of the grid's size) only when asked (``eager=True``): on the
payload scenes and the small test grids those cost more solver time than the few iterations
they save (measured in bench/ and docs/trajectory.md).

The paper's form (:attr:`NogoodForm.ACTIONS`) forbids the actions executed at the first
violating step while the bodies are where they are, one violation per plan; it is kept for
comparison.  Position nogoods are sound when the check of a motion depends on nothing but the
bound fluents: docs/trajectory.md says what a domain must satisfy for that.

The result carries a :class:`RefineStatus`; the command line maps it to an exit code, and
:meth:`RefinementResult.to_json` is the robot-task form of a ``cplus.plan/1`` result.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from cplus.history import History, decode_history
from cplus.program import QuerySpec
from cplus.robot.offline.nogoods import Nogood, NogoodStore, action_nogood, position_nogood
from cplus.robot.offline.task import RobotTask, TaskError
from cplus.sat.horizon import HorizonStats, QuerySession

__all__ = ["DEFAULT_MAX_HORIZON", "Iteration", "NogoodForm", "Precheck", "RefineStatus",
           "RefinementResult", "refine"]

DEFAULT_MAX_HORIZON = 40
"""Where an open maxstep range (``N..infinity``) stops during refinement unless told."""

REFINE_SOLVER = "minisat22"
"""The solver of a refinement unless told (planning's default is glucose4).  Refinement is
many short incremental solves of one growing CNF; MiniSat's were faster than Glucose's on
every payload scene (``bench/bench_payload.py --paths``, median of 15 solver paths: the
island 0.75 s against 0.80 s, the raised wall 0.66 against 0.70 s, the shipped task alike)."""


class RefineStatus(StrEnum):
    """How a refinement ended (the ``status`` of its JSON result)."""

    FOUND = "found"                    # a collision-free plan
    UNSAFE = "unsafe"                  # refinement off, and the first plan has a violation
    NO_SAFE_PLAN = "no_safe_plan"      # proved: plans exist, none collision-free in the horizon range
    GAVE_UP = "gave_up"                # --max-iterations stopped the loop before a plan or a proof
    NO_PLAN = "no_plan"                # no plan at all in the query's maxstep range
    HORIZON_LIMIT = "horizon_limit"    # no plan at all up to --max-horizon of an open range


class NogoodForm(StrEnum):
    """What a violation teaches the planner."""

    POSITIONS = "positions"    # the involved bodies' positions over the motion, every violation
    ACTIONS = "actions"        # the paper's form: the executed actions where the bodies are, first violation


@dataclass
class Iteration:
    """One pass of the loop: the plan's length, its violations, what was learned from them."""

    number: int
    maxstep: int
    violations: tuple = ()          # trajectory.Violation, by step and time
    learned: tuple[Nogood, ...] = ()
    seconds: float = 0.0

    @property
    def violation(self):
        """The first violation, or ``None`` for a collision-free plan."""
        return self.violations[0] if self.violations else None

    def text(self) -> str:
        head = f"% refinement {self.number}: plan of length {self.maxstep}"
        if not self.violations:
            return f"{head} is collision-free"
        lines = [f"{head}: {len(self.violations)} violation{'s' if len(self.violations) > 1 else ''}"]
        for v in self.violations:
            lines.append(f"%   {v.kind.value} between steps {v.step} and {v.step + 1}: {v.message}")
        if self.learned:
            lines.append("%   forbidding at every step: " + "; ".join(n.text for n in self.learned))
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {"iteration": self.number, "maxstep": self.maxstep,
                "violations": [{"kind": v.kind.value, "step": v.step, "u": v.u, "point": list(v.point),
                                "subject": v.subject, "message": v.message} for v in self.violations],
                "learned": [n.to_json() for n in self.learned], "seconds": round(self.seconds, 6)}


@dataclass
class Precheck:
    """What the eager pre-check handed the solver before the first solve."""

    points: int = 0          # (robot, grid point) it can never hold
    motions: int = 0         # (robot, straight move between grid points) that fails
    pairs_checked: int = 0   # pairs of grid points classified (0: pairs left to the lazy loop)
    length_pairs: int = 0    # payload end vectors (before, after) whose motion leaves the length band
    seconds: float = 0.0

    def text(self) -> str:
        pairs = (f"{self.motions} of {self.pairs_checked} straight moves between them" if self.pairs_checked
                 else "moves between them learned as they occur")
        return (f"% pre-check ({self.seconds:.3f} s): {self.points} grid points an arm cannot hold, {pairs}; "
                f"{self.length_pairs} payload turns too fast for its length")

    def to_json(self) -> dict:
        return {"points": self.points, "motions": self.motions, "pairs_checked": self.pairs_checked,
                "length_pairs": self.length_pairs, "seconds": round(self.seconds, 6)}


@dataclass
class RefinementResult:
    """What :func:`refine` found: the refined plan (or why there is none) and every iteration."""

    status: RefineStatus
    query: QuerySpec
    form: NogoodForm = NogoodForm.POSITIONS
    history: History | None = None
    states: list | None = None
    iterations: list[Iteration] = field(default_factory=list)
    first_history: History | None = None
    first_states: list | None = None
    first_violation: object | None = None
    reason: str = ""
    no_solution_with_maxstep: list[int] = field(default_factory=list)
    horizon: int | None = None       # the last maxstep the loop worked at
    precheck: Precheck | None = None
    session: QuerySession | None = None
    store: NogoodStore | None = None     # what the solver was taught (NogoodStore.excludes explains a plan)
    known: list[Nogood] = field(default_factory=list)   # nogoods given to refine() (learned before)
    optimum: object | None = None    # --minimize: a cplus.sat.optimize.Optimum for the plan found

    @property
    def found(self) -> bool:
        return self.history is not None

    @property
    def learned(self) -> int:
        """Nogoods learned by the loop (the pre-check's not counted)."""
        return sum(len(it.learned) for it in self.iterations)

    @property
    def nogoods(self) -> list[Nogood]:
        """Every nogood this refinement knew or learned: to give the next one (``known``)."""
        return self.known + [ng for it in self.iterations for ng in it.learned]

    @property
    def stats(self) -> list[HorizonStats]:
        return self.session.stats if self.session is not None else []

    @property
    def shown(self) -> History | None:
        """The plan to print: the refined one, or the unsafe first plan when refinement is off."""
        return self.history or (self.first_history if self.status is RefineStatus.UNSAFE else None)

    def to_json(self, label: str | None = None) -> dict:
        from cplus.output import history_json
        hist = self.shown
        q = self.query
        return {
            "query": {"label": label if label is not None else q.label, "kind": "nmquery" if q.nm else "query",
                      "min_maxstep": q.lo, "max_maxstep": q.hi},
            "status": self.status.value,
            "maxstep": hist.maxstep if hist else None,
            "no_solution_with_maxstep": list(self.no_solution_with_maxstep),
            "histories": [history_json(hist)] if hist else [],
            "stats": [{"maxstep": s.maxstep, "variables": s.variables, "clauses": s.clauses,
                       "encode_s": round(s.encode_s, 6), "solve_s": round(s.solve_s, 6),
                       "satisfiable": s.satisfiable} for s in self.stats],
            "refinement": [it.to_json() for it in self.iterations],
            "nogoods": {"form": self.form.value, "learned": self.learned,
                        "precheck": self.precheck.to_json() if self.precheck else None},
            "horizon": self.horizon,
            "reason": self.reason or None,
            **({"optimum": _optimum_json(self.optimum)} if self.optimum is not None else {}),
        }


def _optimum_json(opt) -> dict:
    from cplus.sat.optimize import optimum_fields
    return optimum_fields(opt)


def refine(task: RobotTask, label: str = "0", max_iterations: int | None = None, max_horizon: int | None = None,
           solver: str | None = None, refine: bool = True, *, nogoods: NogoodForm | str = NogoodForm.POSITIONS,
           eager: bool | None = None,
           on_iteration: Callable[[Iteration], None] | None = None,
           on_horizon: Callable[[HorizonStats], None] | None = None,
           on_precheck: Callable[[Precheck], None] | None = None,
           session: QuerySession | None = None, known: Iterable[Nogood] = (),
           minimize=None, time_limit: float | None = None) -> RefinementResult:
    """Plan, check every step continuously, learn, plan again in the same solver.

    ``max_iterations`` (``None`` or 0: no limit) bounds the plans examined; reaching it ends
    with :attr:`RefineStatus.GAVE_UP`.  ``eager``: ``None`` pre-checks points and payload
    turns, ``True`` also every move between two grid points, ``False`` nothing (all is learned
    as plans meet it).  ``refine=False`` checks the first plan only.  ``session``: a live
    solver to refine in (not yet solved), instead of a new one for the query ``label``, and
    ``known``: nogoods learned before (:attr:`RefinementResult.nogoods` of an earlier
    refinement of the same domain), forbidden from the start; the online monitor re-plans
    from the state the arms were found in with both.

    ``minimize`` (a :class:`cplus.sat.optimize.Objective`): the cheapest collision-free plan
    at the shortest length that has one.  Refinement goes on inside the search: each
    collision-free plan of cost ``c`` becomes the best, the bound ``cost =< c - 1`` is assumed,
    and the plans the solver then proposes are checked and learned from as before, until the
    bound has no plan left (the best is optimal among the collision-free plans: every nogood
    only excludes plans that fail the check).  ``time_limit`` (seconds, checked between
    iterations) and Ctrl-C stop it with the best so far, not proved.

    Raises:
        TaskError: the start or goal cannot be reached, or the checker refuses the plan's states.
    """
    form = NogoodForm(nogoods)
    domain = task.domain
    query = domain.query(label)  # type: ignore[attr-defined]
    task.check_start_goal(query)
    if query.hi is None and max_horizon is None:
        max_horizon = DEFAULT_MAX_HORIZON
    if session is None:
        session = QuerySession(domain.theory, query, solver or REFINE_SOLVER, max_horizon)  # type: ignore[attr-defined]
    else:
        query, max_horizon = session.query, session.max_horizon
    result = RefinementResult(RefineStatus.NO_PLAN, query, form, session=session)
    horizon = session.horizon
    store = result.store = NogoodStore(horizon, domain.theory.atoms)  # type: ignore[attr-defined]
    guard = None
    if refine and form is NogoodForm.POSITIONS and eager is not False:
        # behind one assumption, so that an unsatisfiable horizon tells whether it needed them
        guard = horizon.new_var()
        session.assumptions.append(guard)
        result.precheck = _precheck(task, store, guard, bool(eager))
        if on_precheck:
            on_precheck(result.precheck)
    learned: set[tuple] = set()
    for ng in known:
        if ng.key not in learned:
            learned.add(ng.key)
            store.add(ng)
            result.known.append(ng)
    plans_exist = False     # does the domain have a plan in the range, geometry aside?
    number = 0
    opt = _Cheapest(session, minimize, time_limit) if minimize is not None else None

    def finish(status: RefineStatus, reason: str, it: Iteration | None = None, t0: float = 0.0) -> RefinementResult:
        if it is not None:
            it.seconds = time.perf_counter() - t0
            result.iterations.append(it)
            if on_iteration:
                on_iteration(it)
        result.status, result.reason = status, reason
        return result

    for m in session.horizons():
        result.horizon = m
        ok = session.solve_at(m)
        if on_horizon:
            on_horizon(session.stats[-1])
        while ok:
            plans_exist = True
            number += 1
            t0 = time.perf_counter()
            hist = decode_history(session)
            states = task.states(hist)
            violations = _check(task, states, first_only=form is NogoodForm.ACTIONS)
            if result.first_history is None:
                result.first_history, result.first_states = hist, states
                result.first_violation = violations[0] if violations else None
            if not violations:
                result.history, result.states = hist, states
                if opt is None:
                    return finish(RefineStatus.FOUND, "", Iteration(number, m), t0)
                it = Iteration(number, m)
                ok = opt.cheaper(m, hist, states)
                it.seconds = time.perf_counter() - t0
                result.iterations.append(it)
                if on_iteration:
                    on_iteration(it)
                continue
            if not refine:
                return finish(RefineStatus.UNSAFE, "refinement is off (--no-refine) and the plan is not "
                              "collision-free", Iteration(number, m, violations), t0)
            new = []
            for ng in _nogoods(task, hist, states, violations, form):
                if ng.key not in learned:
                    learned.add(ng.key)
                    store.add(ng)
                    new.append(ng)
            if not new:   # cannot happen: the plan violates each of its nogoods, which the solver had
                raise TaskError(f"internal error: the solver proposed a plan of length {m} that its learned "
                                "nogoods forbid")
            it = Iteration(number, m, violations, tuple(new))
            if opt is not None and opt.best is not None and (max_iterations and number >= max_iterations):
                result.iterations.append(it)
                return opt.finish(result, "max_iterations")
            if max_iterations and number >= max_iterations:
                proved = f"; none with maxstep {query.lo}..{m - 1}" if m > query.lo else ""
                return finish(RefineStatus.GAVE_UP, f"gave up after {number} refinement iteration"
                              f"{'s' if number > 1 else ''} (--max-iterations) at maxstep {m}{proved}", it, t0)
            ok = opt.resolve() if opt is not None else session.resolve()
            it.seconds = time.perf_counter() - t0
            result.iterations.append(it)
            if on_iteration:
                on_iteration(it)
            if opt is not None and opt.stopped:
                return opt.finish(result, opt.stopped)
        if opt is not None and opt.best is not None:
            return opt.finish(result, opt.stopped)
        if not plans_exist and guard is not None and guard in horizon.solver.core():
            # the pre-check's clauses took part: does the domain alone have a plan here?
            t0 = time.perf_counter()
            plans_exist = horizon.solver.solve([session.act])
            session.stats[-1].solve_s += time.perf_counter() - t0
        result.no_solution_with_maxstep.append(m)
    hi = query.hi if query.hi is not None else max_horizon
    limit = "" if query.hi is not None else " (--max-horizon)"
    if plans_exist:
        return finish(RefineStatus.NO_SAFE_PLAN, f"no collision-free plan with maxstep {query.lo}..{hi}{limit}")
    status = RefineStatus.NO_PLAN if query.hi is not None else RefineStatus.HORIZON_LIMIT
    return finish(status, f"no plan with maxstep {query.lo}..{hi}{limit}")


def _check(task: RobotTask, states: list, first_only: bool) -> tuple:
    import trajectory
    try:
        if first_only:
            v = trajectory.first_violation(task.scene, states)  # type: ignore[arg-type]
            return () if v is None else (v,)
        return trajectory.all_violations(task.scene, states)  # type: ignore[arg-type]
    except trajectory.TrajectoryError as exc:
        raise TaskError.from_trajectory(exc) from None


def _nogoods(task: RobotTask, hist: History, states: list, violations: tuple, form: NogoodForm) -> list[Nogood]:
    if form is NogoodForm.ACTIONS:
        return [action_nogood(task, hist, violations[0].step)]
    import trajectory
    out = []
    for v in violations:
        cause = trajectory.cause_of(task.scene, states, v)  # type: ignore[arg-type]
        box = trajectory.widen(task.scene, states, cause)  # type: ignore[arg-type]
        held = list(hist.states[cause.first:cause.last + 1]) if cause.holds else None
        out.append(position_nogood(task, box, held))
    return out


def _precheck(task: RobotTask, store: NogoodStore, guard: int, pairs: bool) -> Precheck:
    """The eager pre-check: nogoods for the points an arm cannot hold and the payload turns,
    and with ``pairs`` for every failing move between two grid points, before the first solve."""
    import trajectory
    t0 = time.perf_counter()
    scene = task.scene
    grid = scene.grid  # type: ignore[attr-defined]
    n = (grid.x_max - grid.x_min + 1) * (grid.y_max - grid.y_min + 1)
    bad = trajectory.bad_single_body_motions(scene, pairs=pairs)  # type: ignore[arg-type]
    for b in bad:
        box = {(k, b.robot, axis): (int(p[axis]), int(p[axis])) for k, p in enumerate(b.points) for axis in (0, 1)}
        store.add(position_nogood(task, box), guard)
    turns = trajectory.failing_length_pairs(scene)  # type: ignore[arg-type]
    if turns:
        store.add_vector_pairs(task, turns, guard)
    return Precheck(sum(1 for b in bad if len(b.points) == 1), sum(1 for b in bad if len(b.points) == 2),
                    len(scene.robots) * n * (n - 1) if pairs else 0, len(turns),  # type: ignore[attr-defined]
                    time.perf_counter() - t0)


class _Cheapest:
    """The cheapest collision-free plan at one horizon, searched inside the refinement: the
    bound on the cost is one more assumption of the live solver, so nogoods learned under
    one bound stay for the next (and for longer horizons)."""

    def __init__(self, session: QuerySession, objective, time_limit: float | None) -> None:
        from cplus.sat.optimize import CostBound
        self._bound_cls = CostBound
        self.session = session
        self.objective = objective
        self.deadline = None if time_limit is None else time.perf_counter() + time_limit
        self.base = list(session.assumptions)
        self.bound: Any = None
        self.best: int | None = None
        self.history: History | None = None
        self.states: list | None = None
        self.stopped: str | None = None
        self.solves = 0

    def cheaper(self, m: int, hist: History, states: list) -> bool:
        """A collision-free plan: keep it if cheaper, and solve for a cheaper one."""
        if self.bound is None:
            self.bound = self._bound_cls(self.session, self.objective, m)
        value = self.bound.model_value()
        self.best, self.history, self.states = value, hist, states
        a = self.bound.at_most(value - 1)
        if a is None:
            return False
        self.session.assumptions = self.base + a
        return self.resolve()

    def resolve(self) -> bool:
        if self.deadline is not None and time.perf_counter() >= self.deadline and self.best is not None:
            self.stopped = "time_limit"
            return False
        self.solves += 1
        try:
            return self.session.resolve()
        except KeyboardInterrupt:
            if self.best is None:
                raise
            self.stopped = "interrupted"
            return False

    def finish(self, result: RefinementResult, stopped: str | None) -> RefinementResult:
        from cplus.sat.optimize import Optimum
        assert self.best is not None and self.bound is not None
        self.session.assumptions = list(self.base)
        proved = stopped is None
        result.history = self.history
        result.states = self.states
        result.optimum = Optimum(self.objective.text, self.best, proved,
                                 self.best if proved else self.bound.low, stopped=stopped, solves=self.solves)
        result.status = RefineStatus.FOUND
        result.reason = "" if proved else f"the cheapest plan is not proved ({stopped})"
        return result
