"""The continuous checker on hand-made plans."""

from __future__ import annotations

import pytest
from traj_helpers import CLEAN_PAYLOAD_PLAN, FIRST_PAYLOAD_PLAN, carried, plan

from trajectory import (
    PlanStateError,
    Scene,
    StepState,
    ViolationKind,
    all_violations,
    first_violation,
    parse_scene,
)
from trajectory.scene import EXAMPLE_SCENE

K = ViolationKind


def grid_point_clean(scene: Scene, states: list[StepState]) -> bool:
    """What the domain checks: payload length and collision at states, arm moves per step."""
    low, high = scene.payload.length_sq_band
    for st in states:
        (x1, y1), (x2, y2) = st.payload["pl1"], st.payload["pl2"]
        if not low <= (x2 - x1) ** 2 + (y2 - y1) ** 2 <= high or scene.collision(x1, y1, x2, y2):
            return False
    for a, b in zip(states, states[1:]):
        for r in scene.robot_names:
            if scene.collision(*b.robots[r], *a.robots[r]):
                return False
    return True


class TestPayloadScenePlans:
    def test_clean_plan_has_no_violation(self, payload_scene: Scene) -> None:
        states = plan(*CLEAN_PAYLOAD_PLAN)
        assert grid_point_clean(payload_scene, states)
        assert first_violation(payload_scene, states) is None
        assert all_violations(payload_scene, states) == ()

    def test_first_plan_passes_grid_points_but_fails_between(self, payload_scene: Scene) -> None:
        states = plan(*FIRST_PAYLOAD_PLAN)
        assert grid_point_clean(payload_scene, states)
        v = first_violation(payload_scene, states)
        assert v is not None
        assert (v.step, v.kind, v.subject) == (3, K.PAYLOAD_LENGTH, "payload")
        assert v.u == pytest.approx(0.2763932, abs=1e-6)  # 25 - 10u + 10u^2 ... = 23
        assert "reaching 22.5" in v.message and "(2, 2)-(2, 7) to (6, 2)-(3, 6)" in v.message

    def test_sweep_across_the_post(self, payload_scene: Scene) -> None:
        """r2 passes above the post, r1 below it: states and arm paths are clear, the stick is not."""
        states = plan(((6, 2), (6, 7)), ((8, 2), (8, 7)))
        assert grid_point_clean(payload_scene, states)
        v = first_violation(payload_scene, states)
        assert v is not None and v.kind == K.PAYLOAD_COLLISION and v.obstacle == "post"
        assert v.u == pytest.approx(0.3) and v.point in ((6.6, 5.6), (6.6, 6.4))
        assert [w.kind for w in all_violations(payload_scene, states)] == [K.PAYLOAD_COLLISION]
        assert "hits obstacle 'post'" in v.message


