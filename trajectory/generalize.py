"""Grow the positions of one violation into a box of grid positions that all fail.

A violation of the continuous check depends on a few positions (`trajectory.cause_of`): a
robot's two points, or the payload's four end points, over one motion. A planner that
forbids exactly those positions learns one motion at a time; the same obstacle is met again
one cell to the left, or with the other end a cell lower. This module widens each coordinate
of the cause into an interval of grid values, one value at a time, as long as *every*
combination in the box still fails, so that one nogood forbids a whole family of motions.

Soundness rests on the test of "fails", which must never say yes when the checker says no:

* the payload (both ends over one motion, or one state): its squared length leaves the band
  by more than rounding, or its swept region meets an obstacle shrunk by `MARGIN` (the
  first-contact argument of `trajectory.geometry`, vectorised with numpy and shapely). A
  contact with the shrunk obstacle is a contact, by at least `MARGIN`, with the real one,
  which the checker (whose tolerance errs towards contact) reports;
* a robot (its two points, or one): the checker's own exact tests, one by one, on a smaller
  budget.

Growing stops when a value fails the test or when the budget of tested combinations is spent.

>>> from trajectory.scene import parse_scene, EXAMPLE_SCENE
>>> from trajectory.states import StepState
>>> scene = parse_scene(EXAMPLE_SCENE, "example.toml")
>>> at = lambda p1, p2: StepState({"r1": p1, "r2": p2}, {"pl1": p1, "pl2": p2},
...                               {"pl1": "r1", "pl2": "r2"})
>>> plan = [at((1, 1), (1, 4)), at((4, 1), (4, 4))]
>>> from trajectory.checker import first_violation, cause_of
>>> box = widen(scene, plan, cause_of(scene, plan, first_violation(scene, plan)))
>>> box[(0, "r1", 0)][0] <= 1 and box[(1, "r1", 0)][1] >= 4
True
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import shapely

from .checker import Cause, cause_of  # noqa: F401  (cause_of: the doctest)
from .geometry import EPS
from .kinematics import choices_at, surviving_choices
from .scene import Scene
from .states import StepState

__all__ = ["Box", "widen", "payload_motions_fail", "MARGIN", "PAYLOAD_BUDGET", "ROBOT_BUDGET"]

Box = dict[tuple[int, str, int], tuple[int, int]]
"""``(step offset, body, axis 0 = x / 1 = y) -> (low, high)``: inclusive grid intervals."""

MARGIN = 1e-6
"""How far inside an obstacle (grid units) a contact must reach to count when widening."""

PAYLOAD_BUDGET = 10000
"""Payload motions tested per widened violation (vectorised: about a millisecond per 1,000)."""

ROBOT_BUDGET = 200
"""Robot motions tested per widened violation (the checker's exact tests, one by one)."""


def widen(scene: Scene, states: Sequence[StepState], cause: Cause, budget: int | None = None) -> Box:
    """The cause's positions as a box of grid intervals that all fail (at least the exact
    positions themselves). Causes spanning more than one motion, or naming who holds what,
    are not widened."""
    dims: list[tuple[int, str, int]] = []
    start: list[int] = []
    for k in range(cause.first, cause.last + 1):
        for body in cause.bodies:
            point = states[k].robots.get(body) or states[k].payload[body]
            for axis in (0, 1):
                dims.append((k - cause.first, body, axis))
                start.append(int(round(point[axis])))
    exact = {d: (v, v) for d, v in zip(dims, start)}
    if cause.holds or cause.span > 1:
        return exact
    grid = scene.grid
    bounds = [(grid.x_min, grid.x_max) if axis == 0 else (grid.y_min, grid.y_max) for _, _, axis in dims]
    if set(cause.bodies) == set(scene.end_names):
        order = [scene.end_names.index(b) for b in cause.bodies]
        fails = _payload_test(scene, cause.span, order)
        budget = PAYLOAD_BUDGET if budget is None else budget
    elif len(cause.bodies) == 1 and cause.bodies[0] in scene.robot_names:
        fails = _robot_test(scene, cause.bodies[0], cause.span)
        budget = ROBOT_BUDGET if budget is None else budget
    else:
        return exact
    lo, hi = _grow(fails, start, bounds, budget)
    return {d: (a, b) for d, a, b in zip(dims, lo, hi)}


def _grow(fails: Callable[[np.ndarray], np.ndarray], start: list[int], bounds: list[tuple[int, int]],
          budget: int) -> tuple[list[int], list[int]]:
    """Widen one value at a time, round robin over the coordinates and both directions."""
    lo, hi = list(start), list(start)
    spent = 0
    grown = True
    while grown:
        grown = False
        for d in range(len(start)):
            for value in (lo[d] - 1, hi[d] + 1):
                if not bounds[d][0] <= value <= bounds[d][1]:
                    continue
                ranges = [range(lo[e], hi[e] + 1) if e != d else range(value, value + 1)
                          for e in range(len(start))]
                size = math.prod(len(r) for r in ranges)
                if spent + size > budget:
                    continue
                spent += size
                slab = np.stack(np.meshgrid(*(np.arange(r.start, r.stop, dtype=float) for r in ranges),
                                            indexing="ij"), axis=-1).reshape(-1, len(ranges))
                if bool(np.all(fails(slab))):
                    if value < lo[d]:
                        lo[d] = value
                    else:
                        hi[d] = value
                    grown = True
    return lo, hi


# ---------------------------------------------------------------------------- the payload


def _payload_test(scene: Scene, span: int, order: list[int]) -> Callable[[np.ndarray], np.ndarray]:
    """Rows ``x, y`` of each body (in the cause's order) at each step -> certainly fails."""
    shrunk = [p for o in scene.obstacles for p in _parts(o.polygon.buffer(-MARGIN, join_style="mitre"))]
    for p in shrunk:
        shapely.prepare(p)
    low, high = scene.payload.length_sq_band

    def fails(rows: np.ndarray) -> np.ndarray:
        ends = [rows[:, 2 * k:2 * k + 2] for k in range(2)]
        a1, a2 = ends[order.index(0)], ends[order.index(1)]
        if span == 0:
            b1, b2 = a1, a2
        else:
            later = [rows[:, 4 + 2 * k:4 + 2 * k + 2] for k in range(2)]
            b1, b2 = later[order.index(0)], later[order.index(1)]
        return payload_motions_fail(a1, a2, b1, b2, shrunk, low, high)
    return fails


def _parts(geom) -> list:
    if geom.is_empty:
        return []
    return list(getattr(geom, "geoms", [geom]))


def payload_motions_fail(a1: np.ndarray, a2: np.ndarray, b1: np.ndarray, b2: np.ndarray,
                         obstacles: Sequence, low: float, high: float) -> np.ndarray:
    """For each payload motion (ends a1 -> b1 and a2 -> b2, arrays of shape (n, 2)): does its
    squared length leave ``[low, high]`` or its swept region meet one of ``obstacles``?

    Only certain failures count: the band is widened by rounding noise, and the obstacles
    should be shrunk by the caller (the sweep test is exact up to rounding).
    """
    d0 = a2 - a1
    dd = (b2 - b1) - d0
    qa = (dd * dd).sum(axis=1)
    qb = 2.0 * (d0 * dd).sum(axis=1)
    qc = (d0 * d0).sum(axis=1)
    ends = [qc, qa + qb + qc]
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(qa > 0.0, -qb / (2.0 * qa), 0.0)
    inside = (vertex > 0.0) & (vertex < 1.0)
    at_vertex = np.where(inside, (qa * vertex + qb) * vertex + qc, qc)
    q_min = np.minimum(np.minimum(ends[0], ends[1]), at_vertex)
    q_max = np.maximum(ends[0], ends[1])
    noise = 8.0 * EPS * max(1.0, abs(low), abs(high))
    out = (q_min < low - noise) | (q_max > high + noise)
    todo = np.flatnonzero(~out)
    if len(todo) and obstacles:
        out[todo] = _sweeps_hit(a1[todo], a2[todo], b1[todo], b2[todo], obstacles)
    return out


def _sweeps_hit(a1, a2, b1, b2, obstacles) -> np.ndarray:
    """The first-contact test of `geometry.first_sweep_contact`, for many motions at once: the
    start segment or an end's path meets the polygon, or a vertex of it is swept."""
    hit = np.zeros(len(a1), dtype=bool)
    pts = np.stack([a1, a2, b1, b2])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    for poly in obstacles:
        x0, y0, x1, y1 = poly.bounds
        near = np.flatnonzero(~hit & (lo[:, 0] <= x1) & (hi[:, 0] >= x0) & (lo[:, 1] <= y1) & (hi[:, 1] >= y0))
        if not len(near):
            continue
        n1, n2, m1, m2 = a1[near], a2[near], b1[near], b2[near]
        lines = shapely.linestrings(np.concatenate([np.stack([n1, n2], axis=1), np.stack([n1, m1], axis=1),
                                                    np.stack([n2, m2], axis=1)]))
        touched = shapely.intersects(lines, poly).reshape(3, -1).any(axis=0)
        vertices = shapely.get_coordinates(poly.exterior)[:-1]
        rest = ~touched
        if rest.any():
            touched[rest] = _vertex_swept(n1[rest], n2[rest], m1[rest], m2[rest], vertices)
        hit[near] = touched
    return hit


def _cross(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]


def _vertex_swept(a1, a2, b1, b2, vertices) -> np.ndarray:
    """`geometry.first_vertex_sweep` for many motions (rows) and vertices (columns) at once:
    is some vertex ever on the moving segment?"""
    e1, e2 = (b1 - a1)[:, None, :], (b2 - a2)[:, None, :]
    d0 = (a2 - a1)[:, None, :]
    dd = e2 - e1
    w0, z0 = vertices[None, :, :] - a1[:, None, :], vertices[None, :, :] - a2[:, None, :]
    ca = -_cross(dd, e1)
    cb = _cross(dd, w0) - _cross(d0, e1)
    cc = _cross(d0, w0)
    da = (e1 * e2).sum(axis=2)
    db = -((w0 * e2).sum(axis=2) + (e1 * z0).sum(axis=2))
    dc = (w0 * z0).sum(axis=2)
    tiny = 1e-12
    ca, da = np.broadcast_to(ca, cc.shape), np.broadcast_to(da, cc.shape)
    hit = np.zeros(cc.shape, dtype=bool)
    quad = np.abs(ca) > tiny
    lin = ~quad & (np.abs(cb) > tiny)
    disc = cb * cb - 4.0 * ca * cc
    real = quad & (disc >= 0.0)
    sq = np.sqrt(np.where(real, disc, 0.0))
    qq = -0.5 * (cb + np.copysign(sq, cb))
    with np.errstate(divide="ignore", invalid="ignore"):
        roots = (np.where(real, qq / ca, np.nan), np.where(real & (qq != 0.0), cc / qq, np.nan),
                 np.where(lin, -cc / cb, np.nan))
    for u in roots:
        ok = (u >= 0.0) & (u <= 1.0)
        uu = np.where(ok, u, 0.0)
        hit |= ok & ((da * uu + db) * uu + dc <= 0.0)
    # the vertex on the moving line at every time: swept when it is ever between the ends
    flat = ~quad & ~lin & (np.abs(cc) <= tiny)
    if flat.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            vert = np.where(da > 0.0, -db / (2.0 * da), 0.0)
        inside = (vert > 0.0) & (vert < 1.0)
        d_min = np.minimum(np.minimum(dc, da + db + dc), np.where(inside, (da * vert + db) * vert + dc, dc))
        hit |= flat & (d_min <= 0.0)
    return np.asarray(hit.any(axis=1))


# ---------------------------------------------------------------------------- a robot


def _robot_test(scene: Scene, name: str, span: int) -> Callable[[np.ndarray], np.ndarray]:
    """Rows ``x, y`` at each step -> the checker's verdict on the robot alone (exact)."""
    arm = scene.robot(name).arm

    def hits(p, q) -> bool:
        from .geometry import first_path_contact
        return any(first_path_contact(p, q, scene.obstacles[k].polygon) is not None
                   for k in scene.workspace.candidates([p, q]))

    def one(row: np.ndarray) -> bool:
        p = (float(row[0]), float(row[1]))
        q = (float(row[2]), float(row[3])) if span else p
        choices = choices_at(arm, *p)
        if not choices or not choices_at(arm, *q):
            return True
        return hits(p, q) or not surviving_choices(arm, choices, p, q)[0]

    def fails(rows: np.ndarray) -> np.ndarray:
        out = np.zeros(len(rows), dtype=bool)
        for k, row in enumerate(rows):
            out[k] = one(row)
            if not out[k]:
                break       # one safe motion is enough to refuse the slab
        return out
    return fails
