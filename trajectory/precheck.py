"""Classify single-body motions between grid points up front: the eager pre-check.

A planner that learns from the continuous check (position nogoods) can also be told, before
its first plan, what one end-effector can never do on the grid:

* stand at a grid point no branch of its arm can hold within the joint limits, or inside an
  obstacle;
* move in a straight line between two grid points it can hold when that line meets an
  obstacle or, from every branch it could use at the start, leaves its reach or joint limits.

The points are few (one check per robot and grid point). The pairs are many (the square of
the grid's points per robot), so they are classified in a batch: the obstacle test reads the
scene's collision table (one vectorised shapely call for all pairs), the reach test samples
every segment with numpy, and every pair either flags is then confirmed by the checker's own
exact tests, one by one. A bad motion is reported only when the checker itself would report
it in any plan (:func:`trajectory.cause_of` gives the same positions); a pair the batch
misses is simply left to the planner's lazy loop.

The payload's length needs no positions at all: its squared length over a motion is a
quadratic in time whose coefficients depend only on the vector between the ends before and
after the motion (`geometry.payload_length_sq`). `failing_length_pairs` lists every pair of
integer end vectors, both within the length band, whose motion leaves the band on the way
(the paper's case of a payload rotated too fast): a short list (20 vectors and 332 pairs for
the payload scene), classified once by the checker's own exact test.

The paper's external ``collision/4`` is the same idea for obstacles at grid points.

>>> from trajectory.scene import parse_scene, EXAMPLE_SCENE
>>> scene = parse_scene(EXAMPLE_SCENE, "example.toml")
>>> bad = bad_single_body_motions(scene)
>>> sorted({len(b.points) for b in bad}), all(b.robot in scene.robot_names for b in bad)
([1, 2], True)
>>> ((0, 3), (3, 1)) in failing_length_pairs(scene)      # turned too fast: 6.2 < 8 half-way
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from .geometry import EPS, Point2, first_exit_from_band, first_path_contact, payload_length_sq
from .kinematics import Arm, _branch_angle, _reach_root, _turns_for, choices_at, surviving_choices
from .scene import Scene
from .violations import ViolationKind

__all__ = ["BadMotion", "bad_single_body_motions", "failing_length_pairs", "MAX_LENGTH_VECTORS"]

MAX_LENGTH_VECTORS = 400
"""Above this many end vectors within the band, `failing_length_pairs` gives up (returns
nothing): the pairs grow with its square, and the lazy loop learns what it meets."""

_SAMPLES = 17
"""Points per segment in the batch reach test (its misses are left to the lazy loop)."""


@dataclass(frozen=True, slots=True)
class BadMotion:
    """A robot can never be at ``points[0]`` (one point), or never move ``points[0] -> points[1]``."""

    robot: str
    points: tuple[Point2, ...]
    kind: ViolationKind


def bad_single_body_motions(scene: Scene, pairs: bool = True) -> list[BadMotion]:
    """Every grid point each robot cannot hold and, with ``pairs``, every straight move
    between two points it can hold that the continuous check rejects."""
    grid = scene.grid
    points = [(float(x), float(y)) for x, y in grid.points()]
    out: list[BadMotion] = []
    for robot in scene.robots:
        good: list[int] = []
        for k, p in enumerate(points):
            if not choices_at(robot.arm, *p):
                out.append(BadMotion(robot.name, (p,), ViolationKind.OUT_OF_REACH))
            elif _effector_hits(scene, p, p):
                out.append(BadMotion(robot.name, (p,), ViolationKind.EFFECTOR_COLLISION))
            else:
                good.append(k)
        if pairs and len(good) > 1:
            out.extend(_bad_pairs(scene, robot.name, robot.arm, points, good))
    return out


def _effector_hits(scene: Scene, p: Point2, q: Point2) -> bool:
    """The checker's effector test: does the straight path p -> q meet an obstacle?"""
    return any(first_path_contact(p, q, scene.obstacles[k].polygon) is not None
               for k in scene.workspace.candidates([p, q]))


