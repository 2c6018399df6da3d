"""Trajectory files: `cplus.trajectory/1` JSON (read and write) and a flat CSV (write).

The JSON file is what crosses to the execution side, so loading validates every field and a
problem names it (``robots[0].samples.x: expected 111 numbers``). The CSV has one row per
(robot, tick) with the columns ``robot,tick,t_s,step,x,y,s,theta_deg`` followed by one
``<port>_deg`` column per motor port used by any robot (empty where a robot lacks that port).

`trajectory_to_dict` / `trajectory_from_dict` and `to_csv_text` are pure; `save_json`,
`save_csv` and `load_trajectory` add the file I/O.

>>> from trajectory import StepState, build_trajectory, parse_scene
>>> from trajectory.scene import EXAMPLE_SCENE
>>> held = {"pl1": "r1", "pl2": "r2"}
>>> states = [StepState({"r1": (1, 1), "r2": (1, 4)}, {"pl1": (1, 1), "pl2": (1, 4)}, held),
...           StepState({"r1": (4, 1), "r2": (4, 4)}, {"pl1": (4, 1), "pl2": (4, 4)}, held)]
>>> traj = build_trajectory(parse_scene(EXAMPLE_SCENE, "example.toml"), states, check=False,
...                         points_per_step=2, step_time_s=0.2)
>>> doc = trajectory_to_dict(traj)
>>> doc["format"], doc["tick_ms"], doc["robots"][0]["samples"]["x"]
('cplus.trajectory/1', 100, [1, 2.5, 4])
>>> trajectory_from_dict(doc).robot("r1").setpoints_deg.tolist() == traj.robot("r1").setpoints_deg.tolist()
True
>>> print(to_csv_text(traj).splitlines()[0])
robot,tick,t_s,step,x,y,s,theta_deg,A_deg,B_deg
>>> trajectory_from_dict({"format": "cplus.trajectory/1"})
Traceback (most recent call last):
...
trajectory.errors.TrajectoryFormatError: error: trajectory.json: tick_ms: missing
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .errors import TrajectoryError, TrajectoryFormatError
from .kinematics import Arm, BranchChoice
from .model import TRAJECTORY_FORMAT, MotorChannel, RobotTrajectory, Trajectory, frozen_array

__all__ = [
    "trajectory_to_dict",
    "trajectory_from_dict",
    "to_json_text",
    "to_csv_text",
    "save_json",
    "save_csv",
    "load_trajectory",
]

_SAMPLE_FIELDS = ("t_s", "step", "x", "y", "s", "theta_deg")


def _num(v: float) -> float | int:
    """JSON numbers: whole values as integers, others as the shortest exact decimal."""
    f = float(v)
    return int(f) if f.is_integer() and abs(f) < 2**53 else f


def trajectory_to_dict(traj: Trajectory) -> dict[str, Any]:
    """The `cplus.trajectory/1` document as plain JSON-ready data."""
    robots = []
    for r in traj.robots:
        robots.append({
            "name": r.name,
            "kinematics": {
                "rail_origin": [_num(c) for c in r.arm.rail_origin],
                "rail_dir": [_num(c) for c in r.arm.rail_dir],
                "arm_length": _num(r.arm.length),
                "s_limits": [_num(c) for c in r.arm.s_limits],
                "theta_limits_deg": [_num(math.degrees(t)) for t in r.arm.theta_limits_rad],
                "branch": r.branch.branch,
                "turns": r.branch.turns,
            },
            "motors": [
                {"port": m.port, "joint": m.joint, "deg_per_unit": _num(m.deg_per_unit),
                 "offset_deg": _num(m.offset_deg), "zero_joint": _num(m.zero_joint),
                 "min_deg": m.min_deg, "max_deg": m.max_deg}
                for m in r.motors
            ],
            "samples": {
                "t_s": [_num(v) for v in r.t_s],
                "step": [int(v) for v in r.step],
                "x": [_num(v) for v in r.x],
                "y": [_num(v) for v in r.y],
                "s": [_num(v) for v in r.s],
                "theta_deg": [_num(v) for v in r.theta_deg],
            },
            "setpoints_deg": [[int(v) for v in row] for row in r.setpoints_deg],
        })
    return {
        "format": TRAJECTORY_FORMAT,
        "tick_ms": traj.tick_ms,
        "step_time_s": _num(traj.step_time_s),
        "points_per_step": traj.points_per_step,
        "source": dict(traj.source),
        "robots": robots,
    }


def _dumps(value: Any, indent: int) -> str:
    """JSON with objects indented and flat lists (or lists of flat lists) on one line each."""
    pad = " " * indent
    if isinstance(value, dict) and value:
        items = [f'{pad}  {json.dumps(k)}: {_dumps(v, indent + 2)}' for k, v in value.items()]
        return "{\n" + ",\n".join(items) + f"\n{pad}}}"
    if isinstance(value, list) and value and any(isinstance(v, dict) for v in value):
        items = [f"{pad}  {_dumps(v, indent + 2)}" for v in value]
        return "[\n" + ",\n".join(items) + f"\n{pad}]"
    if isinstance(value, list) and value and all(isinstance(v, list) for v in value):
        items = [f"{pad}  {json.dumps(v, separators=(', ', ': '))}" for v in value]
        return "[\n" + ",\n".join(items) + f"\n{pad}]"
    return json.dumps(value, separators=(", ", ": "))


def to_json_text(traj: Trajectory) -> str:
    """The JSON file's text: structure indented, each sample list on one line."""
    return _dumps(trajectory_to_dict(traj), 0) + "\n"


