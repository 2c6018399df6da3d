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


def _grow(every_fails: Callable[[np.ndarray], bool], start: list[int], bounds: list[tuple[int, int]],
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
                low = lo.copy()
                low[d] = value
                shape = [h - a + 1 if e != d else 1 for e, (a, h) in enumerate(zip(lo, hi))]
                size = math.prod(shape)
                if spent + size > budget:
                    continue
                spent += size
                # every combination, the last coordinate fastest (as itertools.product)
                slab = (np.indices(shape).reshape(len(shape), -1).T + np.array(low)).astype(float)
                if every_fails(slab):
                    if value < lo[d]:
                        lo[d] = value
                    else:
                        hi[d] = value
                    grown = True
    return lo, hi


# ---------------------------------------------------------------------------- the payload


class _Shrunk:
    """An obstacle shrunk by `MARGIN` (one part of it), prepared, with its bounds and vertices."""

    __slots__ = ("polygon", "bounds", "vx", "vy")

    def __init__(self, polygon) -> None:
        shapely.prepare(polygon)
        self.polygon = polygon
        self.bounds = polygon.bounds
        ring = shapely.get_coordinates(polygon.exterior)[:-1]
        self.vx, self.vy = ring[:, 0].copy(), ring[:, 1].copy()


def _payload_test(scene: Scene, span: int, order: list[int]) -> Callable[[np.ndarray], bool]:
    """Rows ``x, y`` of each body (in the cause's order) at each step -> does every one of
    them certainly fail?"""
    shrunk = [_Shrunk(p) for p in scene.workspace.shrunk(MARGIN)]
    low, high = scene.payload.length_sq_band
    c1, c2 = 2 * order.index(0), 2 * order.index(1)
    d1, d2 = (c1 + 4, c2 + 4) if span else (c1, c2)

    def every_fails(rows: np.ndarray) -> bool:
        cols = rows.T
        found = _motions_fail(cols[c1], cols[c1 + 1], cols[c2], cols[c2 + 1],
                              cols[d1], cols[d1 + 1], cols[d2], cols[d2 + 1], shrunk, low, high, every=True)
        return found is not None and bool(found.all())
    return every_fails


def payload_motions_fail(a1: np.ndarray, a2: np.ndarray, b1: np.ndarray, b2: np.ndarray,
                         obstacles: Sequence, low: float, high: float) -> np.ndarray:
    """For each payload motion (ends a1 -> b1 and a2 -> b2, arrays of shape (n, 2)): does its
    squared length leave ``[low, high]`` or its swept region meet one of ``obstacles``?

    Only certain failures count: the band is widened by rounding noise, and the obstacles
    should be shrunk by the caller (the sweep test is exact up to rounding).
    """
    found = _motions_fail(a1[:, 0], a1[:, 1], a2[:, 0], a2[:, 1], b1[:, 0], b1[:, 1], b2[:, 0], b2[:, 1],
                          [_Shrunk(p) for p in obstacles], low, high)
    assert found is not None
    return found


def _motions_fail(a1x, a1y, a2x, a2y, b1x, b1y, b2x, b2y, obstacles: Sequence[_Shrunk],
                  low: float, high: float, every: bool = False) -> np.ndarray | None:
    """`payload_motions_fail` on coordinate columns (one array per coordinate: numpy's
    reductions over a short last axis cost more than the arithmetic). With ``every``, ``None``
    as soon as some motion is certainly clean (it touches no obstacle's bounding box and keeps
    its length), when only "do they all fail?" is asked."""
    d0x, d0y = a2x - a1x, a2y - a1y
    ddx, ddy = (b2x - b1x) - d0x, (b2y - b1y) - d0y
    qa = ddx * ddx + ddy * ddy
    qb = 2.0 * (d0x * ddx + d0y * ddy)
    qc = d0x * d0x + d0y * d0y
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(qa > 0.0, -qb / (2.0 * qa), 0.0)
    inside = (vertex > 0.0) & (vertex < 1.0)
    at_vertex = np.where(inside, (qa * vertex + qb) * vertex + qc, qc)
    end = qa + qb + qc
    q_min = np.minimum(np.minimum(qc, end), at_vertex)
    q_max = np.maximum(qc, end)
    noise = 8.0 * EPS * max(1.0, abs(low), abs(high))
    out = (q_min < low - noise) | (q_max > high + noise)
    todo = np.flatnonzero(~out)
    if len(todo) and (obstacles or every):
        hit = _sweeps_hit(a1x[todo], a1y[todo], a2x[todo], a2y[todo], b1x[todo], b1y[todo],
                          b2x[todo], b2y[todo], obstacles, every)
        if hit is None:
            return None
        out[todo] = hit
    return out


def _sweeps_hit(a1x, a1y, a2x, a2y, b1x, b1y, b2x, b2y, obstacles: Sequence[_Shrunk],
                every: bool = False) -> np.ndarray | None:
    """The first-contact test of `geometry.first_sweep_contact`, for many motions at once: the
    start segment or an end's path meets a polygon (shapely, polygon by polygon), or a vertex
    of it is swept (all polygons' vertices at once). ``every``: ``None`` as soon as a motion is
    near no polygon at all."""
    n = len(a1x)
    lo_x = np.minimum(np.minimum(a1x, a2x), np.minimum(b1x, b2x))
    hi_x = np.maximum(np.maximum(a1x, a2x), np.maximum(b1x, b2x))
    lo_y = np.minimum(np.minimum(a1y, a2y), np.minimum(b1y, b2y))
    hi_y = np.maximum(np.maximum(a1y, a2y), np.maximum(b1y, b2y))
    near = [(lo_x <= x1) & (hi_x >= x0) & (lo_y <= y1) & (hi_y >= y0)
            for x0, y0, x1, y1 in (ob.bounds for ob in obstacles)]
    if every and (not near or not np.logical_or.reduce(near).all()):
        return None
    hit = np.zeros(n, dtype=bool)
    vertex_test = []        # (obstacle, rows near it that its lines miss)
    for ob, close in zip(obstacles, near):
        rows = np.flatnonzero(close & ~hit)
        if not len(rows):
            continue
        k = len(rows)
        n1x, n1y, n2x, n2y = a1x[rows], a1y[rows], a2x[rows], a2y[rows]
        coords = np.empty((3 * k, 2, 2))
        for row, (px, py, qx, qy) in enumerate(((n1x, n1y, n2x, n2y), (n1x, n1y, b1x[rows], b1y[rows]),
                                                (n2x, n2y, b2x[rows], b2y[rows]))):
            block = coords[row * k:(row + 1) * k]
            block[:, 0, 0], block[:, 0, 1], block[:, 1, 0], block[:, 1, 1] = px, py, qx, qy
        touched = shapely.intersects(shapely.linestrings(coords), ob.polygon).reshape(3, -1).any(axis=0)
        hit[rows[touched]] = True
        vertex_test.append((ob, rows[~touched]))
    # one vertex test for what is left: rows x every vertex of the polygons each row is near
    ask = np.zeros(n, dtype=bool)
    for _, rows in vertex_test:
        ask[rows] = True
    ask &= ~hit
    rows = np.flatnonzero(ask)
    if len(rows):
        where = np.full(n, -1)
        where[rows] = np.arange(len(rows))
        wanted = np.zeros((len(rows), sum(len(ob.vx) for ob, _ in vertex_test)), dtype=bool)
        col = 0
        for ob, mine in vertex_test:
            at = where[mine]
            at = at[at >= 0]
            wanted[at, col:col + len(ob.vx)] = True
            col += len(ob.vx)
        vx = np.concatenate([ob.vx for ob, _ in vertex_test])
        vy = np.concatenate([ob.vy for ob, _ in vertex_test])
        swept = _vertex_swept(a1x[rows], a1y[rows], a2x[rows], a2y[rows], b1x[rows], b1y[rows],
                              b2x[rows], b2y[rows], vx, vy)
        hit[rows] = (swept & wanted).any(axis=1)
    return hit


def _vertex_swept(a1x, a1y, a2x, a2y, b1x, b1y, b2x, b2y, vx, vy) -> np.ndarray:
    """`geometry.first_vertex_sweep` for many motions (rows) and vertices (columns) at once:
    is the vertex ever on the moving segment?"""
    col = np.newaxis
    e1x, e1y = (b1x - a1x)[:, col], (b1y - a1y)[:, col]
    e2x, e2y = (b2x - a2x)[:, col], (b2y - a2y)[:, col]
    d0x, d0y = (a2x - a1x)[:, col], (a2y - a1y)[:, col]
    ddx, ddy = e2x - e1x, e2y - e1y
    w0x, w0y = vx[col, :] - a1x[:, col], vy[col, :] - a1y[:, col]
    z0x, z0y = vx[col, :] - a2x[:, col], vy[col, :] - a2y[:, col]
    ca = -(ddx * e1y - ddy * e1x)
    cb = (ddx * w0y - ddy * w0x) - (d0x * e1y - d0y * e1x)
    cc = d0x * w0y - d0y * w0x
    da = e1x * e2x + e1y * e2y
    db = -((w0x * e2x + w0y * e2y) + (e1x * z0x + e1y * z0y))
    dc = w0x * z0x + w0y * z0y
    tiny = 1e-12
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
    return hit


# ---------------------------------------------------------------------------- a robot


def _robot_test(scene: Scene, name: str, span: int) -> Callable[[np.ndarray], bool]:
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

    def every_fails(rows: np.ndarray) -> bool:
        return all(one(row) for row in rows)     # one safe motion is enough to refuse the slab
    return every_fails
