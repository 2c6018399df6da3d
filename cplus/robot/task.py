"""A robot task: a C+ domain plus a ``scene.toml`` that gives it geometry.

The scene provides the ``collision`` external to the grounder and says which fluents give
each end-effector's and each payload end's coordinates; :class:`RobotTask` checks those
bindings against the domain and turns a history into :class:`trajectory.StepState` s.  The
refinement loop that uses it is :mod:`cplus.robot.refine`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from cplus import ir
from cplus.errors import CPlusError, Location
from cplus.ground.pf import mk_and
from cplus.ground.theory import template_lit
from cplus.history import History, executed_actions
from cplus.output import Display
from cplus.program import QuerySpec
from cplus.signature import GroundConst, NamedSort

__all__ = ["TaskError", "RobotTask", "scene_beside"]


def scene_beside(domain_path: str) -> str | None:
    """The ``scene.toml`` beside a domain file, if there is one: it makes the file a robot task."""
    beside = os.path.join(os.path.dirname(os.path.abspath(domain_path)), "scene.toml")
    return beside if os.path.isfile(beside) else None


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

    @classmethod
    def from_trajectory(cls, exc) -> TaskError:
        """Wrap a :class:`trajectory.TrajectoryError` (it carries its own location)."""
        return cls(exc.message, exc.location)


@dataclass
class RobotTask:
    """A domain, its scene, and the ground constants the scene's bindings name."""

    domain: object                 # cplus.api.Domain
    scene: object                  # trajectory.Scene
    robots: dict[str, tuple[GroundConst, GroundConst]]
    ends: dict[str, tuple[GroundConst, GroundConst]]
    holds: dict[tuple[str, str], GroundConst]

    @classmethod
    def load(cls, domain_path: str, scene_path: str, extern_files: list[str] = ()) -> RobotTask:  # type: ignore[assignment]
        """Load the scene first (its errors come before any planning), then the domain with
        the scene's externals, then check every binding against the domain."""
        import trajectory
        from cplus.api import Domain
        from cplus.externals import load_extern_file
        from cplus.resolve import BUILTIN_EXTERNALS
        try:
            scene = trajectory.load_scene(scene_path)
        except trajectory.TrajectoryError as exc:
            raise TaskError.from_trajectory(exc) from None
        ext = BUILTIN_EXTERNALS.copy()
        for name, fn in scene.externals().items():
            ext.add_predicate(name, 4, fn)
        for f in extern_files:
            load_extern_file(f, ext)
        domain = Domain.load(domain_path, ext)
        return cls._bind(domain, scene)

    @classmethod
    def _bind(cls, domain, scene) -> RobotTask:
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
            out.append(StepState(robots=robots, payload=payload, holds=holds, actions=actions))  # type: ignore[arg-type]
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
                    trajectory.check_reachable(self.scene, r, (vx, vy), "start", _tloc(lx))  # type: ignore[arg-type]
            for e, (x, y) in self.ends.items():
                if x.text in goal and y.text in goal:
                    (vx, lx), (vy, _) = goal[x.text], goal[y.text]
                    errors = []
                    for r in self.robots:
                        try:
                            trajectory.check_reachable(self.scene, r, (vx, vy), f"goal of {e}", _tloc(lx))  # type: ignore[arg-type]
                            break
                        except trajectory.TrajectoryError as exc:
                            errors.append(exc)
                    else:
                        raise errors[0]
        except trajectory.TrajectoryError as exc:
            raise TaskError.from_trajectory(exc) from None

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
            text = f.cst.decl.name + (f"({','.join(render_value(a) for a in args)})" if args else "")  # type: ignore[arg-type]
            table[text] = (f.value.value, f.loc)

    for formula, _ in query.items:
        for part in ir.conjuncts(formula):
            if isinstance(part, ir.StampF):
                if isinstance(part.time, ir.Lit) and part.time.value == 0:
                    walk(part.body, start)
                elif isinstance(part.time, ir.MaxStepT):
                    walk(part.body, goal)
    return start, goal