def to_csv_text(traj: Trajectory) -> str:
    """The CSV file's text: one row per (robot, tick)."""
    ports = sorted({m.port for r in traj.robots for m in r.motors})
    buf = io.StringIO()
    out = csv.writer(buf, lineterminator="\n")
    out.writerow(["robot", "tick", *_SAMPLE_FIELDS, *(f"{p}_deg" for p in ports)])
    for r in traj.robots:
        col = {m.port: j for j, m in enumerate(r.motors)}
        for k in range(len(r.t_s)):
            row: list[Any] = [r.name, k]
            row += [_num(getattr(r, f)[k]) for f in _SAMPLE_FIELDS]
            row += [int(r.setpoints_deg[k, col[p]]) if p in col else "" for p in ports]
            out.writerow(row)
    return buf.getvalue()


def save_json(traj: Trajectory, path: str | Path) -> Path:
    """Write the trajectory as `cplus.trajectory/1` JSON; returns the path."""
    p = Path(path)
    p.write_text(to_json_text(traj), encoding="utf-8")
    return p


def save_csv(traj: Trajectory, path: str | Path) -> Path:
    """Write the trajectory as CSV; returns the path."""
    p = Path(path)
    p.write_text(to_csv_text(traj), encoding="utf-8")
    return p


def load_trajectory(path: str | Path) -> Trajectory:
    """Read and validate a `cplus.trajectory/1` JSON file.

    Raises
    ------
    TrajectoryFormatError
        Naming the file and the field that is missing or wrong.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise TrajectoryFormatError(f"{p}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise TrajectoryFormatError(f"{p}: not UTF-8 text: {exc.reason}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise TrajectoryFormatError(f"{p}:{exc.lineno}:{exc.colno}: invalid JSON: {exc.msg}") from None
    return trajectory_from_dict(data, str(p))


class _Fields:
    """Typed access to the JSON document; every complaint names the file and the field."""

    def __init__(self, filename: str) -> None:
        self.filename = filename

    def fail(self, field: str, problem: str) -> TrajectoryFormatError:
        return TrajectoryFormatError(f"{self.filename}: {field}: {problem}", field)

    def get(self, obj: Any, key: str, field: str) -> Any:
        if not isinstance(obj, dict):
            raise self.fail(field.rsplit(".", 1)[0] if "." in field else field, "expected an object")
        if key not in obj:
            raise self.fail(field, "missing")
        return obj[key]

    def number(self, value: Any, field: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(field, f"expected a finite number, got {value!r}")
        return float(value)

    def integer(self, value: Any, field: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(field, f"expected an integer, got {value!r}")
        return value

    def string(self, value: Any, field: str) -> str:
        if not isinstance(value, str):
            raise self.fail(field, f"expected a string, got {value!r}")
        return value

    def numbers(self, value: Any, field: str, count: int | None = None) -> list[float]:
        if not isinstance(value, list):
            raise self.fail(field, "expected a list of numbers")
        if count is not None and len(value) != count:
            raise self.fail(field, f"expected {count} numbers, got {len(value)}")
        return [self.number(v, f"{field}[{k}]") for k, v in enumerate(value)]

    def pair(self, value: Any, field: str) -> tuple[float, float]:
        a, b = self.numbers(value, field, 2)
        return a, b


def trajectory_from_dict(data: Any, filename: str = "trajectory.json") -> Trajectory:
    """Validate a parsed `cplus.trajectory/1` document and build the `Trajectory`.

    Raises
    ------
    TrajectoryFormatError
        Naming the field that is missing or wrong.
    """
    f = _Fields(filename)
    if not isinstance(data, dict):
        raise f.fail("(document)", "expected a JSON object")
    fmt = f.get(data, "format", "format")
    if fmt != TRAJECTORY_FORMAT:
        raise f.fail("format", f"expected {TRAJECTORY_FORMAT!r}, got {fmt!r}")
    tick_ms = f.integer(f.get(data, "tick_ms", "tick_ms"), "tick_ms")
    step_time_s = f.number(f.get(data, "step_time_s", "step_time_s"), "step_time_s")
    pps = f.integer(f.get(data, "points_per_step", "points_per_step"), "points_per_step")
    if tick_ms < 1 or pps < 1 or step_time_s <= 0:
        raise f.fail("tick_ms", "tick_ms, points_per_step and step_time_s must be positive")
    if not math.isclose(tick_ms * pps, step_time_s * 1000.0):
        raise f.fail("tick_ms", f"tick_ms * points_per_step ({tick_ms * pps}) must equal "
                     f"step_time_s in milliseconds ({step_time_s * 1000.0:g})")
    source = data.get("source", {})
    if not isinstance(source, Mapping):
        raise f.fail("source", "expected an object")
    raw_robots = f.get(data, "robots", "robots")
    if not isinstance(raw_robots, list) or not raw_robots:
        raise f.fail("robots", "expected a non-empty list")
    robots = []
    ticks: int | None = None
    for i, raw in enumerate(raw_robots):
        robot = _robot(f, raw, f"robots[{i}]", ticks)
        ticks = len(robot.t_s)
        robots.append(robot)
    names = [r.name for r in robots]
    if len(set(names)) != len(names):
        raise f.fail("robots", "robot names must be unique")
    steps = robots[0].step
    if ticks is None or (ticks - 1) % pps != 0:
        raise f.fail("robots[0].samples.t_s", f"a plan of whole steps has k * {pps} + 1 samples, "
                     f"not {ticks}")
    plan_length = int(steps[-1]) if len(steps) else 0
    return Trajectory(tick_ms=tick_ms, step_time_s=step_time_s, points_per_step=pps,
                      plan_length=plan_length, robots=tuple(robots), source=dict(source))


def _robot(f: _Fields, raw: Any, base: str, ticks: int | None) -> RobotTrajectory:
    name = f.string(f.get(raw, "name", f"{base}.name"), f"{base}.name")
    kin = f.get(raw, "kinematics", f"{base}.kinematics")
    kb = f"{base}.kinematics"
    origin = f.pair(f.get(kin, "rail_origin", f"{kb}.rail_origin"), f"{kb}.rail_origin")
    direction = f.pair(f.get(kin, "rail_dir", f"{kb}.rail_dir"), f"{kb}.rail_dir")
    length = f.number(f.get(kin, "arm_length", f"{kb}.arm_length"), f"{kb}.arm_length")
    s_limits = f.pair(f.get(kin, "s_limits", f"{kb}.s_limits"), f"{kb}.s_limits")
    t_limits = f.pair(f.get(kin, "theta_limits_deg", f"{kb}.theta_limits_deg"), f"{kb}.theta_limits_deg")
    branch = f.integer(f.get(kin, "branch", f"{kb}.branch"), f"{kb}.branch")
    if branch not in (1, -1):
        raise f.fail(f"{kb}.branch", f"expected 1 or -1, got {branch}")
    turns = f.integer(kin.get("turns", 0), f"{kb}.turns")
    norm = math.hypot(*direction)
    if norm == 0.0:
        raise f.fail(f"{kb}.rail_dir", "must not be zero")
    try:
        arm = Arm(origin, (direction[0] / norm, direction[1] / norm), length, s_limits,
                  (math.radians(t_limits[0]), math.radians(t_limits[1])))
    except TrajectoryError as exc:
        raise f.fail(kb, exc.message) from None

    raw_motors = f.get(raw, "motors", f"{base}.motors")
    if not isinstance(raw_motors, list) or not raw_motors:
        raise f.fail(f"{base}.motors", "expected a non-empty list")
    motors = []
    for j, m in enumerate(raw_motors):
        mb = f"{base}.motors[{j}]"
        port = f.string(f.get(m, "port", f"{mb}.port"), f"{mb}.port")
        if port not in ("A", "B", "C"):
            raise f.fail(f"{mb}.port", f"expected A, B or C, got {port!r}")
        joint = f.string(f.get(m, "joint", f"{mb}.joint"), f"{mb}.joint")
        if joint not in ("s", "theta"):
            raise f.fail(f"{mb}.joint", f"expected \"s\" or \"theta\", got {joint!r}")
        ratio = f.number(f.get(m, "deg_per_unit", f"{mb}.deg_per_unit"), f"{mb}.deg_per_unit")
        if ratio == 0.0:
            raise f.fail(f"{mb}.deg_per_unit", "must not be 0")
        motors.append(MotorChannel(
            port, joint, ratio,
            f.number(m.get("offset_deg", 0.0), f"{mb}.offset_deg"),
            f.number(f.get(m, "zero_joint", f"{mb}.zero_joint"), f"{mb}.zero_joint"),
            f.integer(f.get(m, "min_deg", f"{mb}.min_deg"), f"{mb}.min_deg"),
            f.integer(f.get(m, "max_deg", f"{mb}.max_deg"), f"{mb}.max_deg"),
        ))
    ports = [m.port for m in motors]
    if len(set(ports)) != len(ports):
        raise f.fail(f"{base}.motors", "a port is used twice")
    for joint in ("s", "theta"):
        if not any(m.joint == joint for m in motors):
            raise f.fail(f"{base}.motors", f"no motor drives joint {joint!r}")

    samples = f.get(raw, "samples", f"{base}.samples")
    sb = f"{base}.samples"
    t_s = f.numbers(f.get(samples, "t_s", f"{sb}.t_s"), f"{sb}.t_s", ticks)
    if not t_s:
        raise f.fail(f"{sb}.t_s", "expected at least one sample")
    n = len(t_s)
    columns = {"t_s": t_s}
    for key in ("x", "y", "s", "theta_deg"):
        columns[key] = f.numbers(f.get(samples, key, f"{sb}.{key}"), f"{sb}.{key}", n)
    raw_step = f.get(samples, "step", f"{sb}.step")
    if not isinstance(raw_step, list) or len(raw_step) != n:
        raise f.fail(f"{sb}.step", f"expected {n} integers")
    step = [f.integer(v, f"{sb}.step[{k}]") for k, v in enumerate(raw_step)]

    raw_sp = f.get(raw, "setpoints_deg", f"{base}.setpoints_deg")
    if not isinstance(raw_sp, list) or len(raw_sp) != n:
        raise f.fail(f"{base}.setpoints_deg", f"expected {n} rows, one per tick")
    rows = []
    for k, row in enumerate(raw_sp):
        if not isinstance(row, list) or len(row) != len(motors):
            raise f.fail(f"{base}.setpoints_deg[{k}]", f"expected {len(motors)} integers, one per motor")
        rows.append([f.integer(v, f"{base}.setpoints_deg[{k}][{j}]") for j, v in enumerate(row)])
    return RobotTrajectory(
        name=name, arm=arm, branch=BranchChoice(branch, turns), motors=tuple(motors),
        t_s=frozen_array(t_s), step=frozen_array(step, np.int64),
        x=frozen_array(columns["x"]), y=frozen_array(columns["y"]),
        s=frozen_array(columns["s"]), theta_deg=frozen_array(columns["theta_deg"]),
        setpoints_deg=frozen_array(np.array(rows, dtype=np.int64).reshape(n, len(motors)), np.int64),
    )
