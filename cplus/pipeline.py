"""From a plan to motion: scenes, the refinement loop (the paper's Algorithm 1), exports.

This is the glue between the planner and :mod:`trajectory` (and, for ``cplus run``,
:mod:`nxt_link`).  A robot task is a C+ domain plus a ``scene.toml``: the scene provides the
``collision`` external to the grounder and says which fluents give each end-effector's
and each payload end's coordinates.

Refinement: after each plan the continuous checker walks the steps; at the first violation
between steps i and i+1 it reports the positions L (every bound coordinate at step i) and the
actions A executed at step i; the planner then forbids "exactly A while the robots and the
payload are at L" at every transition, by clauses added to the same live solver, and solves
again, at longer horizons when the current one runs out.

The paper forbids the conjunction of the executed actions only, which also forbids every
larger action set (a diagonal move that contains the blocked straight one, say); we forbid
the exact set (each action's truth value and the attributes of the executed ones), so no
collision-free motion is lost.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

from cplus import ir
from cplus.errors import CPlusError, Location
from cplus.ground.pf import mk_and
from cplus.ground.theory import template_lit
from cplus.history import History, decode_history, executed_actions
from cplus.output import Display
from cplus.planner import find_horizon
from cplus.program import QuerySpec
from cplus.sat.horizon import QuerySession
from cplus.signature import GroundConst, NamedSort

__all__ = ["TaskError", "RobotTask", "Iteration", "RefinementResult", "refine", "plan_command", "run_command",
           "DEFAULT_MAX_HORIZON"]

DEFAULT_MAX_HORIZON = 40
"""Where an open maxstep range (``N..infinity``) stops during refinement unless told."""


class TaskError(CPlusError):
    """A scene and a domain that do not fit together, or a failed trajectory step.

    ``where`` is ``file:line:col`` in the scene (or domain) file, when known."""

    def __init__(self, message: str, where: object | None = None) -> None:
        super().__init__(message)
        self.where = None if where is None else str(where)

    def render(self) -> str:
        return f"{self.where}: error: {self.message}" if self.where else f"error: {self.message}"

    def __str__(self) -> str:
        return self.render()


def _from_trajectory_error(exc) -> TaskError:
    """Wrap a :class:`trajectory.TrajectoryError` (it carries its own location)."""
    return TaskError(exc.message, exc.location)


@dataclass
class RobotTask:
    """A domain, its scene, and the ground constants the scene's bindings name."""

    domain: object                 # cplus.api.Domain
    scene: object                  # trajectory.Scene
    robots: dict[str, tuple[GroundConst, GroundConst]]
    ends: dict[str, tuple[GroundConst, GroundConst]]
    holds: dict[tuple[str, str], GroundConst]

    @classmethod
    def load(cls, domain_path: str, scene_path: str, extern_files: list[str] = ()) -> "RobotTask":
        """Load the scene first (its errors come before any planning), then the domain with
        the scene's externals, then check every binding against the domain."""
        import trajectory
        from cplus.api import Domain
        from cplus.externals import load_extern_file
        from cplus.resolve import BUILTIN_EXTERNALS
        try:
            scene = trajectory.load_scene(scene_path)
        except trajectory.TrajectoryError as exc:
            raise _from_trajectory_error(exc) from None
        ext = BUILTIN_EXTERNALS.copy()
        for name, fn in scene.externals().items():
            ext.add_predicate(name, 4, fn)
        for f in extern_files:
            load_extern_file(f, ext)
        domain = Domain.load(domain_path, ext)
        return cls._bind(domain, scene)

    @classmethod
    def _bind(cls, domain, scene) -> "RobotTask":
        sig = domain.program.signature
        by_text = {gc.text: gc for gc in sig.ground}

        def fluent(binding) -> GroundConst:
            gc = by_text.get(binding.fluent)
            if gc is None or not gc.decl.is_fluent:
                what = "an unknown fluent" if gc is None else f"a {gc.decl.kind}, not a fluent"
                raise TaskError(f"binding names {what} '{binding.fluent}' (not a ground fluent of "
                                f"{domain.path})", binding.location)
            if not all(isinstance(v, int) for v in gc.domain):
                raise TaskError(f"'{binding.fluent}' has non-integer values; a coordinate binding needs an "
                                "integer fluent", binding.location)
            return gc

        robots = {r.name: (fluent(r.x), fluent(r.y)) for r in scene.robots}
        ends = {e.name: (fluent(e.x), fluent(e.y)) for e in scene.payload.ends}
        hb = scene.payload.holds
        decl = sig.lookup(hb.fluent, 2)
        if decl is None or not decl.is_fluent or decl.domain != NamedSort("boolean"):
            raise TaskError(f"'holds' names '{hb.fluent}', which must be a Boolean fluent holds(Robot,End) "
                            "of the domain", hb.location)
        holds = {}
        for r in robots:
            for e in ends:
                gc = decl.instances.get((r, e))
                if gc is None:
                    raise TaskError(f"the domain has no '{hb.fluent}({r},{e})'", hb.location)
                holds[(r, e)] = gc
        return cls(domain, scene, robots, ends, holds)

    # ------------------------------------------------------------------ states
    def states(self, hist: History) -> list:
        """The plan as :class:`trajectory.StepState` s, one per step."""
        from trajectory import StepState
        display = Display(self.domain.program)  # type: ignore[attr-defined]
        out = []
        for t, state in enumerate(hist.states):
            robots = {r: (state[x], state[y]) for r, (x, y) in self.robots.items()}
            payload = {e: (state[x], state[y]) for e, (x, y) in self.ends.items()}
            holds = {e: next((r for r in self.robots if state[self.holds[(r, e)]] == "true"), None)
                     for e in self.ends}
            actions = tuple(display.action_atoms(hist.actions[t])) if t < len(hist.actions) else ()
            out.append(StepState(robots=robots, payload=payload, holds=holds, actions=actions))
        return out

    def check_start_goal(self, query: QuerySpec) -> None:
        """Every robot must reach its start point, and each payload end's goal must be
        reachable by a robot, before anything is planned."""
        import trajectory
        start, goal = _stamped_values(query)
        try:
            for r, (x, y) in self.robots.items():
                if x.text in start and y.text in start:
                    (vx, lx), (vy, _) = start[x.text], start[y.text]
                    trajectory.check_reachable(self.scene, r, (vx, vy), "start", _tloc(lx))
            for e, (x, y) in self.ends.items():
                if x.text in goal and y.text in goal:
                    (vx, lx), (vy, _) = goal[x.text], goal[y.text]
                    errors = []
                    for r in self.robots:
                        try:
                            trajectory.check_reachable(self.scene, r, (vx, vy), f"goal of {e}", _tloc(lx))
                            break
                        except trajectory.TrajectoryError as exc:
                            errors.append(exc)
                    else:
                        raise errors[0]
        except trajectory.TrajectoryError as exc:
            raise _from_trajectory_error(exc) from None

    def forbidden(self, hist: History, step: int) -> tuple:
        """The template formula "exactly these actions at these positions" at ``step``,
        and its description."""
        atoms = self.domain.theory.atoms  # type: ignore[attr-defined]
        state, acts = hist.states[step], hist.actions[step]
        lits = []
        where = []
        for gcs in list(self.robots.values()) + list(self.ends.values()):
            for gc in gcs:
                lits.append(template_lit(atoms.lit(gc, state[gc]), 0))
        for name, (x, y) in list(self.robots.items()) + list(self.ends.items()):
            where.append(f"{name} at ({state[x]},{state[y]})")
        done = set(executed_actions(acts))
        for gc, v in acts.items():
            d = gc.decl
            if d.hidden or d.kind not in ("exogenousAction", "action", "attribute"):
                continue
            if d.kind == "attribute":
                parent = d.parent.instances.get(gc.args[:d.parent.arity])  # type: ignore[union-attr]
                if parent in done:
                    lits.append(template_lit(atoms.lit(gc, v), 0))
                continue
            lits.append(template_lit(atoms.lit(gc, v), 0))
        display = Display(self.domain.program)  # type: ignore[attr-defined]
        return mk_and(lits), display.action_atoms(acts), where


