"""Geometry at its edges: roots on the ends of [0, 1], degenerate motions and polygons touched
at a corner, with exact expected values (and the test reference's tangent root)."""

from __future__ import annotations

import pytest
from shapely.geometry import box
from traj_helpers import real_roots

from trajectory.geometry import (
    Contact,
    Quadratic,
    first_failing_interval,
    first_failing_time,
    first_path_contact,
    first_sweep_contact,
    first_vertex_sweep,
    payload_length_sq,
    quadratic_roots,
    segment_geometry,
)

SQUARE = box(-1, -1, 1, 1)


def test_quadratic_values_and_shifts():
    q = Quadratic(1, 2, 3)
    assert q(2.0) == 11.0 and q(0.0) == 3.0
    assert q.shifted(5) == Quadratic(1, 2, -2)
    assert payload_length_sq((0, 0), (3, 4), (1, 1), (1, 5)) == Quadratic(9, -18.0, 25)


@pytest.mark.parametrize("q, expected", [
    (Quadratic(1, -2, 0), ((1.0, -1.0), (0.0, 0.0))),
    (Quadratic(0, 1, 0), ((0.0, 0.0), (1.0, 1.0))),
    (Quadratic(-1, 2, 0), ((0.0, 0.0), (1.0, 1.0))),     # vertex at u = 1: an end, not inside
    (Quadratic(-4, 4, 0), ((0.0, 0.0), (0.5, 1.0))),
    (Quadratic(4, -4, 2), ((0.5, 1.0), (1.0, 2.0))),      # a tie: the later end
])
def test_extremes_on_the_unit_interval(q, expected):
    assert q.extremes_on_unit() == expected


@pytest.mark.parametrize("q, roots", [
    (Quadratic(1, -1, 0), [0.0, 1.0]),                   # both ends of [0, 1] are in it
    (Quadratic(1, 1, 0), [0.0]),                         # -1 is not
    (Quadratic(0, 1, 1e-13), [0.0]),                     # a hair below 0 counts as 0
    (Quadratic(0, 1, 1e-11), []),                        # more than a hair does not
    (Quadratic(0, 1, -1 - 1e-13), [1.0]),                # a hair beyond 1 counts as 1
    (Quadratic(0, 1, -1 - 1e-11), []),
    (Quadratic(1, -2.0000000000002, 1.0000000000002), [1.0]),  # a double root at the end
    (Quadratic(2, -1, 0.125), [0.25]),                   # exactly tangent
    (Quadratic(1e-13, 1e-13, 1e-13), None),              # every coefficient below tol: vanishes
    (Quadratic(1e-13, 1e-13, 1.0), []),
    (Quadratic(1e-13, 2.0, -1.0), [0.5]),                # a below tol: linear
])
def test_roots_at_the_edges(q, roots):
    got = quadratic_roots(q, 1e-12)
    assert got == (None if roots is None else pytest.approx(roots, abs=1e-12))


def test_the_reference_keeps_a_tangent_root():
    """(u - 0.1)^2 with rounded coefficients: the discriminant is a few ulps below 0, and a
    segment at exactly full reach meets its bound there; dropping it would hide the exit."""
    assert real_roots(1.0, -0.2, 0.010000000000000002) == pytest.approx([0.1, 0.1])
    assert real_roots(1.0, 0.0, 1.0) == []
    assert real_roots(0.0, 2.0, -1.0) == [0.5] and real_roots(0.0, 0.0, 1.0) == []


def test_first_failing_interval_clamps_and_skips_empty_intervals():
    assert first_failing_interval([-3, 0.5, 7], lambda u: u > 0.5) == (0.5, 0.75)
    assert first_failing_interval([], lambda u: True) == (0.0, 0.5)
    assert first_failing_interval([0.2, 0.2], lambda u: 0.1 < u < 0.2) is None
    assert first_failing_interval([0.2, 0.6], lambda u: u > 0.2) == (0.2, 0.4)
    assert first_failing_time([0.25], lambda u: u > 0.25) == 0.25
    assert first_failing_time([0.25], lambda u: False) is None


def test_segment_geometry_of_a_robot_that_does_not_move():
    assert segment_geometry((1, 1), (1, 1)).geom_type == "Point"
    assert segment_geometry((1, 1), (1, 2)).geom_type == "LineString"


@pytest.mark.parametrize("p, q, expected", [
    ((0, 0), (0, 0), Contact(0.0, (0, 0))),              # standing inside
    ((0, 2), (0, -2), Contact(0.25, (0.0, 1.0))),
    ((0, -2), (0, 2), Contact(0.25, (0.0, -1.0))),       # the first point from p, either way
    ((-2, 1), (2, 1), Contact(0.25, (-1.0, 1.0))),       # along an edge
    ((-2, 1.5), (2, 1.5), None),
    ((2, 2), (1, 1), Contact(1.0, (1.0, 1.0))),          # reaching a corner at the end
    ((-3, 0), (-2, 0), None),
])
def test_path_contacts(p, q, expected):
    assert first_path_contact(p, q, SQUARE) == expected


@pytest.mark.parametrize("v, expected", [
    ((1, 0), 0.5), ((1, 1e-3), None), ((3, 0), None), ((-1e-3, 0), None), ((0, 0), 0.0), ((2, 0), 1.0),
])
def test_a_point_payload_moving_in_a_line_sweeps_exactly_its_path(v, expected):
    assert first_vertex_sweep((0, 0), (0, 0), (2, 0), (2, 0), v) == expected


def test_a_point_payload_standing_still_sweeps_only_its_point():
    assert first_vertex_sweep((0, 0), (0, 0), (0, 0), (0, 0), (0, 0)) == 0.0
    assert first_vertex_sweep((0, 0), (0, 0), (0, 0), (0, 0), (0, 1e-3)) is None


def test_a_vertex_on_the_moving_line_all_the_time():
    """A segment sliding along its own line: the vertex is swept from when an end reaches it."""
    assert first_vertex_sweep((0, 0), (1, 0), (2, 0), (3, 0), (2, 0)) == pytest.approx(0.5)
    assert first_vertex_sweep((0, 0), (1, 0), (2, 0), (3, 0), (0.5, 0)) == 0.0
    assert first_vertex_sweep((0, 0), (1, 0), (2, 0), (3, 0), (4, 0)) is None


@pytest.mark.parametrize("ends, u, points", [
    (((0, 0), (0, 5), (0, 0), (0, 5), box(-1, 1, 1, 2)), 0.0, [(0.0, 1.0)]),
    (((0, 5), (0, 0), (0, 5), (0, 0), box(-1, 1, 1, 2)), 0.0, [(0.0, 2.0)]),  # first from a1
    (((-3, 0), (-2, 0), (3, 0), (4, 0), SQUARE), 1 / 6, [(-1.0, 0.0)]),
    (((-3, -3), (-3, 3), (3, -3), (3, 3), SQUARE), 1 / 3, [(-1.0, 1.0), (-1.0, -1.0)]),  # an edge: a corner
    (((-3, 2), (3, 2), (-3, 3), (3, 3), SQUARE), None, []),
])
def test_sweep_contacts(ends, u, points):
    got = first_sweep_contact(*ends)
    if u is None:
        assert got is None
    else:
        assert got is not None and got.u == pytest.approx(u) and got.point in points
