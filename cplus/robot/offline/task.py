"""A robot task: a C+ domain plus a ``scene.toml`` that gives it geometry.

The scene provides the ``collision`` external to the grounder and says which fluents give
each end-effector's and each payload end's coordinates; :class:`RobotTask` checks those
bindings against the domain and turns a history into :class:`trajectory.StepState` s.  The
refinement loop that uses it is :mod:`cplus.robot.offline.refine`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from cplus import ir
from cplus.errors import CPlusError, Location
from cplus.history import History
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

        def coordinate(binding, axis: int) -> GroundConst:
            """A coordinate fluent must range over exactly the scene's grid: the checker, the
            pre-check and the learned nogoods all speak of grid points."""
            gc = fluent(binding)
            g = scene.grid
            lo, hi = (g.x_min, g.x_max) if axis == 0 else (g.y_min, g.y_max)
            if set(gc.domain) != set(range(lo, hi + 1)):
                values = sorted(gc.domain)
                have = (f"{values[0]}..{values[-1]}" if values == list(range(values[0], values[-1] + 1))
                        else ", ".join(map(str, values)))
                name = "xy"[axis]
                raise TaskError(f"'{binding.fluent}' ranges over {have}, but the scene's [grid] has {name} in "
                                f"{lo}..{hi} ({name}_min, {name}_max): make them agree", binding.location)
            return gc

        robots = {r.name: (coordinate(r.x, 0), coordinate(r.y, 1)) for r in scene.robots}
        ends = {e.name: (coordinate(e.x, 0), coordinate(e.y, 1)) for e in scene.payload.ends}
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
            holds = {e: next((r for r in self.robots if state[self.holds[(r, e)]] is True), None)
                     for e in self.ends}
            actions = tuple(display.action_atoms(hist.actions[t])) if t < len(hist.actions) else ()
            out.append(StepState(robots=robots, payload=payload, holds=holds, actions=actions))  # type: ignore[arg-type]
        return out

    def check_start_goal(self, query: QuerySpec) -> None:
        """Before anything is planned: every robot can hold its start point, outside the
        obstacles; the payload's start and goal lie outside the obstacles, within its length
        band; each payload end's goal is reachable by some robot.  Each refusal is one error
        located at the query."""
        import trajectory
        scene = self.scene
        start, goal = _stamped_values(query)

        def point(table: dict, fluents: tuple) -> tuple | None:
            x, y = fluents
            if x.text in table and y.text in table:
                (vx, loc), (vy, _) = table[x.text], table[y.text]
                return (vx, vy), loc
            return None
        try:
            for r, fluents in self.robots.items():
                found = point(start, fluents)
                if found:
                    (p, loc) = found
                    trajectory.check_reachable(scene, r, p, "start", _tloc(loc))  # type: ignore[arg-type]
                    self._clear(f"robot {r}'s start {_pt(p)}", p, p, loc)
            for e, fluents in self.ends.items():
                found = point(goal, fluents)
                if found:
                    (p, loc) = found
                    errors = []
                    for r in self.robots:
                        try:
                            trajectory.check_reachable(scene, r, p, f"goal of {e}", _tloc(loc))  # type: ignore[arg-type]
                            break
                        except trajectory.TrajectoryError as exc:
                            errors.append(exc)
                    else:
                        raise errors[0]
        except trajectory.TrajectoryError as exc:
            raise TaskError.from_trajectory(exc) from None
        for table, when in ((start, "start"), (goal, "goal")):
            ends = [point(table, f) for f in self.ends.values()]
            for e, found in zip(self.ends, ends):
                if found:
                    self._clear(f"payload end {e}'s {when} {_pt(found[0])}", found[0], found[0], found[1])
            if all(ends):
                (a, loc), (b, _) = ends  # type: ignore[misc]
                self._clear(f"the payload's {when} {_pt(a)}-{_pt(b)}", a, b, loc)
                low, high = scene.payload.length_sq_band  # type: ignore[attr-defined]
                sq = (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2
                if not low <= sq <= high:
                    raise TaskError(f"the payload's {when} {_pt(a)}-{_pt(b)} has squared length {sq}, outside the "
                                    f"scene's [{low:g}, {high:g}] (payload length and tolerance_sq)", loc)

    def _clear(self, what: str, a: tuple, b: tuple, loc) -> None:
        """Refuse a point or segment of the query that meets an obstacle."""
        names = self.scene.obstacles_met(*a, *b)  # type: ignore[attr-defined]
        if names:
            raise TaskError(f"{what} is inside obstacle '{names[0]}'" if a == b
                            else f"{what} meets obstacle '{names[0]}'", loc)

    # ------------------------------------------------------------------ nogoods
    def body_fluents(self, body: str) -> tuple[GroundConst, GroundConst]:
        """The fluents of a robot's or a payload end's coordinates."""
        return self.robots.get(body) or self.ends[body]


def _pt(p: tuple) -> str:
    return f"({p[0]},{p[1]})"


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
