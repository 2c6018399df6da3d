"""Exact geometry of straight-line motions: quadratics in time, swept segments, first contact.

Between two plan steps every end-effector moves in a straight line, all at the same time,
parametrised by ``u`` in [0, 1]. Everything the checker asks about such a motion reduces to
low-degree polynomials in ``u``, which this module solves in closed form instead of sampling:

* the payload's squared length ``|P2(u) - P1(u)|^2`` is a quadratic in ``u``;
* a fixed point ``V`` lies on the moving segment ``[P1(u), P2(u)]`` exactly when the
  quadratic ``cross(P2(u) - P1(u), V - P1(u))`` vanishes and the quadratic
  ``(V - P1(u)) . (V - P2(u))`` is not positive.

Why the swept region is not a polygon: the segment ``[P1(u), P2(u)]`` traces the image of the
unit square under a bilinear map (a ruled surface). When that map folds, the region's outline
contains an arc of the parabola enveloped by the moving line (for ``P1(u) = (u, 0)``,
``P2(u) = (0, 1 - u)`` the region is bounded by the axes and ``sqrt(x) + sqrt(y) = 1``), so
neither the quadrilateral ``A1 B1 B2 A2`` nor the two triangles ``A1 B1 B2``, ``A1 A2 B2`` are
the region in general. The obstacle test therefore does not build the region. It uses the
contact argument of continuous collision detection: if the moving segment meets a closed
polygon at some time, then at the *first* such time either the segment already meets it at
``u = 0``, or one of the moving ends touches the polygon (the end's straight path meets the
polygon), or a vertex of the polygon lies on the moving segment. The first two are segment
versus polygon tests done by shapely; the last is the pair of quadratics above. The result is
exact up to floating-point rounding, and the tolerance (`EPS`, relative to the scene's scale)
always errs on the side of reporting a contact.

>>> first_sweep_contact((0, 0), (0, 5), (1, 0), (1, 5), _square(0.4, 2.0, 0.6, 2.2)).u
0.4
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, Point, Polygon

__all__ = [
    "EPS",
    "Point2",
    "Quadratic",
    "Contact",
    "quadratic_roots",
    "first_failing_interval",
    "first_failing_time",
    "payload_length_sq",
    "first_exit_from_band",
    "first_path_contact",
    "first_vertex_sweep",
    "first_sweep_contact",
    "segment_geometry",
    "lerp",
]

EPS = 1e-9
"""Relative tolerance of every geometric decision (scaled by the size of the coordinates)."""

Point2 = tuple[float, float]


def lerp(a: Point2, b: Point2, u: float) -> Point2:
    """The point at parameter ``u`` on the straight motion from ``a`` to ``b``."""
    return (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]))


def _scale(*points: Sequence[float]) -> float:
    """A length scale for tolerances: the largest coordinate magnitude, at least 1."""
    return max([1.0] + [abs(float(c)) for p in points for c in p])


@dataclass(frozen=True, slots=True)
class Quadratic:
    """``a*u**2 + b*u + c`` as a function of the motion parameter ``u``."""

    a: float
    b: float
    c: float

    def __call__(self, u: float) -> float:
        return (self.a * u + self.b) * u + self.c

    def shifted(self, k: float) -> Quadratic:
        """The quadratic minus the constant ``k`` (for solving ``q(u) = k``)."""
        return Quadratic(self.a, self.b, self.c - k)

    def extremes_on_unit(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """``((u_min, q_min), (u_max, q_max))`` over [0, 1], exactly (ends and the vertex)."""
        candidates = [0.0, 1.0]
        if self.a != 0.0:
            vertex = -self.b / (2.0 * self.a)
            if 0.0 < vertex < 1.0:
                candidates.append(vertex)
        values = [(self(u), u) for u in candidates]
        low = min(values)
        high = max(values)
        return (low[1], low[0]), (high[1], high[0])


def quadratic_roots(q: Quadratic, tol: float) -> list[float] | None:
    """Real roots of ``q`` in [0, 1], sorted; ``None`` when ``q`` vanishes identically.

    ``tol`` is the size below which a coefficient counts as zero; a discriminant that is
    negative by less than rounding noise is taken as a double root, so a tangential touch is
    never lost.
    """
    a, b, c = q.a, q.b, q.c
    if abs(a) <= tol and abs(b) <= tol:
        return None if abs(c) <= tol else []
    roots: list[float]
    if abs(a) <= tol:
        roots = [-c / b]
    else:
        disc = b * b - 4.0 * a * c
        noise = 8.0 * EPS * (b * b + abs(4.0 * a * c))
        if disc < -noise:
            roots = []
        elif disc <= noise:
            roots = [-b / (2.0 * a)]
        else:
            sq = math.sqrt(disc)
            qq = -0.5 * (b + math.copysign(sq, b))      # |qq| >= sq / 2 > 0: never zero
            roots = [qq / a, c / qq]
    slack = 1e-12
    return sorted(min(1.0, max(0.0, r)) for r in roots if -slack <= r <= 1.0 + slack)


def first_failing_interval(
    breakpoints: Sequence[float], fails: Callable[[float], bool]
) -> tuple[float, float] | None:
    """``(start, probe)`` of the first interval of [0, 1] where ``fails`` holds, or ``None``.

    ``fails`` must be constant on each open interval between consecutive breakpoints (which
    is the case when the breakpoints include every root of the polynomials it compares), and
    the set where it holds must be open in [0, 1] (a strict inequality of continuous
    functions). Each interval is then classified exactly by its midpoint ``probe``; the failure
    starts at the interval's left end ``start``.
    """
    points = sorted({0.0, 1.0, *(min(1.0, max(0.0, b)) for b in breakpoints)})
    for left, right in zip(points, points[1:]):
        if fails(0.5 * (left + right)):     # a sorted set: right > left
            return left, 0.5 * (left + right)
    return None


def first_failing_time(breakpoints: Sequence[float], fails: Callable[[float], bool]) -> float | None:
    """The first ``u`` in [0, 1] from which ``fails`` holds, or ``None`` if it never does.

    Same contract as `first_failing_interval`.
    """
    found = first_failing_interval(breakpoints, fails)
    return None if found is None else found[0]


def payload_length_sq(a1: Point2, a2: Point2, b1: Point2, b2: Point2) -> Quadratic:
    """Squared distance ``|P2(u) - P1(u)|^2`` while P1 moves a1->b1 and P2 moves a2->b2."""
    d0 = (a2[0] - a1[0], a2[1] - a1[1])
    dd = ((b2[0] - a2[0]) - (b1[0] - a1[0]), (b2[1] - a2[1]) - (b1[1] - a1[1]))
    return Quadratic(
        dd[0] * dd[0] + dd[1] * dd[1],
        2.0 * (d0[0] * dd[0] + d0[1] * dd[1]),
        d0[0] * d0[0] + d0[1] * d0[1],
    )


def first_exit_from_band(q: Quadratic, low: float, high: float) -> float | None:
    """First ``u`` in [0, 1] where ``q(u)`` leaves the closed band [low, high], or ``None``.

    Touching a bound is allowed; rounding noise (relative `EPS`) counts as inside.
    """
    scale = max(1.0, abs(low), abs(high), abs(q.a), abs(q.b), abs(q.c))
    tol = EPS * scale
    breaks: list[float] = []
    for bound in (low, high):
        roots = quadratic_roots(q.shifted(bound), tol)
        if roots:
            breaks.extend(roots)
    return first_failing_time(breaks, lambda u: not (low - tol <= q(u) <= high + tol))


@dataclass(frozen=True, slots=True)
class Contact:
    """The first contact of a motion with an obstacle: time ``u`` in [0, 1] and the point."""

    u: float
    point: Point2


def segment_geometry(p: Point2, q: Point2) -> LineString | Point:
    """A shapely segment, or a point when both ends coincide (a robot that does not move)."""
    if p == q:
        return Point(p)
    return LineString([p, q])


def _first_along(p: Point2, q: Point2, hit: shapely.Geometry) -> Point2:
    """The point of ``hit`` (a part of the segment p-q) that comes first from ``p``."""
    coords = shapely.get_coordinates(hit)
    dx, dy = q[0] - p[0], q[1] - p[1]
    norm = dx * dx + dy * dy
    if norm == 0.0:
        return p
    ts = ((coords[:, 0] - p[0]) * dx + (coords[:, 1] - p[1]) * dy) / norm
    k = int(ts.argmin())
    return (float(coords[k, 0]), float(coords[k, 1]))


def first_path_contact(p: Point2, q: Point2, polygon: Polygon) -> Contact | None:
    """First contact of a point moving straight from ``p`` to ``q`` with a closed polygon."""
    path = segment_geometry(p, q)
    if not shapely.intersects(path, polygon):
        return None
    hit = shapely.intersection(path, polygon)
    if hit.is_empty:  # touching within shapely's own tolerance only
        where = shapely.get_coordinates(shapely.shortest_line(path, polygon))[0]
        point = (float(where[0]), float(where[1]))
    else:
        point = _first_along(p, q, hit)
    dx, dy = q[0] - p[0], q[1] - p[1]
    norm = dx * dx + dy * dy
    u = 0.0 if norm == 0.0 else ((point[0] - p[0]) * dx + (point[1] - p[1]) * dy) / norm
    return Contact(min(1.0, max(0.0, u)), point)


def first_vertex_sweep(a1: Point2, a2: Point2, b1: Point2, b2: Point2, v: Point2) -> float | None:
    """First ``u`` at which the fixed point ``v`` lies on the moving segment, or ``None``.

    The segment at time ``u`` is ``[P1(u), P2(u)]`` with ``P1`` moving a1->b1 and ``P2``
    moving a2->b2. ``v`` is on it iff ``c(u) = cross(P2 - P1, v - P1) = 0`` (on the line) and
    ``d(u) = (v - P1) . (v - P2) <= 0`` (between the ends); both are quadratics in ``u``.
    """
    e1 = (b1[0] - a1[0], b1[1] - a1[1])
    e2 = (b2[0] - a2[0], b2[1] - a2[1])
    d0 = (a2[0] - a1[0], a2[1] - a1[1])
    dd = (e2[0] - e1[0], e2[1] - e1[1])
    w0 = (v[0] - a1[0], v[1] - a1[1])
    z0 = (v[0] - a2[0], v[1] - a2[1])

    def cross(p: Point2, q: Point2) -> float:
        return p[0] * q[1] - p[1] * q[0]

    def dot(p: Point2, q: Point2) -> float:
        return p[0] * q[0] + p[1] * q[1]

    scale = _scale(a1, a2, b1, b2, v)
    near = EPS * scale
    if math.hypot(*d0) <= near and math.hypot(*dd) <= near:
        # a segment of length 0 throughout is a point on a straight path: v is on the path or
        # not (the quadratics below vanish or square the distance, and lose half the digits)
        run = math.hypot(*e1)
        if run <= near:
            return 0.0 if math.hypot(*w0) <= near else None
        if abs(cross(e1, w0)) / run > near:
            return None
        u = dot(w0, e1) / (run * run)
        return min(max(u, 0.0), 1.0) if -near / run <= u <= 1.0 + near / run else None
    c = Quadratic(-cross(dd, e1), cross(dd, w0) - cross(d0, e1), cross(d0, w0))
    d = Quadratic(dot(e1, e2), -(dot(w0, e2) + dot(e1, z0)), dot(w0, z0))
    tol = EPS * scale * scale

    def between(u: float) -> bool:
        # v on the line a distance t beyond an end of a segment of length L has d = t*(t+L):
        # the bound keeps t within EPS*scale whatever L is (a fixed EPS*scale**2 would let a
        # segment of length 0 reach sqrt(EPS)*scale, 3e-5 grid units, before it gets there)
        length = math.hypot(d0[0] + u * dd[0], d0[1] + u * dd[1])
        return d(u) <= EPS * scale * (EPS * scale + length)

    roots = quadratic_roots(c, tol)
    if roots is None:
        # v is on the moving line at every time: it is swept iff it is ever between the ends
        if between(0.0):
            return 0.0
        # d(0) > 0, so the first time v is between the ends is d's first root in [0, 1]
        d_roots = quadratic_roots(d, tol)
        return d_roots[0] if d_roots else None
    for u in roots:
        if between(u):
            return u
    return None


def first_sweep_contact(a1: Point2, a2: Point2, b1: Point2, b2: Point2, polygon: Polygon) -> Contact | None:
    """First contact between the moving segment and a closed polygon (interior or boundary).

    The segment starts as ``[a1, a2]`` and ends as ``[b1, b2]``; both ends move in straight
    lines at once. Returns the earliest time and a contact point, or ``None`` when the swept
    region misses the polygon. Exact by the first-contact argument in the module docstring.
    """
    start = segment_geometry(a1, a2)
    if shapely.intersects(start, polygon):
        hit = shapely.intersection(start, polygon)
        point = _first_along(a1, a2, hit) if not hit.is_empty else a1
        return Contact(0.0, point)
    best: Contact | None = None
    for p, q in ((a1, b1), (a2, b2)):
        contact = first_path_contact(p, q, polygon)
        if contact is not None and (best is None or contact.u < best.u):
            best = contact
    ring = shapely.get_coordinates(polygon.exterior)[:-1]
    for vx, vy in ring:
        vertex = (float(vx), float(vy))
        u = first_vertex_sweep(a1, a2, b1, b2, vertex)
        if u is not None and (best is None or u < best.u):
            best = Contact(u, vertex)
    return best


def _square(x0: float, y0: float, x1: float, y1: float) -> Polygon:
    """An axis-aligned rectangle (used in examples)."""
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