class TestHandMadeCases:
    @pytest.fixture()
    def scene(self) -> Scene:
        # example scene: post x in [2, 3], y in [-1, 1]; r1 rail y = -1, r2 rail y = 5, arms 3
        return parse_scene(EXAMPLE_SCENE, "example.toml")

    def test_swept_payload_clips_a_corner_between_clean_grid_points(self) -> None:
        """A small island between grid columns: the stick sweeps over it between two steps."""
        text = EXAMPLE_SCENE.replace("[[2, -1], [3, -1], [3, 1], [2, 1], [2, -1]]",
                                     "[[3.3, 2.3], [3.7, 2.3], [3.7, 2.7], [3.3, 2.7], [3.3, 2.3]]")
        scene = parse_scene(text, "island.toml")
        states = plan(((3, 1), (3, 4)), ((4, 1), (4, 4)))
        assert grid_point_clean(scene, states)
        v = first_violation(scene, states)
        assert v is not None and v.kind == K.PAYLOAD_COLLISION
        assert v.u == pytest.approx(0.3) and v.point in ((3.3, 2.3), (3.3, 2.7))

    def test_diagonal_move_breaks_the_length_only_mid_way(self, payload_scene: Scene) -> None:
        """r2 moves diagonally by (3, -1) around a resting r1: length 5 at both steps.

        |P2 - P1|^2 = 10u^2 - 10u + 25 dips to 22.5 at u = 0.5, below the band [23, 27]: it
        leaves the band at the root of 10u^2 - 10u + 2 = 0, u = (5 - sqrt(5)) / 10.
        """
        states = plan(((8, 0), (8, 5)), ((8, 0), (11, 4)))
        assert grid_point_clean(payload_scene, states)
        found = all_violations(payload_scene, states)
        assert [w.kind for w in found] == [K.PAYLOAD_LENGTH]
        assert found[0].u == pytest.approx((5 - 5 ** 0.5) / 10, abs=1e-12)
        assert "reaching 22.5 (length 4.743) at u = 0.5" in found[0].message
        # the same motion sampled only at the two grid points would pass
        assert first_violation(payload_scene, [states[0], states[0]]) is None

    def test_effector_collision(self, scene: Scene) -> None:
        states = plan(((1, 1), (1, 4)), ((4, 1), (4, 4)))
        kinds = [(w.kind, w.subject) for w in all_violations(scene, states)]
        assert (K.EFFECTOR_COLLISION, "r1") in kinds and (K.PAYLOAD_COLLISION, "payload") in kinds
        v = first_violation(scene, states)
        assert v is not None and v.kind == K.EFFECTOR_COLLISION and v.point == (2.0, 1.0)
        assert v.u == pytest.approx(1 / 3)

    def test_out_of_reach_along_the_segment(self, scene: Scene) -> None:
        """r2 (rail y = 5, arm 3) is sent down to y = 1.5: the violation starts where its path
        crosses the reach limit y = 2, four fifths of the way, not at the end."""
        states = plan(((4, 1), (4, 4)), ((4, 1), (4, 1.5)))
        v = [w for w in all_violations(scene, states) if w.subject == "r2"]
        assert v and v[0].kind == K.OUT_OF_REACH and v[0].step == 0
        assert v[0].u == pytest.approx(2 / 2.5) and v[0].point == pytest.approx((4.0, 2.0))
        assert "leaves its reach" in v[0].message

    def test_joint_limit_mid_way(self) -> None:
        """Start and end can each be held, but no single branch follows the path between.

        Branch +1: s(u) is convex and dips below s_min = -4 mid-way. Branch -1 would need
        s = 2.49 at the end, above this scene's s_max = 2.2. A robot cannot switch branch on
        the way, so the motion is impossible.
        """
        text = EXAMPLE_SCENE.replace("s_limits = [-4, 10]", "s_limits = [-4, 2.2]", 1)
        scene = parse_scene(text, "tight.toml")
        assert scene.reachable("r1", -3.2, 1.9) and scene.reachable("r1", -0.5, -0.7)
        states = plan(((-3.2, 1.9), (0, 4)), ((-0.5, -0.7), (0, 4)))
        v = [w for w in all_violations(scene, states) if w.subject == "r1"]
        assert len(v) == 1 and v[0].kind == K.JOINT_LIMIT and 0 < v[0].u < 1
        assert "branch +1 at u = " in v[0].message and "s leaves its limits [-4, 2.2]" in v[0].message

    def test_detached_end_jumps_to_the_other_robot(self, scene: Scene) -> None:
        """The literal domain's trap: pl1 is held by r1, then shows up at r2's position."""
        a = carried((1, 1), (1, 4))
        b = StepState({"r1": (2, 2), "r2": (1, 4)}, {"pl1": (1, 4), "pl2": (1, 4)},
                      {"pl1": "r2", "pl2": "r2"})
        v = first_violation(scene, [a, b])
        assert v is not None and v.kind == K.DETACHED and v.subject == "pl1"
        assert "does not follow it" in v.message and "to r2" in v.message

    def test_ends_swap_robots_at_the_last_step(self, scene: Scene) -> None:
        a = carried((1, 1), (1, 4))
        b = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 4), "pl2": (1, 1)},
                      {"pl1": "r2", "pl2": "r1"})
        found = [w for w in all_violations(scene, [a, b]) if w.kind == K.DETACHED]
        assert {w.subject for w in found} >= {"pl1", "pl2"}

    def test_end_moving_while_not_held(self, scene: Scene) -> None:
        a = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (2, 1), "pl2": (2, 4)}, {})
        b = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (3, 1), "pl2": (3, 4)}, {})
        found = [w for w in all_violations(scene, [a, b]) if w.kind == K.DETACHED]
        assert [w.subject for w in found] == ["pl1", "pl2"]
        assert "while no robot holds it" in found[0].message

    def test_holds_inconsistent_with_positions(self, scene: Scene) -> None:
        a = StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (2, 1), "pl2": (1, 4)},
                      {"pl1": "r1", "pl2": "r2"})
        v = first_violation(scene, [a, a])
        assert v is not None and v.kind == K.DETACHED and "is said to be held by r1" in v.message

    def test_pick_up_is_fine(self, scene: Scene) -> None:
        """An unheld end that stays put, then a robot arrives at it: no violation."""
        a = StepState({"r1": (0, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 4)}, {"pl2": "r2"})
        b = carried((1, 1), (1, 4))
        assert first_violation(scene, [a, b]) is None

    def test_first_violation_is_the_earliest(self, scene: Scene) -> None:
        states = plan(((4, 1), (4, 4)), ((5, 1), (5, 4)), ((5, 1), (2, 1)), ((9, 1), (9, 4)))
        found = all_violations(scene, states)
        assert found == tuple(sorted(found, key=lambda w: w.sort_key))
        v = first_violation(scene, states)
        assert v == found[0] and v.step == 1

    def test_single_state_plan(self, scene: Scene) -> None:
        assert first_violation(scene, [carried((1, 1), (1, 4))]) is None
        found = all_violations(scene, [carried((2, 0), (2, 3))])
        assert [(w.kind, w.u) for w in found] == [(K.EFFECTOR_COLLISION, 0.0), (K.PAYLOAD_COLLISION, 0.0)]

    def test_unreachable_start_and_end(self, scene: Scene) -> None:
        v = first_violation(scene, plan(((1, 3), (1, 4)), ((1, 1), (1, 4))))
        assert v is not None and v.kind == K.OUT_OF_REACH and v.subject == "r1" and v.step == 0
        found = all_violations(scene, plan(((1, 1), (1, 4)), ((1, 3.5), (1, 4))))
        assert any(w.kind == K.OUT_OF_REACH and w.u > 0 for w in found)

    def test_states_must_match_the_scene(self, scene: Scene) -> None:
        bad = StepState({"r1": (1, 1)}, {"pl1": (1, 1), "pl2": (1, 4)}, {})
        with pytest.raises(PlanStateError, match="step 0: no position for robot r2"):
            first_violation(scene, [bad])
        extra = StepState({"r1": (1, 1), "r2": (1, 4), "r3": (0, 0)}, {"pl1": (1, 1), "pl2": (1, 4)})
        with pytest.raises(PlanStateError, match="robot r3 is not in the scene"):
            all_violations(scene, [extra])
        with pytest.raises(PlanStateError, match="held by unknown robot r9"):
            first_violation(scene, [StepState({"r1": (1, 1), "r2": (1, 4)},
                                              {"pl1": (1, 1), "pl2": (1, 4)}, {"pl1": "r9"})])
        with pytest.raises(PlanStateError, match="at least one state"):
            first_violation(scene, [])
        with pytest.raises(PlanStateError, match="must be finite"):
            StepState({"r1": (float("nan"), 1)}, {})

    def test_violation_time(self, scene: Scene) -> None:
        v = first_violation(scene, plan(((1, 1), (1, 4)), ((1, 1), (1, 4)), ((4, 1), (4, 4))))
        assert v is not None and v.time_s(2.0) == pytest.approx((1 + 1 / 3) * 2.0)