def _bad_pairs(scene: Scene, name: str, arm: Arm, points: list[Point2], good: list[int]) -> list[BadMotion]:
    idx = np.asarray(good)
    i, j = np.meshgrid(idx, idx, indexing="ij")
    keep = i != j
    i, j = i[keep], j[keep]
    pts = np.asarray(points)
    flagged = np.flatnonzero(_table_hits(scene, points, i, j))
    # the checker's own predicate (GEOS intersects, obstacle by obstacle), on the flagged pairs only
    lines = shapely.linestrings(np.stack([pts[i[flagged]], pts[j[flagged]]], axis=1))
    confirmed = np.zeros(len(flagged), dtype=bool)
    for obstacle in scene.obstacles:
        confirmed |= shapely.intersects(lines, obstacle.polygon)
    hits = np.zeros(len(i), dtype=bool)
    hits[flagged[confirmed]] = True
    leaves = ~hits & ~_followable(arm, pts[i], pts[j])
    out = [BadMotion(name, (points[a], points[b]), ViolationKind.EFFECTOR_COLLISION)
           for a, b in zip(i[hits].tolist(), j[hits].tolist())]
    for a, b in zip(i[leaves].tolist(), j[leaves].tolist()):
        p, q = points[a], points[b]
        if not surviving_choices(arm, choices_at(arm, *p), p, q)[0]:
            out.append(BadMotion(name, (p, q), ViolationKind.OUT_OF_REACH))
    return out


def _table_hits(scene: Scene, points: list[Point2], i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Which pairs the scene's collision table says meet an obstacle (all, if there is none)."""
    ws = scene.workspace
    table = ws._table if ws._table is not None else ws._build_table()
    if table is None:
        return np.array([scene.collision(*points[a], *points[b]) for a, b in zip(i.tolist(), j.tolist())],
                        dtype=bool)
    grid = scene.grid
    ny = grid.y_max - grid.y_min + 1
    pts = np.asarray(points)
    flat = ((pts[:, 0] - grid.x_min) * ny + (pts[:, 1] - grid.y_min)).astype(int)
    return table[flat[i], flat[j]]


def _followable(arm: Arm, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per segment p -> q: can some branch feasible at p follow it (checked at samples)?"""
    u = np.linspace(0.0, 1.0, _SAMPLES)
    xs = p[:, 0:1] + (q[:, 0:1] - p[:, 0:1]) * u
    ys = p[:, 1:2] + (q[:, 1:2] - p[:, 1:2]) * u
    along, across = arm.rail_frame(xs, ys)
    tol = EPS * arm.scale
    within = np.abs(across) <= arm.length + tol
    lo_s, hi_s = arm.s_limits
    lo_t, hi_t = arm.theta_limits_rad
    starts, where = np.unique(p, axis=0, return_inverse=True)
    _, start_across = arm.rail_frame(starts[:, 0], starts[:, 1])
    ok = np.zeros(len(p), dtype=bool)
    for branch in (1, -1):
        base = _branch_angle(arm, branch, across)
        start_angle = _branch_angle(arm, branch, start_across)
        turns = np.array([_turns_or_nan(arm, branch, float(a)) for a in start_angle])[np.ravel(where)]
        theta = base + 2.0 * math.pi * turns[:, None]
        s = along - branch * _reach_root(arm, across)
        feasible = (within & (theta >= lo_t - EPS) & (theta <= hi_t + EPS)
                    & (s >= lo_s - tol) & (s <= hi_s + tol))
        ok |= feasible.all(axis=1)
    return ok


def _turns_or_nan(arm: Arm, branch: int, angle: float) -> float:
    turns = _turns_for(arm, branch, angle)
    return math.nan if turns is None else float(turns)


def failing_length_pairs(scene: Scene) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Every pair ``(d0, d1)`` of integer vectors ``end2 - end1`` that fit the grid and the
    length band, such that carrying the payload from ``d0`` to ``d1`` in one motion takes its
    squared length out of the band on the way (exactly: the checker's test)."""
    grid = scene.grid
    low, high = scene.payload.length_sq_band
    w, h = grid.x_max - grid.x_min, grid.y_max - grid.y_min
    r = int(math.isqrt(int(math.floor(high))) + 1)
    vectors = [(dx, dy) for dx in range(-min(w, r), min(w, r) + 1) for dy in range(-min(h, r), min(h, r) + 1)
               if low <= dx * dx + dy * dy <= high]
    if len(vectors) > MAX_LENGTH_VECTORS:
        return []
    origin = (0.0, 0.0)
    out = []
    for d0 in vectors:
        for d1 in vectors:
            q = payload_length_sq(origin, (float(d0[0]), float(d0[1])), origin, (float(d1[0]), float(d1[1])))
            if first_exit_from_band(q, low, high) is not None:
                out.append((d0, d1))
    return out
