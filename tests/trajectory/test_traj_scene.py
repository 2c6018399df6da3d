"""Scene files: the payload scene, the collision external, and located errors for bad input."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from traj_helpers import PAYLOAD_SCENE

from trajectory import (
    JointLimitError,
    Location,
    Scene,
    SceneError,
    UnreachableError,
    check_reachable,
    load_scene,
    parse_scene,
)
from trajectory.kinematics import choices_at
from trajectory.scene import EXAMPLE_SCENE

PAYLOAD_TEXT = PAYLOAD_SCENE.read_text(encoding="utf-8")
SCENE = load_scene(PAYLOAD_SCENE)  # one instance: its collision table is built once


class TestPayloadScene:
    def test_contents(self, payload_scene: Scene) -> None:
        s = payload_scene
        assert s.name == "payload"
        assert s.robot_names == ("r1", "r2")
        assert s.end_names == ("pl1", "pl2")
        assert [o.name for o in s.obstacles] == ["low wall", "post"]
        assert s.payload.length_sq_band == (23.0, 27.0)
        assert (s.grid.x_min, s.grid.x_max, s.grid.y_min, s.grid.y_max) == (0, 12, -1, 7)
        assert [m.port for m in s.robot("r1").motors] == ["A", "B", "C"]
        assert {m.joint for m in s.robot("r2").motors} == {"s", "theta"}

    def test_bindings_name_fluents_with_locations(self, payload_scene: Scene) -> None:
        bound = dict(payload_scene.bindings())
        assert bound["r1.x"].fluent == "xpos(r1)"
        assert bound["pl2.y"].fluent == "ypay(pl2)"
        assert bound["payload.holds"].fluent == "on"
        loc = bound["r2.y"].location
        line = PAYLOAD_TEXT.splitlines()[loc.line - 1]
        assert line[loc.col - 1:].startswith('y = "ypos(r2)"')
        assert loc.file == str(PAYLOAD_SCENE)

    def test_start_and_goal_are_reachable(self, payload_scene: Scene) -> None:
        for robot, points in {"r1": [(0, 0), (10, 0)], "r2": [(0, 5), (10, 5)]}.items():
            for p in points:
                assert choices_at(payload_scene.robot(robot).arm, *p)  # some branch holds it
                assert check_reachable(payload_scene, robot, p, "start") is None

    def test_unreachable_point_is_a_located_error(self, payload_scene: Scene) -> None:
        with pytest.raises(UnreachableError) as err:
            check_reachable(payload_scene, "r1", (3, 6), "goal")
        text = str(err.value)
        assert "r1" in text and "goal (3, 6)" in text
        loc = payload_scene.robot("r1").location
        assert text.startswith(f"{loc.file}:{loc.line}:{loc.col}: error: ")
        where = Location("query.cp", 7, 3)
        with pytest.raises(UnreachableError, match=r"^query\.cp:7:3: error: robot r2"):
            check_reachable(payload_scene, "r2", (0, 0), "start", where)

    def test_joint_limit_error_when_within_reach(self, example_scene: Scene) -> None:
        # (12, 2): 3 above r1's rail, so theta = 90 deg, but s = 12 > s_max = 10 on both branches
        with pytest.raises(JointLimitError, match=r"branch \+1: s = 12 .*branch -1: s = 12"):
            check_reachable(example_scene, "r1", (12, 2), "goal")


class TestCollisionExternal:
    def test_semantics(self, payload_scene: Scene) -> None:
        c = payload_scene.collision
        assert c(4, 0, 6, 0)            # through the low wall
        assert not c(4, 2, 6, 2)        # above it
        assert c(4, 1, 6, 2)            # crosses the wall's top edge
        assert c(5, 1, 5, 1)            # a point inside the wall
        assert not c(0, 0, 0, 0)        # a free point
        assert c(7, 5, 7, 7)            # through the post
        assert c(6, 6, 8, 6)            # y = 6 crosses the post
        assert not c(6, 5, 8, 5)        # under it

    def test_touching_counts(self) -> None:
        scene = parse_scene(EXAMPLE_SCENE, "e.toml")  # post: x in [2, 3], y in [-1, 1]
        assert scene.collision(0, 1, 4, 1)   # runs along the top edge
        assert scene.collision(1, 2, 3, 0)   # touches the corner (2, 1)
        assert not scene.collision(0, 2, 4, 2)
        assert scene.collision(2.5, 3, 2.5, 1.0)
        assert not scene.collision(2.5, 3, 2.5, 1.0001)

    def test_arguments_outside_the_grid_and_non_integers(self, payload_scene: Scene) -> None:
        c = payload_scene.collision
        assert c(-5, 0, 20, 0)
        assert not c(-5, 3, 20, 3)
        assert c(4.9, 1.2, 5.1, 1.2)
        assert c(5.0, 1.0, 5, 1)

    @settings(max_examples=300)
    @given(st.integers(-3, 15), st.integers(-3, 9), st.integers(-3, 15), st.integers(-3, 9))
    def test_table_agrees_with_shapely(self, x1: int, y1: int, x2: int, y2: int) -> None:
        scene = SCENE
        seg = shapely.Point(x1, y1) if (x1, y1) == (x2, y2) else shapely.LineString([(x1, y1), (x2, y2)])
        expected = any(shapely.intersects(seg, o.polygon) for o in scene.obstacles)
        assert scene.collision(x1, y1, x2, y2) is expected
        assert scene.collision(x2, y2, x1, y1) is expected

    def test_externals(self, payload_scene: Scene) -> None:
        assert payload_scene.externals()["collision"](4, 0, 6, 0) is True

    @settings(max_examples=200)
    @given(st.integers(0, 12), st.integers(-1, 7), st.integers(0, 12), st.integers(-1, 7),
           st.sampled_from([int, float, np.int64, np.float64]))
    def test_a_grid_point_is_a_grid_point_whatever_its_number_type(self, x1: int, y1: int, x2: int, y2: int,
                                                                   kind: type) -> None:
        """The grounder passes ints; a float or a numpy number of the same value gets the same
        answer, the geometric one (the table is looked up by value)."""
        expected = bool(SCENE.workspace.union.intersects(
            shapely.Point(x1, y1) if (x1, y1) == (x2, y2) else shapely.LineString([(x1, y1), (x2, y2)])))
        answer = SCENE.externals()["collision"](kind(x1), kind(y1), kind(x2), kind(y2))
        assert answer is expected

    def test_off_grid_points_next_to_grid_points_are_not_rounded(self, payload_scene: Scene) -> None:
        c = payload_scene.collision
        assert c(4, 2, 6, 2) is False and c(4, 1.5, 6, 1.5) is True      # the wall's top edge
        assert c(7, 5, 7, 5.6) is True and c(7, 5, 7, 5.5999) is False    # the post's bottom edge
        assert c(7, 5, 7, 5.6 + 1e-12) is True


class TestWorkspace:
    @settings(max_examples=60)
    @given(st.lists(st.tuples(st.integers(-3, 14), st.integers(-3, 9), st.sampled_from([0.3, 0.5, 1.0, 2.5]),
                              st.sampled_from([0.3, 0.5, 1.0, 2.5])), max_size=25),
           st.lists(st.lists(st.tuples(st.integers(-4, 16), st.integers(-4, 10)), min_size=1, max_size=4),
                    min_size=1, max_size=20))
    def test_candidates_are_the_tree_s_answer_in_the_tree_s_order(self, boxes, queries) -> None:
        """The checker breaks ties between obstacles in this order, so it must not change."""
        from trajectory.workspace import Workspace
        polygons = [shapely.box(x, y, x + w, y + h) for x, y, w, h in boxes]
        ws = Workspace(polygons, (0, 12, -1, 7))
        for points in queries:
            xs, ys = [p[0] for p in points], [p[1] for p in points]
            tree = [int(k) for k in ws.tree.query(shapely.box(min(xs), min(ys), max(xs), max(ys)))]
            assert ws.candidates([(float(x), float(y)) for x, y in points]) == tree

    def test_shrunk_obstacles(self, example_scene: Scene) -> None:
        ws = example_scene.workspace
        (post,) = ws.shrunk(0.25)
        assert post.bounds == (2.25, -0.75, 2.75, 0.75)
        assert ws.shrunk(0.25) is ws.shrunk(0.25)        # computed once
        assert ws.shrunk(0.6) == ()                      # thinner than twice the margin: nothing left


# -- bad input: every error located at file:line:col -------------------------------------------

def _replace(old: str, new: str) -> str:
    assert old in PAYLOAD_TEXT, old
    return PAYLOAD_TEXT.replace(old, new, 1)


def _line_of(text: str, needle: str) -> int:
    for k, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return k
    raise AssertionError(needle)


# (mutated text, the line the error must point at (a substring of it), message pattern)
BAD = {
    "wrong format": (_replace('format = "cplus.scene/1"', 'format = "cplus.scene/2"'),
                     'format = "cplus.scene/2"', r"unsupported scene format 'cplus.scene/2'"),
    "missing field": (_replace("arm_length = 7.0\n", "", ), "[robots.r1]",
                      r"missing required field 'arm_length' in robots\.r1"),
    "open polygon": (_replace("[4.5, 1.5], [4.5, -3.0]]", "[4.5, 1.5], [4.5, -2.0]]"),
                     "[4.5, -2.0]]", r"'low wall' is not closed: its last point \(4.5, -2\)"),
    "self-intersecting polygon": (_replace("[[6.6, 5.6], [7.4, 5.6], [7.4, 6.4], [6.6, 6.4], [6.6, 5.6]]",
                                           "[[6.6, 5.6], [7.4, 6.4], [7.4, 5.6], [6.6, 6.4], [6.6, 5.6]]"),
                                  "[[6.6, 5.6], [7.4, 6.4]",
                                  r"'post' is not a simple polygon: self-intersection at \(7, 6\)"),
    "too few points": (_replace("[[6.6, 5.6], [7.4, 5.6], [7.4, 6.4], [6.6, 6.4], [6.6, 5.6]]",
                                "[[6.6, 5.6], [7.4, 5.6], [6.6, 5.6]]"),
                       "[[6.6, 5.6], [7.4, 5.6], [6.6, 5.6]]", r"at least 3 corners"),
    "zero area": (_replace("[[6.6, 5.6], [7.4, 5.6], [7.4, 6.4], [6.6, 6.4], [6.6, 5.6]]",
                           "[[6, 5], [7, 5], [8, 5], [6, 5]]"), "[[6, 5], [7, 5], [8, 5], [6, 5]]",
                  r"'post' has zero area"),
    "point not a pair": (_replace("[7.4, 6.4], [6.6, 6.4]", "[7.4, 6.4, 1], [6.6, 6.4]"),
                         "[7.4, 6.4, 1]", r"obstacles\[1\]\.points\[2\] must be a pair"),
    "bad port": (_replace('port = "C"', 'port = "D"'), 'port = "D"', r"one of A, B, C, not 'D'"),
    "duplicate port": (_replace('port = "B"', 'port = "A"  # dup'), 'port = "A"  # dup',
                       r"robot r1 uses port A twice"),
    "no theta motor": (_replace('joint = "theta"', 'joint = "s"'), "[[robots.r1.motors]]",
                       r"robot r1 has no motor driving joint 'theta'"),
    "bad joint": (_replace('joint = "theta"', 'joint = "elbow"'), 'joint = "elbow"',
                  r"\"s\" or \"theta\", not 'elbow'"),
    "zero gear ratio": (_replace("deg_per_unit = 5.0", "deg_per_unit = 0"), "deg_per_unit = 0",
                        r"gear ratio\) must not be 0"),
    "negative arm": (_replace("arm_length = 7.0", "arm_length = -7.0"), "arm_length = -7.0",
                     r"robots\.r1\.arm_length must be positive, not -7"),
    "limits unordered": (_replace("s_limits = [-8.0, 20.0]", "s_limits = [20.0, -8.0]"),
                         "s_limits = [20.0, -8.0]", r"min < max, not \[20, -8\]"),
    "theta span": (_replace("theta_limits_deg = [5.0, 175.0]", "theta_limits_deg = [-180.0, 180.0]"),
                   "theta_limits_deg = [-180.0, 180.0]", r"min < max < min \+ 360"),
    "zero rail": (_replace("rail_dir = [1.0, 0.0]", "rail_dir = [0.0, 0.0]"), "rail_dir = [0.0, 0.0]",
                  r"rail_dir must not be zero"),
    "string for number": (_replace("arm_length = 7.0", 'arm_length = "7"'), 'arm_length = "7"',
                          r"robots\.r1\.arm_length must be a number, not a string"),
    "bool for number": (_replace("length = 5.0", "length = true"), "length = true",
                        r"payload\.length must be a number, not a boolean"),
    "binding not a fluent": (_replace('x = "xpos(r1)"', 'x = "xpos(r1"'), 'x = "xpos(r1"',
                             r"is not a ground fluent"),
    "binding twice": (_replace('y = "ypos(r2)"', 'y = "ypos(r1)"  # twice'), 'y = "ypos(r1)"  # twice',
                      r"fluent ypos\(r1\) is bound twice: to r1\.y and to r2\.y"),
    "unknown field": (_replace("arm_length = 7.0", "arm_lenght = 7.0"), "arm_lenght = 7.0",
                      r"unknown field 'arm_lenght' in robots\.r1; expected one of: rail_origin"),
    "bad branch": (_replace("arm_length = 7.0", "arm_length = 7.0\nbranch = 2"), "branch = 2",
                   r"branch must be 1 or -1, not 2"),
    "tolerance too big": (_replace("tolerance_sq = 2 ", "tolerance_sq = 30 "), "tolerance_sq = 30",
                          r"below length\^2 = 25, not 30"),
    "one payload end": (_replace('[payload.ends.pl2]\nx = "xpay(pl2)"\ny = "ypay(pl2)"\n', ""),
                        '[payload.ends.pl1]', r"exactly 2 ends, not 1"),
    "robot name": (PAYLOAD_TEXT.replace("robots.r2", "robots.R2"), "[robots.R2]",
                   r"robot name 'R2' must be a domain object name"),
    "grid bounds": (_replace("y_max = 7", "y_max = -1"), "y_max = -1", r"must exceed grid\.y_min"),
    "toml syntax": (_replace("arm_length = 7.0", "arm_length = = 7.0"), "arm_length = = 7.0",
                    r"invalid TOML: "),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_scene_is_a_located_error(case: str) -> None:
    text, needle, pattern = BAD[case]
    with pytest.raises(SceneError) as err:
        parse_scene(text, "scene.toml")
    e = err.value
    assert e.location is not None
    assert e.location.line == _line_of(text, needle)
    assert str(e).startswith(f"scene.toml:{e.location.line}:{e.location.col}: error: ")
    assert re.search(pattern, e.message), e.message


def test_missing_file_is_a_scene_error(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "nope.toml")


def test_rail_direction_is_normalised() -> None:
    text = EXAMPLE_SCENE.replace("rail_dir = [1, 0]", "rail_dir = [2, 0]", 1)
    scene = parse_scene(text, "e.toml")
    assert scene.robot("r1").arm.rail_dir == (1.0, 0.0)
    assert math.isclose(scene.robot("r1").arm.theta_limits_rad[0], math.radians(5))
