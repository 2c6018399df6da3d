"""A trajectory file whose parts contradict each other is refused at load, naming the field.

The file is what drives the motors; an edit by hand (a setpoint, a time, a limit) must not
reach them unnoticed.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from traj_helpers import CLEAN_PAYLOAD_PLAN, plan

from trajectory import Scene, Trajectory, TrajectoryFormatError, build_trajectory, load_trajectory
from trajectory.export import trajectory_from_dict, trajectory_to_dict


@pytest.fixture(scope="module")
def data(payload_scene: Scene) -> dict[str, Any]:
    traj = build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=5,
                            step_time_s=0.5)
    return trajectory_to_dict(traj)


def edited(data: dict[str, Any], edit) -> dict[str, Any]:
    out = copy.deepcopy(data)
    edit(out)
    return out


def _swap_times(d):
    t = d["robots"][0]["samples"]["t_s"]
    t[3], t[4] = t[4], t[3]


def _setpoint(delta):
    def edit(d):
        d["robots"][0]["setpoints_deg"][12][2] += delta
    return edit


def _widen_min(d):
    d["robots"][1]["motors"][2]["min_deg"] -= 50


def _move_sample(d):
    d["robots"][1]["samples"]["x"][7] += 0.5


def _step(d):
    d["robots"][0]["samples"]["step"][6] = 0


def _zero(d):
    d["robots"][0]["motors"][0]["zero_joint"] += 1.0


def _joint_beyond_limit(d):
    r = d["robots"][0]
    r["kinematics"]["theta_limits_deg"][1] = max(r["samples"]["theta_deg"]) - 1.0


CASES = [
    (_swap_times, "robots[0].samples.t_s[3]", "times must increase by one tick"),
    (_setpoint(30), "robots[0].setpoints_deg[12][2]", "but sample 12 puts motor C at"),
    (_widen_min, "robots[1].motors[2]", "the joint limits through the gear ratio"),
    (_move_sample, "robots[1].samples.x[7]", "is not where the joints s, theta of sample 7 put the hand"),
    (_step, "robots[0].samples.step[6]", "expected 1 (5 samples per step)"),
    (_zero, "robots[0].motors[0].zero_joint", "the encoders count from tick 0"),
    (_joint_beyond_limit, "robots[0].samples.theta_deg", "is outside the joint limits"),
]


@pytest.mark.parametrize("edit, field, message", CASES, ids=[c[1] for c in CASES])
def test_contradictions_are_refused_naming_the_field(data, edit, field, message) -> None:
    with pytest.raises(TrajectoryFormatError) as err:
        trajectory_from_dict(edited(data, edit), "t.json")
    assert err.value.field.startswith(field)
    assert message in err.value.message


def test_a_setpoint_rounded_the_other_way_is_accepted(data) -> None:
    # within one degree of its sample: rounding and clipping at a limit do that
    def edit(d):
        r = d["robots"][0]
        m = r["motors"][2]
        exact = m["offset_deg"] + m["deg_per_unit"] * (r["samples"]["theta_deg"][12] - m["zero_joint"])
        row = r["setpoints_deg"][12]
        row[2] = math.floor(exact) if row[2] > exact else math.ceil(exact)
    changed = edited(data, edit)
    assert changed["robots"][0]["setpoints_deg"][12] != data["robots"][0]["setpoints_deg"][12]
    traj = trajectory_from_dict(changed, "t.json")
    # loaded as written, not recomputed from the samples
    assert traj.robots[0].setpoints_deg[12].tolist() == changed["robots"][0]["setpoints_deg"][12]


@settings(max_examples=60)
@given(robot=st.integers(0, 1), tick=st.integers(0, 45), motor=st.integers(0, 2),
       delta=st.integers(2, 5000) | st.integers(-5000, -2))
def test_any_setpoint_edited_by_more_than_a_degree_is_refused(data, robot, tick, motor, delta) -> None:
    def edit(d):
        d["robots"][robot]["setpoints_deg"][tick][motor] += delta
    with pytest.raises(TrajectoryFormatError, match=rf"robots\[{robot}\]\.setpoints_deg\[{tick}\]"):
        trajectory_from_dict(edited(data, edit), "t.json")


@pytest.mark.parametrize("text, message", [
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"tick_ms": 1' + "0" * 5000 + "}", "invalid JSON"),
])
def test_hostile_json_is_one_error(tmp_path: Path, text: str, message: str) -> None:
    bad = tmp_path / "t.json"
    bad.write_text(text)
    with pytest.raises(TrajectoryFormatError, match=message):
        load_trajectory(bad)


def test_not_a_regular_file(tmp_path: Path) -> None:
    with pytest.raises(TrajectoryFormatError, match="not a regular file"):
        load_trajectory(tmp_path)
    with pytest.raises(TrajectoryFormatError, match="not a regular file"):
        load_trajectory("/dev/zero")


def test_the_built_trajectory_is_consistent(data) -> None:
    traj: Trajectory = trajectory_from_dict(json.loads(json.dumps(data)), "t.json")
    assert traj.ticks == 46
