"""Trajectory files: `cplus.trajectory/1` JSON (read and write) and a flat CSV (write).

The JSON file is what crosses to the execution side, so loading validates every field and a
problem names it (``robots[0].samples.x: expected 111 numbers``). A file is also checked for
consistency, because an edit by hand must not reach the motors unnoticed: the times are
``k * tick_ms``, the steps ``k // points_per_step``, every sample's hand position is the
forward kinematics of its joints, the joints stay within the joint limits, the motor limits are
those of the joint limits through the gear ratios (or narrower), and every setpoint is its
sample's joint value through the gear ratio, rounded (within one degree). The CSV has one row per
(robot, tick) with the columns ``robot,tick,t_s,step,x,y,s,theta_deg`` followed by one
``<port>_deg`` column per motor port used by any robot (empty where a robot lacks that port).

`trajectory_to_dict` / `trajectory_from_dict` and `to_csv_text` are pure; `save_json`,
`save_csv` and `load_trajectory` add the file I/O.

The ``source`` mapping says where a trajectory came from; the files it names (``domain``,
``scene``) are written by `file_reference`, relative to the trajectory file's folder, and read
back by `referenced_paths`.

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
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .errors import TrajectoryError, TrajectoryFormatError
from .kinematics import Arm, BranchChoice, forward
from .model import TRAJECTORY_FORMAT, MotorChannel, RobotTrajectory, Trajectory, frozen_array

__all__ = [
    "trajectory_to_dict",
    "trajectory_from_dict",
    "to_json_text",
    "to_csv_text",
    "save_json",
    "save_csv",
    "load_trajectory",
    "file_reference",
    "referenced_paths",
]

_SAMPLE_FIELDS = ("t_s", "step", "x", "y", "s", "theta_deg")
#: Larger files are refused before reading: 3000 setpoints per brick need far less.
MAX_FILE_BYTES = 64 * 2**20
#: Setpoints beyond this cannot be motor degrees (the brick holds 16-bit values).
_MAX_SETPOINT = 2**31


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


def file_reference(target: str | Path, trajectory_path: str | Path) -> str:
    """How a trajectory file's ``source`` names another file (its domain, its scene): the
    path relative to the trajectory file's folder, with ``/``.

    Relative to the trajectory file, not to where the run started, so that the reference holds
    from any working directory (``cplus execute out/trajectory.json`` from anywhere); and
    relative rather than absolute, so that it still holds when the files move together (a
    checkout cloned elsewhere, ``out/`` copied along with the domains) and a file meant to be
    shared does not carry the user's home folder.  Absolute where no relative path exists (a
    Windows drive of its own)."""
    target = os.path.abspath(target)
    try:
        return Path(os.path.relpath(target, os.path.dirname(os.path.abspath(trajectory_path)))).as_posix()
    except ValueError:
        return Path(target).as_posix()


def referenced_paths(reference: str, trajectory_path: str | Path, *, written_before: bool = False) -> list[Path]:
    """Where a ``source`` reference (`file_reference`) may be, in the order to try: relative to
    the trajectory file's folder; with ``written_before``, then as written, relative to the
    working directory, which is what files written before references were relative to their
    trajectory file meant (they named the ``domain`` as given where the run started)."""
    paths = [Path(trajectory_path).parent / reference]
    if written_before:
        paths.append(Path(reference))
    return paths


def load_trajectory(path: str | Path) -> Trajectory:
    """Read and validate a `cplus.trajectory/1` JSON file.

    Raises
    ------
    TrajectoryFormatError
        Naming the file and the field that is missing or wrong.
    """
    p = Path(path)
    try:
        if not p.is_file():
            raise TrajectoryFormatError(f"{p}: cannot read: " + ("not a regular file" if p.exists()
                                                                else "No such file or directory"))
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise TrajectoryFormatError(f"{p}: {size} bytes, more than a trajectory can hold "
                                        f"({MAX_FILE_BYTES // 2**20} MiB)")
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise TrajectoryFormatError(f"{p}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise TrajectoryFormatError(f"{p}: not UTF-8 text: {exc.reason}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise TrajectoryFormatError(f"{p}:{exc.lineno}:{exc.colno}: invalid JSON: {exc.msg}") from None
    except RecursionError:
        raise TrajectoryFormatError(f"{p}: invalid JSON: nested too deeply for a trajectory") from None
    except ValueError as exc:  # e.g. an integer of thousands of digits
        raise TrajectoryFormatError(f"{p}: invalid JSON: {exc}") from None
    return trajectory_from_dict(data, str(p))


MAX_NUMBER = 1e9
"""The largest magnitude of a number in a trajectory file (seconds, grid units, degrees): the
scene's bound (:data:`trajectory.toml_locations.MAX_NUMBER`)."""

MAX_INTEGER = 2 ** 31 - 1
"""The largest magnitude of an integer field (an int32) unless the field says less."""

MAX_TURNS = 4
"""How many whole turns an arm angle may be lifted by (``kinematics.turns``): joint limits span
less than a turn, so the inverse kinematics needs 0 or 1 either way; beyond a few it is a
hand-edited file (``10**30`` turns would only overflow the angle)."""