def _tloc(loc: Location | None):
    if loc is None:
        return None
    from trajectory.errors import Location as TLoc
    return TLoc(loc.path, loc.line, loc.col)


def _stamped_values(query: QuerySpec) -> tuple[dict, dict]:
    """Values that the query fixes at step 0 and at maxstep: ``{text: (value, loc)}``."""
    start: dict = {}
    goal: dict = {}

    def walk(f, table) -> None:
        if isinstance(f, ir.And):
            for x in f.items:
                walk(x, table)
        elif isinstance(f, ir.Atom) and isinstance(f.cst, ir.Cst) and isinstance(f.value, ir.Lit) \
                and all(isinstance(a, ir.Lit) for a in f.cst.args):
            args = [a.value for a in f.cst.args]  # type: ignore[union-attr]
            from cplus.signature import render_value
            text = f.cst.decl.name + (f"({','.join(render_value(a) for a in args)})" if args else "")
            table[text] = (f.value.value, f.loc)

    for formula, _ in query.items:
        for part in ir.conjuncts(formula):
            if isinstance(part, ir.StampF):
                if isinstance(part.time, ir.Lit) and part.time.value == 0:
                    walk(part.body, start)
                elif isinstance(part.time, ir.MaxStepT):
                    walk(part.body, goal)
    return start, goal


