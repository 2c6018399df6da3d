"""Helpers for the trajectory tests: scene paths, carried states, hand-made payload plans."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from trajectory import StepState

REPO = Path(__file__).resolve().parents[2]
PAYLOAD_SCENE = REPO / "domains" / "payload" / "scene.toml"

Point = tuple[float, float]


def carried(p1: Point, p2: Point, actions: Sequence[str] = ()) -> StepState:
    """A state where r1 holds pl1 at p1 and r2 holds pl2 at p2."""
    return StepState({"r1": p1, "r2": p2}, {"pl1": p1, "pl2": p2}, {"pl1": "r1", "pl2": "r2"},
                     tuple(actions))


def plan(*pairs: tuple[Point, Point]) -> list[StepState]:
    """Carried states from (r1, r2) position pairs."""
    return [carried(p, q) for p, q in pairs]


# A plan the payload domain allows (every grid-point law holds) and the continuous check
# accepts: found by a discrete simulation of the domain with Algorithm 1 (see scene.toml).
CLEAN_PAYLOAD_PLAN = [
    ((0, 0), (0, 5)), ((0, 0), (0, 5)), ((1, 1), (1, 6)), ((2, 2), (2, 7)), ((6, 2), (5, 7)),
    ((7, 1), (6, 6)), ((8, 0), (7, 5)), ((9, -1), (8, 4)), ((10, 0), (9, 5)), ((10, 0), (10, 5)),
]

# The first plan of that simulation: grid-point clean, but from step 3 to 4 the stick is
# rotated from (2,2)-(2,7) to (6,2)-(3,6) and its squared length dips to 22.5 < 23 mid-way.
FIRST_PAYLOAD_PLAN = [
    ((0, 0), (0, 5)), ((0, 0), (0, 5)), ((1, 1), (1, 6)), ((2, 2), (2, 7)), ((6, 2), (3, 6)),
    ((7, 1), (4, 5)), ((8, 0), (5, 4)), ((9, 0), (6, 4)), ((10, 0), (9, 5)), ((10, 0), (10, 5)),
]


# ---------------------------------------------------------------------------------------------
# An exact reference for "where does a motion first leave a feasible set" (test oracle).


def first_exit(breaks: Sequence[float], feasible) -> float | None:
    """The first u in [0, 1] where ``feasible(u)`` stops holding, given every u where it can
    change (the roots of the boundaries): infeasible at 0, or the start of the first interval
    between breaks whose midpoint is infeasible; None if it holds all the way."""
    if not feasible(0.0):
        return 0.0
    cuts = sorted({0.0, 1.0, *(u for u in breaks if 0.0 < u < 1.0)})
    for a, b in zip(cuts, cuts[1:]):
        if not feasible((a + b) / 2):
            return a
    return None


def real_roots(a: float, b: float, c: float) -> list[float]:
    """The real roots of a u^2 + b u + c (any degree down to a constant). A tangent (a double
    root, as where a segment runs at exactly full reach) has a discriminant that is 0 in exact
    arithmetic but may come out a few ulps below it: within rounding of its terms it counts as
    0, so the tangent root is kept (a break too many only splits an interval of constant
    feasibility, one too few can hide an exit)."""
    if a == 0.0:
        return [-c / b] if b != 0.0 else []
    disc = b * b - 4 * a * c
    if disc < 0:
        if disc < -1e-9 * (b * b + abs(4 * a * c)):
            return []
        disc = 0.0
    r = math.sqrt(disc)
    return [(-b - r) / (2 * a), (-b + r) / (2 * a)]


def arm_holds(arm, choice, x: float, y: float, tol: float = 1e-9) -> bool:
    """Inverse kinematics written out: reach, theta on the branch (lifted by its turns) and s
    within their limits at (x, y)."""
    (ox, oy), (dx, dy), length = arm.rail_origin, arm.rail_dir, arm.length
    along = (x - ox) * dx + (y - oy) * dy
    across = -(x - ox) * dy + (y - oy) * dx
    if abs(across) > length + tol:
        return False
    a = math.asin(max(-1.0, min(1.0, across / length)))
    theta = (a if choice.branch == 1 else math.pi - a) + 2 * math.pi * choice.turns
    s = along - choice.branch * math.sqrt(max(length * length - across * across, 0.0))
    (lo, hi), (s_lo, s_hi) = arm.theta_limits_rad, arm.s_limits
    return lo - tol <= theta <= hi + tol and s_lo - tol <= s <= s_hi + tol


def segment_exit_reference(arm, p0: Point, p1: Point, choice) -> float | None:
    """Where the straight motion p0 -> p1 first leaves what the arm can hold on ``choice``:
    across(u) is linear, so reach and theta limits are crossed where it equals +-l or
    l sin(limit); s = S where (along(u) - S)^2 + across(u)^2 = l^2."""
    (ox, oy), (dx, dy), length = arm.rail_origin, arm.rail_dir, arm.length

    def frame(p: Point) -> tuple[float, float]:
        return (p[0] - ox) * dx + (p[1] - oy) * dy, -(p[0] - ox) * dy + (p[1] - oy) * dx
    (al0, ac0), (al1, ac1) = frame(p0), frame(p1)
    alpha, beta = al1 - al0, ac1 - ac0
    breaks: list[float] = []
    if beta != 0.0:
        for target in (-length, length, *(length * math.sin(t) for t in arm.theta_limits_rad)):
            breaks.append((target - ac0) / beta)
    for bound in arm.s_limits:
        c0 = al0 - bound
        breaks += real_roots(alpha * alpha + beta * beta, 2 * (alpha * c0 + beta * ac0),
                             c0 * c0 + ac0 * ac0 - length * length)

    def feasible(u: float) -> bool:
        return arm_holds(arm, choice, p0[0] + u * (p1[0] - p0[0]), p0[1] + u * (p1[1] - p0[1]))
    return first_exit(breaks, feasible)
