"""The continuous check: does the motion between two plan states stay safe all the way?

The domain checks its laws only at grid points, once per state. Between two states every
end-effector moves in a straight line, all of them at the same time over ``u`` in [0, 1], and
the payload is carried between the two ends. This module checks that whole motion, exactly
(see `geometry` for why the tests are exact):

* ``payload-collision`` - the region the payload sweeps meets an obstacle;
* ``payload-length`` - the squared payload length, a quadratic in ``u``, leaves the scene's
  band ``[L^2 - tol, L^2 + tol]`` anywhere in [0, 1] (the domain's own convention);
* ``effector-collision`` - an end-effector's straight path meets an obstacle;
* ``out-of-reach`` / ``joint-limit`` - an end-effector point anywhere along its path is out of
  its arm's reach, or no IK branch can follow the path within the joint limits. A robot keeps
  one branch for its whole path (switching needs a stop where both coincide), so the branches
  still possible are carried from step to step;
* ``detached`` - a payload end moves without the robot that holds it (jumps to the other
  robot, or moves while nobody holds it): the trap of the literal payload domain.

`first_violation` gives what the refinement loop needs (the step ``i`` whose motion to
``i + 1`` fails, the kind, the time and point of first contact, a message); `all_violations`
lists every problem of every step, one per kind and subject; `cause_of` says which positions
a violation depends on, so that a planner can forbid exactly those (a *position nogood*).

>>> from trajectory.scene import parse_scene, EXAMPLE_SCENE
>>> scene = parse_scene(EXAMPLE_SCENE, "example.toml")
>>> at = lambda p1, p2: StepState({"r1": p1, "r2": p2}, {"pl1": p1, "pl2": p2},
...                               {"pl1": "r1", "pl2": "r2"})
>>> plan = [at((1, 1), (1, 4)), at((4, 1), (4, 4))]
>>> v = first_violation(scene, plan)
>>> v.step, v.kind.value, round(v.u, 3), v.point
(0, 'effector-collision', 0.333, (2.0, 1.0))
>>> [w.kind.value for w in all_violations(scene, plan)]
['effector-collision', 'payload-collision']
>>> cause_of(scene, plan, v)
Cause(bodies=('r1',), first=0, last=1, holds=False)
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from ._format import fmt, fmt_point
from .geometry import (
    EPS,
    Point2,
    first_exit_from_band,
    first_path_contact,
    first_sweep_contact,
    lerp,
    payload_length_sq,
)
from .kinematics import BranchChoice, choices_at, point_problem, surviving_choices
from .scene import Robot, Scene
from .states import StepState, validate_states
from .violations import Violation, ViolationKind

__all__ = ["ViolationKind", "Violation", "Cause", "first_violation", "all_violations", "check_motion", "cause_of"]


def _same(p: Point2, q: Point2) -> bool:
    scale = max(1.0, abs(p[0]), abs(p[1]), abs(q[0]), abs(q[1]))
    return math.hypot(p[0] - q[0], p[1] - q[1]) <= EPS * scale


def _motion_text(i: int, a: Point2, b: Point2) -> str:
    return f"moving {fmt_point(a)} -> {fmt_point(b)} (step {i} -> {i + 1})"


def _detached(scene: Scene, i: int, a: StepState, b: StepState, last: bool) -> list[Violation]:
    out: list[Violation] = []
    checks = [(i, a, 0.0)] + ([(i + 1, b, 1.0)] if last else [])
    for end in scene.end_names:
        for k, state, u in checks:
            holder = state.holder(end)
            if holder is not None and not _same(state.robots[holder], state.payload[end]):
                out.append(Violation(i, ViolationKind.DETACHED, u, state.payload[end], end,
                    f"step {k}: payload end {end} is said to be held by {holder}, but {end} is "
                    f"at {fmt_point(state.payload[end])} and {holder} at "
                    f"{fmt_point(state.robots[holder])}"))
        ea, eb = a.payload[end], b.payload[end]
        holder = a.holder(end)
        if holder is not None and _same(a.robots[holder], ea):
            rb = b.robots[holder]
            if not _same(eb, rb):
                other = [r for r in scene.robot_names if r != holder and _same(b.robots[r], eb)]
                how = f", to {other[0]}" if other else ""
                out.append(Violation(i, ViolationKind.DETACHED, 0.0, ea, end,
                    f"payload end {end} is held by {holder} at step {i} but does not follow it "
                    f"to step {i + 1}: {holder} moves to {fmt_point(rb)}, {end} goes to "
                    f"{fmt_point(eb)}{how}"))
        elif holder is None and not _same(ea, eb):
            out.append(Violation(i, ViolationKind.DETACHED, 0.0, ea, end,
                f"payload end {end} moves {fmt_point(ea)} -> {fmt_point(eb)} (step {i} -> {i + 1}) "
                "while no robot holds it"))
    return out


def _payload(scene: Scene, i: int, a: StepState, b: StepState) -> list[Violation]:
    out: list[Violation] = []
    e1, e2 = scene.end_names
    a1, a2, b1, b2 = a.payload[e1], a.payload[e2], b.payload[e1], b.payload[e2]
    # swept region against the obstacles
    best = None
    for k in scene.workspace.candidates([a1, a2, b1, b2]):
        contact = first_sweep_contact(a1, a2, b1, b2, scene.obstacles[k].polygon)
        if contact is not None and (best is None or contact.u < best[0].u):
            best = (contact, scene.obstacles[k].name)
    if best is not None:
        contact, name = best
        what = ("at the state itself" if contact.u == 0.0 else
                f"between the states, at u = {fmt(round(contact.u, 4))}")
        out.append(Violation(i, ViolationKind.PAYLOAD_COLLISION, contact.u, contact.point, "payload",
            f"the payload, carried from {fmt_point(a1)}-{fmt_point(a2)} to {fmt_point(b1)}-"
            f"{fmt_point(b2)} (step {i} -> {i + 1}), hits obstacle {name!r} at "
            f"{fmt_point(contact.point)} {what}", name))
    # squared length over the motion
    q = payload_length_sq(a1, a2, b1, b2)
    low, high = scene.payload.length_sq_band
    u = first_exit_from_band(q, low, high)
    if u is not None:
        (u_min, q_min), (u_max, q_max) = q.extremes_on_unit()
        worst_u, worst = (u_min, q_min) if q_min < low else (u_max, q_max)
        mid = lerp(lerp(a1, b1, u), lerp(a2, b2, u), 0.5)
        out.append(Violation(i, ViolationKind.PAYLOAD_LENGTH, u, mid, "payload",
            f"the payload's squared length leaves [{fmt(low)}, {fmt(high)}] while carried from "
            f"{fmt_point(a1)}-{fmt_point(a2)} to {fmt_point(b1)}-{fmt_point(b2)} (step {i} -> "
            f"{i + 1}): from u = {fmt(round(u, 4))}, reaching {fmt(round(worst, 4))} (length "
            f"{fmt(round(math.sqrt(max(worst, 0.0)), 4))}) at u = {fmt(round(worst_u, 4))}"))
    return out


def _effectors(scene: Scene, i: int, a: StepState, b: StepState) -> list[Violation]:
    out: list[Violation] = []
    for robot in scene.robot_names:
        p, q = a.robots[robot], b.robots[robot]
        best = None
        for k in scene.workspace.candidates([p, q]):
            contact = first_path_contact(p, q, scene.obstacles[k].polygon)
            if contact is not None and (best is None or contact.u < best[0].u):
                best = (contact, scene.obstacles[k].name)
        if best is not None:
            contact, name = best
            out.append(Violation(i, ViolationKind.EFFECTOR_COLLISION, contact.u, contact.point, robot,
                f"robot {robot}'s end-effector, {_motion_text(i, p, q)}, hits obstacle {name!r} at "
                f"{fmt_point(contact.point)}", name))
    return out


def _point_violation(i: int, u: float, k: int, robot: Robot, p: Point2) -> Violation:
    """A robot cannot even stand at ``p`` (state ``k``) on any branch."""
    problems = [point_problem(robot.arm, p[0], p[1], br) for br in (1, -1)]
    far = any(pr is not None and pr[0] for pr in problems)
    texts = [f"branch {br:+d}: {pr[1]}" for br, pr in zip((1, -1), problems) if pr is not None]
    detail = problems[0][1] if far and problems[0] is not None else "; ".join(texts)
    kind = ViolationKind.OUT_OF_REACH if far else ViolationKind.JOINT_LIMIT
    return Violation(i, kind, u, p, robot.name,
                     f"robot {robot.name} cannot hold its end-effector at {fmt_point(p)} "
                     f"(step {k}): {detail}")


def _reach(scene: Scene, i: int, a: StepState, b: StepState,
           alive: dict[str, tuple[BranchChoice, ...]], last_motion: bool) -> list[Violation]:
    """Reach and joint limits; updates ``alive`` (the branches each robot can still use)."""
    out: list[Violation] = []
    for robot in scene.robots:
        p, q = a.robots[robot.name], b.robots[robot.name]
        choices = alive[robot.name]
        if not choices:
            out.append(_point_violation(i, 0.0, i, robot, p))
            alive[robot.name] = choices_at(robot.arm, q[0], q[1])
            if last_motion and not alive[robot.name] and not _same(p, q):
                out.append(_point_violation(i, 1.0, i + 1, robot, q))
            continue
        survivors, dead = surviving_choices(robot.arm, choices, p, q)
        if survivors:
            alive[robot.name] = survivors
            continue
        last = max(dead, key=lambda cd: cd[1].u)[1]
        far = any(ex.out_of_reach for _, ex in dead)
        kind = ViolationKind.OUT_OF_REACH if far else ViolationKind.JOINT_LIMIT
        parts = {f"at u = {fmt(round(ex.u, 4))}, {fmt_point(ex.point)}: {ex.reason}"
                 for _, ex in dead}
        if len(parts) == 1 and len(dead) > 1:
            detail = "every branch " + parts.pop()
        else:
            detail = "; ".join(f"{choice} at u = {fmt(round(ex.u, 4))}, {fmt_point(ex.point)}: "
                               f"{ex.reason}" for choice, ex in dead)
        verb = "leaves its reach" if far else "cannot stay within its joint limits"
        out.append(Violation(i, kind, last.u, last.point, robot.name,
            f"robot {robot.name} {verb} {_motion_text(i, p, q)}: {detail}"))
        alive[robot.name] = choices_at(robot.arm, q[0], q[1])
    return out


def check_motion(scene: Scene, step: int, a: StepState, b: StepState, *,
                 last: bool = False) -> list[Violation]:
    """Every violation of one motion except reach and joint limits, sorted by time.

    Reach needs the branches carried over from the earlier steps; `all_violations` and
    `first_violation` add it. ``last`` also checks the ``holds`` consistency of state ``b``.
    """
    found = (_detached(scene, step, a, b, last) + _effectors(scene, step, a, b)
             + _payload(scene, step, a, b))
    return sorted(found, key=lambda v: v.sort_key)


def _by_step(scene: Scene, states: Sequence[StepState]) -> Iterator[list[Violation]]:
    validate_states(scene.robot_names, scene.end_names, states)
    motions = list(zip(states, states[1:])) or [(states[0], states[0])]
    start = states[0]
    alive = {r.name: choices_at(r.arm, *start.robots[r.name]) for r in scene.robots}
    for i, (a, b) in enumerate(motions):
        found = check_motion(scene, i, a, b, last=i == len(motions) - 1)
        found += _reach(scene, i, a, b, alive, i == len(motions) - 1)
        yield sorted(found, key=lambda v: v.sort_key)


def all_violations(scene: Scene, states: Sequence[StepState]) -> tuple[Violation, ...]:
    """Every violation of the plan, by step and time: at most one per kind and subject per step.

    A plan of one state is checked as a motion from that state to itself (step 0).

    Raises
    ------
    PlanStateError
        If a state does not name exactly the scene's robots and payload ends.
    """
    return tuple(v for step in _by_step(scene, states) for v in step)


def first_violation(scene: Scene, states: Sequence[StepState]) -> Violation | None:
    """The earliest violation of the plan (smallest step, then time, then kind), or ``None``.

    This is the ``trajectoryCollision`` of the paper's Algorithm 1: the refinement loop blocks
    the actions executed at ``violation.step`` in a state where the payload is where it is at
    that step, and plans again.
    """
    for found in _by_step(scene, states):
        if found:
            return found[0]
    return None


# ---------------------------------------------------------------------------- causes


@dataclass(frozen=True, slots=True)
class Cause:
    """What a violation depends on, and nothing else.

    The positions of ``bodies`` (robot and payload-end names) at the steps ``first`` to
    ``last`` and, when ``holds`` is set, which robot holds which end there. Every plan whose
    states ``t .. t + (last - first)`` give those bodies the same positions (and holders) has
    a violation within those steps, whatever else happens in it and whatever ``t`` is: the
    check of a motion reads nothing but these. That makes "never these positions at
    consecutive steps" a sound constraint for a planner (see docs/trajectory.md).
    """

    bodies: tuple[str, ...]
    first: int
    last: int
    holds: bool = False

    @property
    def span(self) -> int:
        """How many motions it covers (0: a single state)."""
        return self.last - self.first


def cause_of(scene: Scene, states: Sequence[StepState], violation: Violation) -> Cause:
    """The smallest set of positions (of `Cause`'s kind) that ``violation`` of ``states`` needs.

    * effector collision, payload collision, payload length: the bodies of the motion (the
      robot, or both payload ends) at ``step`` and ``step + 1``, or at one of them alone when
      that state is already bad by itself (checked by the same checker, as a motion from the
      state to itself);
    * out of reach, joint limits: the robot at a point it cannot hold at all, else its path
      from the latest step ``j`` from which the arm, free to take any branch there, cannot
      follow the path to ``step + 1`` (the branch a robot keeps makes the verdict depend on
      where it came from; starting with every branch is the most lenient history);
    * detached: every robot and payload end and who holds what, at both steps.
    """
    i, kind = violation.step, violation.kind
    if kind is ViolationKind.DETACHED:
        return Cause(scene.robot_names + scene.end_names, i, i + 1, holds=True)
    j = min(i + 1, len(states) - 1)
    if kind in (ViolationKind.OUT_OF_REACH, ViolationKind.JOINT_LIMIT):
        robot = scene.robot(violation.subject)
        path = [s.robots[robot.name] for s in states]
        for k in (i, j):
            if not choices_at(robot.arm, *path[k]):
                return Cause((robot.name,), k, k)
        for start in range(i, -1, -1):
            alive = choices_at(robot.arm, *path[start])
            for k in range(start, i + 1):
                alive, _ = surviving_choices(robot.arm, alive, path[k], path[k + 1])
                if not alive:
                    return Cause((robot.name,), start, i + 1)
        raise AssertionError(f"no cause found for {violation}")  # the check itself failed: cannot be
    bodies = (violation.subject,) if kind is ViolationKind.EFFECTOR_COLLISION else scene.end_names
    for k in (i, j):
        still = check_motion(scene, k, states[k], states[k])
        if any(v.kind is kind and v.subject == violation.subject for v in still):
            return Cause(bodies, k, k)
    return Cause(bodies, i, j)