# --------------------------------------------------------------------------- refinement


@dataclass
class Iteration:
    number: int
    maxstep: int
    violation: object | None       # trajectory.Violation
    actions: list[str] = field(default_factory=list)
    where: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def text(self) -> str:
        if self.violation is None:
            return f"% refinement {self.number}: plan of length {self.maxstep} is collision-free"
        v = self.violation
        acts = "  ".join(self.actions) or "no action"
        return (f"% refinement {self.number}: plan of length {self.maxstep}: {v.kind.value} between steps "
                f"{v.step} and {v.step + 1}: {v.message}\n"
                f"%   forbidding {{{acts}}} where {', '.join(self.where)}")


@dataclass
class RefinementResult:
    history: History | None
    states: list | None
    iterations: list[Iteration]
    first_history: History | None
    first_states: list | None
    first_violation: object | None
    reason: str = ""
    session: QuerySession | None = None

    @property
    def found(self) -> bool:
        return self.history is not None


def refine(task: RobotTask, label: str = "0", max_iterations: int = 100, max_horizon: int | None = None,
           solver: str | None = None, refine: bool = True,
           on_iteration: Callable[[Iteration], None] | None = None,
           on_horizon: Callable | None = None) -> RefinementResult:
    """Algorithm 1: plan, check continuously, forbid, plan again in the same solver."""
    import trajectory
    from cplus.sat.solver import DEFAULT_SOLVER
    domain = task.domain
    query = domain.query(label)  # type: ignore[attr-defined]
    task.check_start_goal(query)
    if query.hi is None and max_horizon is None:
        max_horizon = DEFAULT_MAX_HORIZON
    session = QuerySession(domain.theory, query, solver or DEFAULT_SOLVER, max_horizon)  # type: ignore
    failed = find_horizon(session, on_horizon)
    result = RefinementResult(None, None, [], None, None, None, session=session)
    result.failed = failed  # type: ignore[attr-defined]
    if session.found is None:
        result.reason = _exhausted(query, max_horizon)
        return result
    number = 0
    while True:
        number += 1
        t0 = time.perf_counter()
        hist = decode_history(session)
        states = task.states(hist)
        try:
            violation = trajectory.first_violation(task.scene, states)
        except trajectory.TrajectoryError as exc:
            raise _from_trajectory_error(exc) from None
        if result.first_history is None:
            result.first_history, result.first_states, result.first_violation = hist, states, violation
        if violation is None or not refine:
            it = Iteration(number, hist.maxstep, violation, seconds=time.perf_counter() - t0)
            result.iterations.append(it)
            if on_iteration:
                on_iteration(it)
            if violation is None:
                result.history, result.states = hist, states
            else:
                result.reason = "refinement is off (--no-refine)"
            return result
        pf, acts, where = task.forbidden(hist, violation.step)
        session.horizon.forbid_everywhere(pf)
        it = Iteration(number, hist.maxstep, violation, acts, where)
        if number >= max_iterations:
            it.seconds = time.perf_counter() - t0
            result.iterations.append(it)
            if on_iteration:
                on_iteration(it)
            result.reason = f"no collision-free plan after {max_iterations} refinement iterations"
            return result
        ok = session.resolve()
        while not ok:
            nxt = session.horizon.m + 1
            if session.query.hi is not None and nxt > session.query.hi or \
                    max_horizon is not None and nxt > max_horizon:
                it.seconds = time.perf_counter() - t0
                result.iterations.append(it)
                if on_iteration:
                    on_iteration(it)
                result.reason = "no collision-free plan: " + _exhausted(query, max_horizon)
                return result
            ok = session.solve_at(nxt)
            if on_horizon:
                on_horizon(session.stats[-1])
        it.seconds = time.perf_counter() - t0
        result.iterations.append(it)
        if on_iteration:
            on_iteration(it)


