"""Trajectory files: JSON round trip, CSV columns, validation errors naming the field."""

from __future__ import annotations

import copy
import csv
import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from traj_helpers import CLEAN_PAYLOAD_PLAN, plan

from trajectory import (
    TRAJECTORY_FORMAT,
    Scene,
    Trajectory,
    TrajectoryFormatError,
    build_trajectory,
    load_trajectory,
    parse_scene,
    save_csv,
    save_json,
    to_csv_text,
)
from trajectory.export import trajectory_from_dict, trajectory_to_dict


@pytest.fixture(scope="module")
def traj(payload_scene: Scene) -> Trajectory:
    return build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=5,
                            step_time_s=0.5, source={"domain": "domains/payload/payload.cp"})


def test_json_round_trip(traj: Trajectory, tmp_path: Path) -> None:
    path = save_json(traj, tmp_path / "t.json")
    data = json.loads(path.read_text())
    assert data["format"] == TRAJECTORY_FORMAT and data["tick_ms"] == 100
    assert data["source"] == {"domain": "domains/payload/payload.cp", "plan_length": 9}
    back = load_trajectory(path)
    assert (back.tick_ms, back.step_time_s, back.points_per_step, back.plan_length) == (100, 0.5, 5, 9)
    for a, b in zip(traj.robots, back.robots):
        assert a.name == b.name and a.branch == b.branch and a.arm == b.arm
        assert a.motors == b.motors
        for field in ("t_s", "x", "y", "s", "theta_deg"):
            np.testing.assert_allclose(getattr(a, field), getattr(b, field), atol=1e-11)
        np.testing.assert_array_equal(a.step, b.step)
        np.testing.assert_array_equal(a.setpoints_deg, b.setpoints_deg)
    assert trajectory_to_dict(back) == data  # stable: saving the loaded file changes nothing
    # the file alone (its kinematics and joint values) gives back the plan's grid points
    for k, r in enumerate(back.robots):
        at_steps = slice(None, None, back.points_per_step)
        x, y = r.forward(r.s[at_steps], np.radians(r.theta_deg[at_steps]))
        expected = np.array([pair[k] for pair in CLEAN_PAYLOAD_PLAN], dtype=float)
        np.testing.assert_allclose(np.column_stack([x, y]), expected, atol=1e-9)


def test_loaded_trajectory_maps_logged_motor_angles_to_positions(traj: Trajectory, tmp_path: Path) -> None:
    """What the execution side does: encoder angles -> joints -> FK -> executed path."""
    back = load_trajectory(save_json(traj, tmp_path / "t.json"))
    r2 = back.robot("r2")
    logged = r2.setpoints_deg + np.array([2, -2, 3])  # a brick that lags a little
    s, theta = r2.joints_from_motor_deg(logged)
    # the two carriage motors' +2 and -2 cancel in their average; the arm's +3 is 0.6 deg
    assert np.max(np.abs(s - r2.s)) <= 0.5 / 81.82 + 1e-12
    assert np.max(np.abs(np.degrees(theta) - r2.theta_deg - 0.6)) <= 0.5 / 5.0 + 1e-12
    x, y = r2.xy_from_motor_deg(logged[0])
    assert (float(x), float(y)) != (0.0, 5.0)  # the lag is visible ...
    assert abs(float(x) - 0.0) < 0.1 and abs(float(y) - 5.0) < 0.1  # ... and small
    with pytest.raises(ValueError, match="3 motors"):
        r2.joints_from_motor_deg([1, 2])


def test_csv(traj: Trajectory, tmp_path: Path) -> None:
    path = save_csv(traj, tmp_path / "t.csv")
    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    assert list(rows[0]) == ["robot", "tick", "t_s", "step", "x", "y", "s", "theta_deg",
                             "A_deg", "B_deg", "C_deg"]
    assert len(rows) == 2 * traj.ticks
    r2_rows = [r for r in rows if r["robot"] == "r2"]
    last = r2_rows[-1]
    assert (float(last["x"]), float(last["y"]), int(last["step"])) == (10.0, 5.0, 9)
    r2 = traj.robot("r2")
    assert [int(r["C_deg"]) for r in r2_rows] == r2.setpoints_deg[:, 2].tolist()