def _shown(value: Any) -> str:
    """A JSON value for a message: a huge integer by its number of digits, long text cut."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10 ** 15:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


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
        """A finite number of magnitude at most :data:`MAX_NUMBER` (an integer is compared as
        it is: ``math.isfinite(10**400)`` raises ``OverflowError``)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                (isinstance(value, float) and not math.isfinite(value)):
            raise self.fail(field, f"expected a finite number, got {_shown(value)}")
        if not -MAX_NUMBER <= value <= MAX_NUMBER:
            raise self.fail(field, f"expected a number in {-MAX_NUMBER:g}..{MAX_NUMBER:g}, got {_shown(value)}")
        return float(value)

    def integer(self, value: Any, field: str, lo: int = -MAX_INTEGER, hi: int = MAX_INTEGER) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(field, f"expected an integer, got {_shown(value)}")
        if not lo <= value <= hi:
            raise self.fail(field, f"expected an integer in {lo}..{hi}, got {_shown(value)}")
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
    for i, robot in enumerate(robots):
        _check_consistent(f, robot, f"robots[{i}]", tick_ms, pps)
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
    turns = f.integer(kin.get("turns", 0), f"{kb}.turns", -MAX_TURNS, MAX_TURNS)
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
        values = [f.integer(v, f"{base}.setpoints_deg[{k}][{j}]") for j, v in enumerate(row)]
        for j, v in enumerate(values):
            if abs(v) >= _MAX_SETPOINT:
                raise f.fail(f"{base}.setpoints_deg[{k}][{j}]", f"{v} is not a motor angle")
        rows.append(values)
    return RobotTrajectory(
        name=name, arm=arm, branch=BranchChoice(branch, turns), motors=tuple(motors),
        t_s=frozen_array(t_s), step=frozen_array(step, np.int64),
        x=frozen_array(columns["x"]), y=frozen_array(columns["y"]),
        s=frozen_array(columns["s"]), theta_deg=frozen_array(columns["theta_deg"]),
        setpoints_deg=frozen_array(np.array(rows, dtype=np.int64).reshape(n, len(motors)), np.int64),
    )


def _check_consistent(f: _Fields, r: RobotTrajectory, base: str, tick_ms: int, pps: int) -> None:
    """Refuse a file whose parts contradict each other (see the module docstring)."""
    sb = f"{base}.samples"
    n = len(r.t_s)
    expected_t = np.arange(n) * tick_ms / 1000.0
    bad = np.flatnonzero(np.abs(r.t_s - expected_t) > 1e-6)
    if len(bad):
        k = int(bad[0])
        raise f.fail(f"{sb}.t_s[{k}]", f"{r.t_s[k]:g} s, expected {expected_t[k]:g} s: sample k is "
                     f"at k * tick_ms ({tick_ms} ms), times must increase by one tick")
    m = (n - 1) // pps
    expected_step = np.minimum(np.arange(n) // pps, m)
    bad = np.flatnonzero(r.step != expected_step)
    if len(bad):
        k = int(bad[0])
        raise f.fail(f"{sb}.step[{k}]", f"{int(r.step[k])}, expected {int(expected_step[k])} "
                     f"({pps} samples per step)")
    arm = r.arm
    s_lo, s_hi = arm.s_limits
    t_lo, t_hi = (math.degrees(t) for t in arm.theta_limits_rad)
    tol = 1e-6 * arm.scale
    for key, values, lo, hi in (("s", r.s, s_lo, s_hi), ("theta_deg", r.theta_deg, t_lo, t_hi)):
        bad = np.flatnonzero((values < lo - tol) | (values > hi + tol))
        if len(bad):
            k = int(bad[0])
            raise f.fail(f"{sb}.{key}[{k}]", f"{values[k]:g} is outside the joint limits "
                         f"[{lo:g}, {hi:g}]")
    x, y = forward(arm, r.s, np.radians(r.theta_deg))
    miss = np.hypot(x - r.x, y - r.y)
    bad = np.flatnonzero(miss > 1e-4 * arm.scale)
    if len(bad):
        k = int(bad[0])
        raise f.fail(f"{sb}.x[{k}]", f"({r.x[k]:g}, {r.y[k]:g}) is not where the joints s, theta of "
                     f"sample {k} put the hand ({float(x[k]):.4g}, {float(y[k]):.4g})")
    for j, motor in enumerate(r.motors):
        mb = f"{base}.motors[{j}]"
        joint = r.s if motor.joint == "s" else r.theta_deg
        if abs(motor.zero_joint - float(joint[0])) > tol:
            raise f.fail(f"{mb}.zero_joint", f"{motor.zero_joint:g}, but the first sample's "
                         f"{motor.joint} is {float(joint[0]):g} (the encoders count from tick 0)")
        lo, hi = (s_lo, s_hi) if motor.joint == "s" else (t_lo, t_hi)
        ends = sorted(motor.offset_deg + motor.deg_per_unit * (v - motor.zero_joint) for v in (lo, hi))
        lo_deg, hi_deg = math.ceil(ends[0] - 1e-9), math.floor(ends[1] + 1e-9)
        if motor.min_deg < lo_deg or motor.max_deg > hi_deg or motor.min_deg > motor.max_deg:
            raise f.fail(f"{mb}", f"motor limits [{motor.min_deg}, {motor.max_deg}] deg are not within "
                         f"[{lo_deg}, {hi_deg}], the joint limits through the gear ratio")
        column = r.setpoints_deg[:, j]
        bad = np.flatnonzero((column < motor.min_deg) | (column > motor.max_deg))
        if len(bad):
            k = int(bad[0])
            raise f.fail(f"{base}.setpoints_deg[{k}][{j}]", f"{int(column[k])} deg is outside motor "
                         f"{motor.port}'s limits [{motor.min_deg}, {motor.max_deg}]")
        exact = motor.motor_deg(joint)
        bad = np.flatnonzero(np.abs(column - exact) > 1.0 + 1e-6)
        if len(bad):
            k = int(bad[0])
            raise f.fail(f"{base}.setpoints_deg[{k}][{j}]", f"{int(column[k])} deg, but sample {k} "
                         f"puts motor {motor.port} at {float(exact[k]):.1f} deg")