def _exhausted(query: QuerySpec, max_horizon: int | None) -> str:
    hi = query.hi if query.hi is not None else max_horizon
    return f"no plan with maxstep {query.lo}..{hi}" + (" (--max-horizon)" if query.hi is None else "")


# --------------------------------------------------------------------------- commands


def _export(task: RobotTask, states: list, violation, args: argparse.Namespace, domain_path: str) -> None:
    import trajectory
    for out in (args.plot, args.trajectory, args.csv):
        if out:
            os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
    try:
        if args.plot:
            trajectory.plot_plan(task.scene, states, violation, path=args.plot,
                                 title=f"{os.path.basename(domain_path)}: plan of length {len(states) - 1}")
            print(f"% wrote {args.plot}", file=sys.stderr)
        if args.trajectory or args.csv:
            if violation is not None:
                raise TaskError("the plan is not collision-free; refusing to export its trajectory")
            traj = trajectory.build_trajectory(task.scene, states, points_per_step=args.points_per_step,
                                               step_time_s=args.step_time, source={"domain": domain_path})
            if args.trajectory:
                trajectory.save_json(traj, args.trajectory)
                print(f"% wrote {args.trajectory}", file=sys.stderr)
            if args.csv:
                trajectory.save_csv(traj, args.csv)
                print(f"% wrote {args.csv}", file=sys.stderr)
    except trajectory.TrajectoryError as exc:
        raise _from_trajectory_error(exc) from None
    except OSError as exc:
        raise TaskError(f"cannot write output: {exc.strerror or exc}") from None


def plan_command(args: argparse.Namespace, scene_path: str) -> int:
    """``cplus plan DOMAIN`` when a scene is present: plan, refine, print, export."""
    from cplus.cli import EXIT_INPUT, EXIT_NO_PLAN, EXIT_NO_SAFE_PLAN, EXIT_OK, _progress, _warn
    from cplus.output import format_result
    if args.n != 1:
        print("cplus plan: -n applies to plain domains; a robot task yields one refined plan",
              file=sys.stderr)
        return EXIT_INPUT
    seen: set = set()
    task = RobotTask.load(args.file, scene_path, args.extern)
    domain = task.domain
    _warn(domain.diagnostics, seen)  # type: ignore[attr-defined]
    labels = [args.query] if args.query else domain.labels  # type: ignore[attr-defined]
    from cplus.cli import _query
    code = EXIT_OK
    docs = []
    for label in labels:
        _query(domain, label, args.file)
        result = refine(task, label, args.max_iterations, args.max_horizon, args.solver, not args.no_refine,
                        on_iteration=lambda it: print(it.text(), file=sys.stderr),
                        on_horizon=_progress(args.stats))
        _warn(domain.diagnostics, seen)  # type: ignore[attr-defined]
        display = Display(domain.program)  # type: ignore[attr-defined]
        # the result is the refined plan; an unsafe plan is shown only when asked for
        shown = result.history or (result.first_history if args.no_refine else None)
        states = result.states or result.first_states
        failed = getattr(result, "failed", [])
        if result.history is None and not args.no_refine and result.session is not None:
            failed = sorted({st.maxstep for st in result.session.stats})   # none of them has a safe plan
        if args.json:
            docs.append(_result_json(task, label, result))
        else:
            sys.stdout.write(format_result(display, failed, [shown] if shown else [], False))
        if result.first_history is None:
            print(f"% {result.reason}", file=sys.stderr)
            code = max(code, EXIT_NO_PLAN)
            continue
        if result.history is None:
            print(f"% {result.reason}", file=sys.stderr)
            if not args.no_refine:
                code = max(code, EXIT_NO_SAFE_PLAN)
                continue
        _export(task, states, None if result.history else result.first_violation, args, args.file)
    if args.json:
        from cplus.output import PLAN_FORMAT
        json.dump({"format": PLAN_FORMAT, "file": args.file, "results": docs}, sys.stdout, indent=1)
        sys.stdout.write("\n")
    return code