def test_csv_leaves_missing_ports_empty(payload_scene: Scene) -> None:
    r2_motor_b = '[[robots.r2.motors]]\nport = "B"\njoint = "s"\ndeg_per_unit = 81.82\n'
    src = Path(payload_scene.file).read_text().replace(r2_motor_b, "")
    scene = parse_scene(src, "fewer.toml")
    t = build_trajectory(scene, plan(*CLEAN_PAYLOAD_PLAN[:3]), points_per_step=2, step_time_s=0.2)
    rows = list(csv.DictReader(io.StringIO(to_csv_text(t))))
    assert {r["B_deg"] for r in rows if r["robot"] == "r2"} == {""}
    assert all(r["B_deg"] != "" for r in rows if r["robot"] == "r1")


def _mutate(data: dict[str, Any], path: list[Any], value: Any) -> dict[str, Any]:
    out = copy.deepcopy(data)
    node = out
    for key in path[:-1]:
        node = node[key]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return out


_DELETE = object()

BAD = [
    (["format"], "cplus.trajectory/9", "format", "expected 'cplus.trajectory/1'"),
    (["tick_ms"], _DELETE, "tick_ms", "missing"),
    (["tick_ms"], 50, "tick_ms", "must equal step_time_s"),
    (["robots"], [], "robots", "non-empty list"),
    (["robots", 0, "samples", "x"], [1, 2], "robots[0].samples.x", "expected 46 numbers, got 2"),
    (["robots", 1, "samples", "y", 3], "a", "robots[1].samples.y[3]", "expected a finite number"),
    (["robots", 0, "setpoints_deg", 2], [1, 2], "robots[0].setpoints_deg[2]", "expected 3 integers"),
    (["robots", 0, "setpoints_deg", 2, 0], 1.5, "robots[0].setpoints_deg[2][0]", "expected an integer"),
    (["robots", 0, "motors", 1, "port"], "Q", "robots[0].motors[1].port", "expected A, B or C"),
    (["robots", 0, "motors", 2, "joint"], "s", "robots[0].motors", "no motor drives joint 'theta'"),
    (["robots", 0, "motors", 0, "deg_per_unit"], 0, "robots[0].motors[0].deg_per_unit", "must not be 0"),
    (["robots", 1, "kinematics", "branch"], 0, "robots[1].kinematics.branch", "expected 1 or -1"),
    (["robots", 1, "kinematics", "arm_length"], -1, "robots[1].kinematics", "arm length must be positive"),
    (["robots", 1, "name"], "r1", "robots", "robot names must be unique"),
    (["robots", 1, "samples", "t_s"], [0.0] * 45, "robots[1].samples.t_s", "expected 46 numbers"),
]


@pytest.mark.parametrize("path,value,field,message", BAD, ids=[b[2] + ":" + b[3][:12] for b in BAD])
def test_bad_files_name_the_field(traj: Trajectory, path, value, field, message) -> None:
    data = trajectory_to_dict(traj)
    with pytest.raises(TrajectoryFormatError) as err:
        trajectory_from_dict(_mutate(data, path, value), "t.json")
    assert err.value.field == field
    assert str(err.value) == f"error: t.json: {field}: " + str(err.value).split(f"{field}: ", 1)[1]
    assert message in err.value.message


def test_not_json_and_missing_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": \n')
    with pytest.raises(TrajectoryFormatError, match=r"bad\.json:2:1: invalid JSON"):
        load_trajectory(bad)
    with pytest.raises(TrajectoryFormatError, match="cannot read"):
        load_trajectory(tmp_path / "missing.json")
    bad.write_text("[1, 2]")
    with pytest.raises(TrajectoryFormatError, match="expected a JSON object"):
        load_trajectory(bad)


def test_trajectory_is_immutable(traj: Trajectory) -> None:
    r = traj.robots[0]
    with pytest.raises(ValueError):
        r.x[0] = 99.0
    with pytest.raises(AttributeError):
        r.name = "zz"  # type: ignore[misc]
    with pytest.raises(TypeError):
        traj.source["x"] = 1  # type: ignore[index]
