"""Exact motion geometry: quadratics in time and the swept payload against polygons."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon, box
from traj_helpers import first_exit, real_roots

from trajectory.geometry import (
    Quadratic,
    first_exit_from_band,
    first_path_contact,
    first_sweep_contact,
    first_vertex_sweep,
    lerp,
    payload_length_sq,
    quadratic_roots,
)


def segment_at(a1, a2, b1, b2, u):
    p, q = lerp(a1, b1, u), lerp(a2, b2, u)
    return shapely.Point(p) if p == q else shapely.LineString([p, q])


class TestQuadratics:
    def test_roots(self) -> None:
        assert quadratic_roots(Quadratic(1, -1, 0.21), 1e-12) == pytest.approx([0.3, 0.7])
        assert quadratic_roots(Quadratic(0, 2, -1), 1e-12) == pytest.approx([0.5])
        assert quadratic_roots(Quadratic(1, 0, 1), 1e-12) == []
        assert quadratic_roots(Quadratic(0, 0, 0), 1e-12) is None
        assert quadratic_roots(Quadratic(0, 0, 3), 1e-12) == []
        assert quadratic_roots(Quadratic(1, 0, -4), 1e-12) == []  # roots +-2, outside [0, 1]

    def test_tangent_double_root_is_found_despite_rounding(self) -> None:
        # (u - 0.1)^2 written with rounded coefficients; the discriminant comes out ~ -1e-17
        q = Quadratic(1.0, -0.2, 0.010000000000000002)
        assert quadratic_roots(q, 1e-12) == pytest.approx([0.1])

    def test_extremes(self) -> None:
        (umin, qmin), (umax, qmax) = Quadratic(2, -2, 1).extremes_on_unit()
        assert (umin, qmin) == (0.5, 0.5) and qmax == 1.0
        (umin, qmin), (umax, qmax) = Quadratic(-1, 0, 0).extremes_on_unit()
        assert (umin, qmin, umax, qmax) == (1.0, -1.0, 0.0, 0.0)

    @given(*[st.tuples(st.integers(-10, 10), st.integers(-10, 10)) for _ in range(4)],
           st.floats(0, 1))
    def test_payload_length_is_the_squared_distance(self, a1, a2, b1, b2, u) -> None:
        p, q = lerp(a1, b1, u), lerp(a2, b2, u)
        direct = (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2
        assert payload_length_sq(a1, a2, b1, b2)(u) == pytest.approx(direct, abs=1e-9)

    def test_diagonal_move_shortens_only_mid_way(self) -> None:
        """pl1 stays, pl2 slides diagonally from (0,5) to (5,0): 25 at both ends, 12.5 mid-way."""
        q = payload_length_sq((0, 0), (0, 5), (0, 0), (5, 0))
        assert q(0) == 25 and q(1) == 25
        u = first_exit_from_band(q, 23, 27)
        assert u == pytest.approx((1 - math.sqrt(1 - 4 * 2 / 50)) / 2)  # 50u^2 - 50u + 2 = 0
        assert q(u) == pytest.approx(23)
        # the same motion with a wide enough band is fine
        assert first_exit_from_band(q, 12.5, 27) is None

    def test_touching_the_band_edge_is_allowed(self) -> None:
        q = Quadratic(4.0, -4.0, 24.0)  # minimum exactly 23 at u = 0.5
        assert first_exit_from_band(q, 23, 27) is None
        assert first_exit_from_band(q, 23.0000001, 27) == pytest.approx(0.5, abs=1e-3)

    def test_out_of_band_at_start(self) -> None:
        assert first_exit_from_band(Quadratic(0, 0, 30), 23, 27) == 0.0

    @settings(max_examples=300)
    @given(*[st.tuples(st.integers(-6, 6), st.integers(-6, 6)) for _ in range(4)],
           st.integers(1, 40))
    def test_band_exit_against_an_exact_reference(self, a1, a2, b1, b2, tol) -> None:
        """The reported u is the first time the squared length leaves [25 - tol, 25 + tol]:
        the reference solves the integer quadratic and classifies each interval exactly
        (rational arithmetic), so an early, late, missed or spurious exit fails."""
        q = payload_length_sq(a1, a2, b1, b2)
        low, high = 25 - tol, 25 + tol
        d0 = (a2[0] - a1[0], a2[1] - a1[1])
        dd = (b2[0] - b1[0] - d0[0], b2[1] - b1[1] - d0[1])
        qa, qb, qc = dd[0] ** 2 + dd[1] ** 2, 2 * (d0[0] * dd[0] + d0[1] * dd[1]), d0[0] ** 2 + d0[1] ** 2

        def inside(u: float) -> bool:
            x = Fraction(u)
            return low <= qa * x * x + qb * x + qc <= high
        expected = first_exit(real_roots(qa, qb, qc - low) + real_roots(qa, qb, qc - high), inside)
        u = first_exit_from_band(q, low, high)
        if expected is None:
            assert u is None
        else:
            assert u is not None and u == pytest.approx(expected, abs=1e-9)


class TestSweptPayload:
    def test_clips_a_corner_between_two_clean_grid_points(self) -> None:
        """Upright payload moves from x = 5 to x = 6; a post at x in [5.3, 5.7] is swept over."""
        post = box(5.3, 2.3, 5.7, 2.7)
        a1, a2, b1, b2 = (5, 0), (5, 5), (6, 0), (6, 5)
        for seg in (shapely.LineString([a1, a2]), shapely.LineString([b1, b2]),
                    shapely.LineString([a1, b1]), shapely.LineString([a2, b2])):
            assert not seg.intersects(post)  # every grid-point and end-path test passes
        contact = first_sweep_contact(a1, a2, b1, b2, post)
        assert contact is not None
        assert contact.u == pytest.approx(0.3)
        assert contact.point in ((5.3, 2.3), (5.3, 2.7))

    def test_rotation_clips_a_corner(self) -> None:
        """The stick turns from upright to slanted; a corner in the swept wedge is hit."""
        a1, a2, b1, b2 = (2, 0), (2, 5), (3, 1), (6, 5)
        corner = box(3.2, 3.3, 3.6, 3.7)   # between x = 2 and the final stick, under y = 5
        assert not shapely.LineString([b1, b2]).intersects(corner)
        contact = first_sweep_contact(a1, a2, b1, b2, corner)
        assert contact is not None and 0 < contact.u < 1
        assert segment_at(a1, a2, b1, b2, contact.u).distance(corner) < 1e-9

    def test_folded_sweep_is_not_the_quadrilateral(self) -> None:
        """P1 = (u, 0), P2 = (0, 1 - u) envelope the parabola sqrt(x) + sqrt(y) = 1.

        The quadrilateral/triangle hull of the four corners is the whole triangle; the swept
        region is only the part under the parabola. A corner at (0.3, 0.3) lies in the hull
        (sqrt(.3) * 2 = 1.095 > 1) but is never swept; one at (0.2, 0.2) is swept.
        """
        a1, a2, b1, b2 = (0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (0.0, 0.0)
        outside = Polygon([(0.3, 0.3), (1.0, 0.3), (1.0, 1.0), (0.3, 1.0)])
        inside = Polygon([(0.2, 0.2), (1.0, 0.2), (1.0, 1.0), (0.2, 1.0)])
        hull = shapely.MultiPoint([a1, a2, b1, b2]).convex_hull
        assert hull.intersects(outside)  # a polygon test would (wrongly) say "hit"
        assert first_sweep_contact(a1, a2, b1, b2, outside) is None
        contact = first_sweep_contact(a1, a2, b1, b2, inside)
        assert contact is not None and contact.point == (0.2, 0.2)
        # x/u + y/(1 - u) = 1 at (0.2, 0.2): u^2 - u + 0.2 = 0, first root (1 - sqrt(0.2)) / 2
        assert contact.u == pytest.approx((1 - math.sqrt(0.2)) / 2)

    def test_crossing_ends(self) -> None:
        """The ends cross over: every position passes through (2, 2), the sweep is a bow tie."""
        a1, a2, b1, b2 = (0, 0), (4, 4), (4, 0), (0, 4)
        assert first_sweep_contact(a1, a2, b1, b2, box(1.9, 1.9, 2.1, 2.1)) is not None
        assert first_vertex_sweep(a1, a2, b1, b2, (2.0, 2.0)) == 0.0
        assert first_vertex_sweep(a1, a2, b1, b2, (2.0, 0.5)) == pytest.approx(0.5)
        # (0.5, 2) is inside the four corners' hull but beside the bow tie's waist
        assert first_vertex_sweep(a1, a2, b1, b2, (0.5, 2.0)) is None
        assert first_sweep_contact(a1, a2, b1, b2, box(0.2, 1.5, 0.8, 2.5)) is None

    def test_collinear_slide(self) -> None:
        """The stick slides along its own line: only what it passes over is swept."""
        a1, a2, b1, b2 = (0, 0), (0, 5), (0, 2), (0, 7)
        assert first_vertex_sweep(a1, a2, b1, b2, (0, 6.5)) == pytest.approx(0.75)
        assert first_vertex_sweep(a1, a2, b1, b2, (0, 7.5)) is None
        assert first_vertex_sweep(a1, a2, b1, b2, (0, 3)) == 0.0
        assert first_vertex_sweep(a1, a2, b1, b2, (0.1, 6)) is None

    def test_degenerate_point_payload(self) -> None:
        """Both ends at the same point moving together: the sweep is the path itself."""
        a, b = (0, 0), (4, 0)
        assert first_vertex_sweep(a, a, b, b, (3, 0)) == pytest.approx(0.75)
        assert first_vertex_sweep(a, a, b, b, (3, 0.01)) is None
        assert first_sweep_contact(a, a, b, b, box(2, -1, 3, 1)).u == pytest.approx(0.5)

    def test_a_point_payload_touches_when_it_gets_there_not_before(self) -> None:
        """A tolerance fixed in squared length let a payload of length 0 count a vertex
        6e-5 ahead as reached at u = 0 (a sweep that is ahead of the motion)."""
        a, b, gap = (2.0, 0.0), (0.0, 0.0), 6.103515625e-05
        assert first_vertex_sweep(a, a, b, b, (2.0 - gap, 0.0)) == pytest.approx(gap / 2)
        contact = first_sweep_contact(a, a, b, b, box(-gap, 0, 2 - gap, 1))
        assert contact is not None and contact.u == pytest.approx(gap / 2)
        # ... and one that passes a vertex 5e-4 to its side never touches it
        assert first_vertex_sweep((1.0, -4.0), (1.0, -4.0), (-1.0, 4.0), (-1.0, 4.0), (0.0, 0.001953125)) is None
        # a long segment still reaches a vertex on its line within the tolerance at once
        assert first_vertex_sweep((0, 0), (0, 5), (0, 2), (0, 7), (0, 5 + 1e-12)) == 0.0

    def test_static_payload(self) -> None:
        assert first_sweep_contact((0, 0), (0, 5), (0, 0), (0, 5), box(1, 1, 2, 2)) is None
        c = first_sweep_contact((0, 0), (0, 5), (0, 0), (0, 5), box(-1, 1, 2, 2))
        assert c is not None and c.u == 0.0 and c.point == (0.0, 1.0)

    def test_end_path_contact_is_first(self) -> None:
        # the lower end runs into a wall before any vertex is swept
        wall = box(3, -1, 4, 0.5)
        c = first_sweep_contact((0, 0), (0, 5), (8, 0), (8, 5), wall)
        assert c is not None and c.u == pytest.approx(3 / 8) and c.point == (3.0, 0.0)
        assert first_path_contact((0, 0), (8, 0), wall).u == pytest.approx(3 / 8)

    _coord = st.integers(-4, 4).map(float)
    _pt = st.tuples(_coord, _coord)
    # Subnormal coordinates (below 2.2e-308) are left out: GEOS loses them (a box whose edge
    # is at y = 2e-313 is hit at u = 0.55 instead of 0.5); no scene is drawn at that scale.
    _corner = st.floats(-3, 3, allow_subnormal=False)

    @settings(max_examples=300)
    @given(_pt, _pt, _pt, _pt, st.tuples(_corner, _corner),
           st.floats(0.2, 2.0), st.floats(0.2, 2.0))
    def test_against_dense_sampling(self, a1, a2, b1, b2, corner, w, h) -> None:
        """Exact contact vs 400 sampled positions: never later, never missed, never spurious."""
        poly = box(corner[0], corner[1], corner[0] + w, corner[1] + h)
        contact = first_sweep_contact(a1, a2, b1, b2, poly)
        us = np.linspace(0, 1, 401)
        hits = [u for u in us if segment_at(a1, a2, b1, b2, u).intersects(poly)]
        if contact is None:
            assert not hits  # a sampled position that meets the polygon was not missed
        else:
            assert segment_at(a1, a2, b1, b2, contact.u).distance(poly) < 1e-7  # real contact
            assert poly.distance(shapely.Point(contact.point)) < 1e-7
            if hits:
                assert contact.u <= hits[0] + 1e-9  # never later than the first sampled hit