def _result_json(task: RobotTask, label: str, result: RefinementResult) -> dict:
    from cplus.output import history_json
    hist = result.history or (result.first_history if result.reason.startswith("refinement is off") else None)
    return {
        "query": {"label": label},
        "status": "found" if result.history else ("unsafe" if hist else
                                                  ("no_safe_plan" if result.first_history else "no_plan")),
        "maxstep": hist.maxstep if hist else None,
        "histories": [history_json(hist)] if hist else [],
        "refinement": [{"iteration": it.number, "maxstep": it.maxstep,
                        "violation": None if it.violation is None else {
                            "kind": it.violation.kind.value, "step": it.violation.step,
                            "u": it.violation.u, "point": list(it.violation.point),
                            "subject": it.violation.subject, "message": it.violation.message},
                        "forbidden_actions": it.actions, "where": it.where} for it in result.iterations],
        "reason": result.reason or None,
    }


def run_command(args: argparse.Namespace) -> int:
    """``cplus run``: plan and refine, export the trajectory, execute it on the bricks (emulated
    ones on pseudo-terminals when no ``--brick`` is given), report the tracking error and draw
    the plan and the execution.  Every product goes to ``--out``."""
    from cplus.cli import EXIT_NO_PLAN, EXIT_NO_SAFE_PLAN, EXIT_OK, _progress, _warn
    from cplus.execute import execute_main
    from cplus.output import PLAN_FORMAT, format_result
    scene_path = args.scene or os.path.join(os.path.dirname(os.path.abspath(args.file)), "scene.toml")
    if not os.path.isfile(scene_path):
        raise TaskError(f"no scene: '{scene_path}' does not exist (give --scene FILE)")
    out = args.out
    os.makedirs(out, exist_ok=True)
    paths = {k: os.path.join(out, name) for k, name in (
        ("plan", "plan.txt"), ("json", "plan.json"), ("picture", "plan.png"), ("trajectory", "trajectory.json"),
        ("csv", "trajectory.csv"), ("log", "execution.json"), ("execution", "execution.png"),
        ("report", "report.txt"))}
    seen: set = set()
    task = RobotTask.load(args.file, scene_path, args.extern)
    _warn(task.domain.diagnostics, seen)  # type: ignore[attr-defined]
    from cplus.cli import _query
    _query(task.domain, args.query, args.file)
    print(f"% planning {args.file} (query {args.query}) with the scene {scene_path}", file=sys.stderr)
    result = refine(task, args.query, args.max_iterations, args.max_horizon, args.solver,
                    on_iteration=lambda it: print(it.text(), file=sys.stderr), on_horizon=_progress(False))
    if result.history is None:
        print(f"% {result.reason}", file=sys.stderr)
        return EXIT_NO_SAFE_PLAN if result.first_history is not None else EXIT_NO_PLAN
    text = format_result(Display(task.domain.program), [], [result.history], False)  # type: ignore
    sys.stdout.write(text)
    with open(paths["plan"], "w", encoding="utf-8") as fh:
        fh.write(text)
    with open(paths["json"], "w", encoding="utf-8") as fh:
        json.dump({"format": PLAN_FORMAT, "file": args.file,
                   "results": [_result_json(task, args.query, result)]}, fh, indent=1)
    export = argparse.Namespace(plot=paths["picture"], trajectory=paths["trajectory"], csv=paths["csv"],
                                points_per_step=args.points_per_step, step_time=args.step_time)
    _export(task, result.states, None, export, args.file)
    print(f"% executing {paths['trajectory']} on "
          + ("the bricks " + ", ".join(args.brick) if args.brick else "emulated bricks"), file=sys.stderr)
    argv = [paths["trajectory"], "--scene", scene_path, "--log", paths["log"], "--plot", paths["execution"],
            "--report", paths["report"]]
    for b in args.brick:
        argv += ["--brick", b]
    code = execute_main(argv)
    if code == EXIT_OK and os.path.isfile(paths["report"]):
        with open(paths["report"], encoding="utf-8") as fh:
            sys.stdout.write("\n" + fh.read())
    return code
