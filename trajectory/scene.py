"""Scene files (`cplus.scene/1`): the geometry a plan is checked against and executed in.

A scene says where the obstacles are, where each robot's rail runs and how long its arm is,
which motors drive which joint through which gear ratio, how long the payload is and how much
its squared length may vary, and which domain fluents give each coordinate (the *bindings*:
robot ``r1``'s end-effector is ``xpos(r1)``, ``ypos(r1)``). The scene also provides the
``collision`` external to the grounder, so the domain file and the geometry cannot disagree.

`parse_scene` validates everything and reports the first problem as a `SceneError` located at
``file:line:col`` (TOML positions come from `toml_locations`). `load_scene` is the same for a
path. The full schema is in ``docs/trajectory.md``.

>>> scene = parse_scene(EXAMPLE_SCENE, "example.toml")
>>> scene.collision(0, 0, 4, 0), scene.collision(0, 0, 0, 3)
(True, False)
>>> scene.robot("r1").x.fluent
'xpos(r1)'
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import shapely
from shapely.geometry import Polygon
from shapely.validation import explain_validity

from ._format import fmt as _fmt
from .errors import JointLimitError, Location, SceneError, UnreachableError
from .geometry import segment_geometry
from .kinematics import Arm, choices_at, point_problem
from .toml_locations import (
    KeyPath,
    KeyPathReader,
    integer_problem,
    kind_of,
    locate_keys,
    nearest_location,
    number_problem,
    parse_toml,
    toml_error,
)
from .workspace import Workspace

__all__ = [
    "SCENE_FORMAT",
    "Binding",
    "Grid",
    "Obstacle",
    "Motor",
    "Robot",
    "PayloadEnd",
    "Payload",
    "Scene",
    "parse_scene",
    "load_scene",
    "check_reachable",
    "EXAMPLE_SCENE",
]

SCENE_FORMAT = "cplus.scene/1"
PORTS = ("A", "B", "C")
JOINTS = ("s", "theta")

_NAME = re.compile(r"[a-z][A-Za-z0-9_]*\Z")
_FLUENT = re.compile(r"[a-z][A-Za-z0-9_]*(\([A-Za-z0-9_]+(,[A-Za-z0-9_]+)*\))?\Z")


@dataclass(frozen=True, slots=True)
class Binding:
    """A ground fluent of the domain (``"xpos(r1)"``) that gives one coordinate.

    ``location`` is where the scene names it, so the planner's glue can report
    ``scene.toml:L:C: error: binding names unknown fluent ...``.
    """

    fluent: str
    location: Location


@dataclass(frozen=True, slots=True)
class Grid:
    """The integer grid the domain plans on (inclusive bounds), and its real-world size."""

    x_min: int
    x_max: int
    y_min: int
    y_max: int
    unit_mm: float | None = None

    def points(self) -> list[tuple[int, int]]:
        """Every grid point, x-major."""
        return [(x, y) for x in range(self.x_min, self.x_max + 1)
                for y in range(self.y_min, self.y_max + 1)]


@dataclass(frozen=True, slots=True)
class Obstacle:
    """A closed, simple polygon with a name (for messages and plots)."""

    name: str
    polygon: Polygon
    location: Location


@dataclass(frozen=True, slots=True)
class Motor:
    """One NXT motor driving one joint.

    ``deg_per_unit`` is the gear ratio: motor degrees per grid unit of ``s``, or per degree of
    ``theta``; negative when the motor is mounted reversed. ``offset_deg`` is what the motor
    reads at the start configuration (usually 0: encoders are reset there).
    """

    port: str
    joint: str
    deg_per_unit: float
    offset_deg: float
    location: Location


@dataclass(frozen=True, slots=True)
class Robot:
    """A rail-mounted arm: its kinematics, motors, bindings and preferred IK branch."""

    name: str
    arm: Arm
    motors: tuple[Motor, ...]
    x: Binding
    y: Binding
    branch: int | None
    location: Location


@dataclass(frozen=True, slots=True)
class PayloadEnd:
    """One end of the payload and the fluents giving its coordinates."""

    name: str
    x: Binding
    y: Binding


@dataclass(frozen=True, slots=True)
class Payload:
    """The payload: nominal length and the domain's tolerance on its *squared* length.

    The allowed squared length is ``[length**2 - tolerance_sq, length**2 + tolerance_sq]``,
    the same convention as the domain's ``linklengthsq`` and ``tolerance`` macros.
    """

    length: float
    tolerance_sq: float
    holds: Binding
    ends: tuple[PayloadEnd, PayloadEnd]
    location: Location

    @property
    def length_sq_band(self) -> tuple[float, float]:
        """The closed interval of allowed squared lengths."""
        nominal = self.length * self.length
        return nominal - self.tolerance_sq, nominal + self.tolerance_sq


@dataclass(frozen=True, slots=True)
class Scene:
    """A validated scene. Build it with `parse_scene` or `load_scene`."""

    file: str
    name: str
    grid: Grid
    obstacles: tuple[Obstacle, ...]
    robots: tuple[Robot, ...]
    payload: Payload
    workspace: Workspace = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        grid = (self.grid.x_min, self.grid.x_max, self.grid.y_min, self.grid.y_max)
        object.__setattr__(self, "workspace", Workspace([o.polygon for o in self.obstacles], grid))

    def robot(self, name: str) -> Robot:
        """The robot called ``name``; `KeyError` if there is none."""
        for robot in self.robots:
            if robot.name == name:
                return robot
        raise KeyError(name)

    @property
    def robot_names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.robots)

    @property
    def end_names(self) -> tuple[str, str]:
        return (self.payload.ends[0].name, self.payload.ends[1].name)

    def collision(self, x1: float, y1: float, x2: float, y2: float) -> bool:
        """The ``collision(X1,Y1,X2,Y2)`` external of the payload domain.

        True when the closed segment from (x1, y1) to (x2, y2) (a point when both ends
        coincide) meets the interior or the boundary of any obstacle.
        """
        return self.workspace.collision(x1, y1, x2, y2)

    def obstacles_met(self, x1: float, y1: float, x2: float, y2: float) -> list[str]:
        """Names of the obstacles the closed segment (x1, y1)-(x2, y2) meets (a point when
        both ends coincide), in the scene's order."""
        hit = set(self.workspace.hits(segment_geometry((x1, y1), (x2, y2))))
        return [o.name for k, o in enumerate(self.obstacles) if k in hit]

    def externals(self) -> dict[str, Any]:
        """The externals this scene provides to the grounder, by name (``collision`` is the
        workspace's own method: one call frame less on the grounder's hottest path)."""
        return {"collision": self.workspace.collision}

    def reachable(self, robot: str, x: float, y: float) -> bool:
        """True when some IK branch holds ``robot``'s end-effector at (x, y) within limits."""
        return bool(choices_at(self.robot(robot).arm, x, y))

    def bindings(self) -> tuple[tuple[str, Binding], ...]:
        """Every binding with what it binds (``"r1.x"``, ``"pl1.y"``, ``"payload.holds"``)."""
        out: list[tuple[str, Binding]] = []
        for robot in self.robots:
            out += [(f"{robot.name}.x", robot.x), (f"{robot.name}.y", robot.y)]
        for end in self.payload.ends:
            out += [(f"{end.name}.x", end.x), (f"{end.name}.y", end.y)]
        out.append(("payload.holds", self.payload.holds))
        return tuple(out)


def check_reachable(
    scene: Scene, robot: str, point: Sequence[float], what: str, location: Location | None = None
) -> None:
    """Raise a located error unless ``robot`` can hold its end-effector at ``point``.

    ``what`` names the point in the message (``"start"``, ``"goal"``). The error points at
    ``location`` when given (e.g. the query line), else at the robot's table in the scene.

    Raises
    ------
    UnreachableError
        The point is farther from the rail than the arm is long.
    JointLimitError
        The point is within reach, but both IK branches break a joint limit there.
    """
    rob = scene.robot(robot)
    x, y = float(point[0]), float(point[1])
    if choices_at(rob.arm, x, y):
        return
    problems = [point_problem(rob.arm, x, y, b) for b in (1, -1)]
    where = location if location is not None else rob.location
    text = f"({_fmt(x)}, {_fmt(y)})"
    first = problems[0]
    assert first is not None
    if first[0]:
        raise UnreachableError(f"robot {robot} cannot reach the {what} {text}: {first[1]}", where)
    detail = "; ".join(f"branch {b:+d}: {p[1]}" for b, p in zip((1, -1), problems) if p is not None)
    raise JointLimitError(f"robot {robot} cannot hold the {what} {text} within its joint limits: "
                          f"{detail}", where)


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene file (see `parse_scene`)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(f"cannot read scene file: {exc.strerror or exc}", Location(str(p), 1, 1)) from None
    except UnicodeDecodeError as exc:
        raise SceneError(f"scene file is not UTF-8 text: {exc.reason}", Location(str(p), 1, 1)) from None
    return parse_scene(text, str(p))


def parse_scene(text: str, filename: str = "scene.toml") -> Scene:
    """Parse and validate the text of a `cplus.scene/1` file.

    Raises
    ------
    SceneError
        On the first problem, located at ``filename:line:col``.
    """
    try:
        data = parse_toml(text)
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        raise SceneError(message, Location(filename, line, col)) from None
    return _Reader(filename, data, locate_keys(text)).scene()


# ---------------------------------------------------------------------------------------------


class _Reader(KeyPathReader):
    """Reads the parsed TOML with type checks; every complaint names its position."""

    def __init__(self, filename: str, data: dict[str, Any], locations: dict[KeyPath, tuple[int, int]]):
        super().__init__(data, locations)
        self.filename = filename

    # -- helpers ---------------------------------------------------------------------------
    def loc(self, path: KeyPath) -> Location:
        line, col = nearest_location(self.locations, path)
        return Location(self.filename, line, col)

    def fail(self, path: KeyPath, message: str) -> SceneError:
        return SceneError(message, self.loc(path))

    def table(self, path: KeyPath, allowed: Sequence[str] | None = None) -> dict[str, Any]:
        value = self.require(path)
        if not isinstance(value, dict):
            raise self.fail(path, f"{self.show(path)} must be a table")
        if allowed is not None:
            for key in value:
                if key not in allowed:
                    raise self.fail(path + (key,), f"unknown field '{key}' in {self.show(path)}; "
                                    f"expected one of: {', '.join(allowed)}")
        return value

    def number(self, path: KeyPath, default: float | None = None) -> float:
        if default is not None and not self.has(path):
            return default
        value = self.require(path)
        problem = number_problem(value)
        if problem is not None:
            raise self.fail(path, f"{self.show(path)} {problem}")
        return float(value)

    def integer(self, path: KeyPath) -> int:
        value = self.require(path)
        problem = integer_problem(value)
        if problem is not None:
            raise self.fail(path, f"{self.show(path)} {problem}")
        return value

    def string(self, path: KeyPath, default: str | None = None) -> str:
        if default is not None and not self.has(path):
            return default
        value = self.require(path)
        if not isinstance(value, str):
            raise self.fail(path, f"{self.show(path)} must be a string, not {kind_of(value)}")
        return value

    def pair(self, path: KeyPath) -> tuple[float, float]:
        value = self.require(path)
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(path, f"{self.show(path)} must be a pair of numbers [a, b]")
        return self.number(path + (0,)), self.number(path + (1,))

    def binding(self, path: KeyPath) -> Binding:
        text = "".join(self.string(path).split())
        if not _FLUENT.match(text):
            raise self.fail(path, f"{self.show(path)} = {self.get(path)!r} is not a ground fluent "
                            "such as \"xpos(r1)\"")
        return Binding(text, self.loc(path))

    # -- sections --------------------------------------------------------------------------
    def scene(self) -> Scene:
        top = self.data
        allowed = ("format", "name", "grid", "obstacles", "robots", "payload")
        for key in top:
            if key not in allowed:
                raise self.fail((key,), f"unknown top-level field '{key}'; expected one of: "
                                f"{', '.join(allowed)}")
        fmt = self.string(("format",))
        if fmt != SCENE_FORMAT:
            raise self.fail(("format",), f"unsupported scene format {fmt!r}; expected {SCENE_FORMAT!r}")
        name = self.string(("name",), default=Path(self.filename).stem)
        grid = self.grid()
        obstacles = self.obstacles()
        robots = self.robots()
        payload = self.payload()
        self.unique_bindings(robots, payload)
        return Scene(self.filename, name, grid, obstacles, robots, payload)

    def grid(self) -> Grid:
        self.table(("grid",), ("x_min", "x_max", "y_min", "y_max", "unit_mm"))
        x_min, x_max = self.integer(("grid", "x_min")), self.integer(("grid", "x_max"))
        y_min, y_max = self.integer(("grid", "y_min")), self.integer(("grid", "y_max"))
        if x_min >= x_max:
            raise self.fail(("grid", "x_max"), f"grid.x_max ({x_max}) must exceed grid.x_min ({x_min})")
        if y_min >= y_max:
            raise self.fail(("grid", "y_max"), f"grid.y_max ({y_max}) must exceed grid.y_min ({y_min})")
        unit: float | None = None
        if self.has(("grid", "unit_mm")):
            unit = self.number(("grid", "unit_mm"))
            if unit <= 0:
                raise self.fail(("grid", "unit_mm"), f"grid.unit_mm must be positive, not {_fmt(unit)}")
        return Grid(x_min, x_max, y_min, y_max, unit)

    def obstacles(self) -> tuple[Obstacle, ...]:
        if not self.has(("obstacles",)):
            return ()
        items = self.get(("obstacles",))
        if not isinstance(items, list):
            raise self.fail(("obstacles",), "obstacles must be an array of tables ([[obstacles]])")
        out: list[Obstacle] = []
        names: set[str] = set()
        for i in range(len(items)):
            base: KeyPath = ("obstacles", i)
            self.table(base, ("name", "points"))
            name = self.string(base + ("name",), default=f"obstacle {i + 1}")
            if name in names:
                raise self.fail(base + ("name",), f"obstacle name {name!r} is used twice")
            names.add(name)
            out.append(Obstacle(name, self.polygon(base + ("points",), name), self.loc(base)))
        return tuple(out)

    def polygon(self, path: KeyPath, name: str) -> Polygon:
        raw = self.require(path)
        if not isinstance(raw, list):
            raise self.fail(path, f"points of obstacle {name!r} must be an array of [x, y] pairs")
        points = [self.pair(path + (k,)) for k in range(len(raw))]
        if len(points) < 4:
            raise self.fail(path, f"obstacle {name!r} needs at least 3 corners and the first "
                            f"repeated at the end to close it; it has {len(points)} points")
        if points[0] != points[-1]:
            raise self.fail(path + (len(points) - 1,),
                            f"obstacle {name!r} is not closed: its last point "
                            f"({_fmt(points[-1][0])}, {_fmt(points[-1][1])}) differs from its first "
                            f"({_fmt(points[0][0])}, {_fmt(points[0][1])}); repeat the first point "
                            "at the end")
        polygon = Polygon(points)
        if polygon.convex_hull.area <= 0.0:
            raise self.fail(path, f"obstacle {name!r} has zero area: its corners are on one line")
        if not polygon.is_valid:
            reason = explain_validity(polygon)
            m = re.match(r"(.*)\[([-\d.e+]+) ([-\d.e+]+)\]", reason)
            where = f" at ({_fmt(float(m.group(2)))}, {_fmt(float(m.group(3)))})" if m else ""
            what = m.group(1).strip().lower() if m else reason.lower()
            raise self.fail(path, f"obstacle {name!r} is not a simple polygon: {what}{where}")
        return shapely.normalize(polygon)

    def robots(self) -> tuple[Robot, ...]:
        robots = self.table(("robots",))
        if not robots:
            raise self.fail(("robots",), "the scene defines no robots")
        return tuple(self.robot(name) for name in robots)

    def robot(self, name: str) -> Robot:
        base: KeyPath = ("robots", name)
        if not _NAME.match(name):
            raise self.fail(base, f"robot name {name!r} must be a domain object name "
                            "(a lowercase letter, then letters, digits or '_')")
        self.table(base, ("rail_origin", "rail_dir", "arm_length", "s_limits", "theta_limits_deg",
                          "branch", "bindings", "motors"))
        origin = self.pair(base + ("rail_origin",))
        dx, dy = self.pair(base + ("rail_dir",))
        norm = math.hypot(dx, dy)
        if norm == 0.0:
            raise self.fail(base + ("rail_dir",), f"robots.{name}.rail_dir must not be zero")
        length = self.number(base + ("arm_length",))
        if length <= 0:
            raise self.fail(base + ("arm_length",), f"robots.{name}.arm_length must be positive, "
                            f"not {_fmt(length)}")
        s_lo, s_hi = self.pair(base + ("s_limits",))
        if s_lo >= s_hi:
            raise self.fail(base + ("s_limits",), f"robots.{name}.s_limits must be [min, max] with "
                            f"min < max, not [{_fmt(s_lo)}, {_fmt(s_hi)}]")
        t_lo, t_hi = self.pair(base + ("theta_limits_deg",))
        if not (t_lo < t_hi and t_hi - t_lo < 360.0):
            raise self.fail(base + ("theta_limits_deg",), f"robots.{name}.theta_limits_deg must be "
                            f"[min, max] with min < max < min + 360, not [{_fmt(t_lo)}, {_fmt(t_hi)}]")
        branch: int | None = None
        if self.has(base + ("branch",)):
            raw = self.get(base + ("branch",))
            if isinstance(raw, bool) or raw not in (1, -1):
                raise self.fail(base + ("branch",), f"robots.{name}.branch must be 1 or -1, "
                                f"not {raw!r}")
            branch = int(raw)
        arm = Arm((origin[0], origin[1]), (dx / norm, dy / norm), length, (s_lo, s_hi),
                  (math.radians(t_lo), math.radians(t_hi)))
        self.table(base + ("bindings",), ("x", "y"))
        x = self.binding(base + ("bindings", "x"))
        y = self.binding(base + ("bindings", "y"))
        return Robot(name, arm, self.motors(name), x, y, branch, self.loc(base))

    def motors(self, robot: str) -> tuple[Motor, ...]:
        path: KeyPath = ("robots", robot, "motors")
        items = self.require(path)
        if not isinstance(items, list) or not items:
            raise self.fail(path, f"robots.{robot}.motors must be a non-empty array of tables "
                            f"([[robots.{robot}.motors]])")
        out: list[Motor] = []
        for k in range(len(items)):
            base = path + (k,)
            self.table(base, ("port", "joint", "deg_per_unit", "offset_deg"))
            port = self.string(base + ("port",))
            if port not in PORTS:
                raise self.fail(base + ("port",), f"motor port must be one of A, B, C, not {port!r}")
            if any(m.port == port for m in out):
                raise self.fail(base + ("port",), f"robot {robot} uses port {port} twice")
            joint = self.string(base + ("joint",))
            if joint not in JOINTS:
                raise self.fail(base + ("joint",), f"motor joint must be \"s\" or \"theta\", "
                                f"not {joint!r}")
            ratio = self.number(base + ("deg_per_unit",))
            if ratio == 0.0:
                raise self.fail(base + ("deg_per_unit",), "deg_per_unit (the gear ratio) must not be 0")
            offset = self.number(base + ("offset_deg",), default=0.0)
            out.append(Motor(port, joint, ratio, offset, self.loc(base)))
        for joint in JOINTS:
            if not any(m.joint == joint for m in out):
                raise self.fail(path, f"robot {robot} has no motor driving joint {joint!r}")
        return tuple(out)

    def payload(self) -> Payload:
        base: KeyPath = ("payload",)
        self.table(base, ("length", "tolerance_sq", "holds", "ends"))
        length = self.number(base + ("length",))
        if length <= 0:
            raise self.fail(base + ("length",), f"payload.length must be positive, not {_fmt(length)}")
        tol = self.number(base + ("tolerance_sq",))
        if not 0.0 <= tol < length * length:
            raise self.fail(base + ("tolerance_sq",), f"payload.tolerance_sq must be at least 0 and "
                            f"below length^2 = {_fmt(length * length)}, not {_fmt(tol)}")
        if self.has(base + ("holds",)):
            holds_text = self.string(base + ("holds",))
            if not _NAME.match(holds_text):
                raise self.fail(base + ("holds",), f"payload.holds must name a Boolean fluent "
                                f"constant such as \"on\", not {holds_text!r}")
            holds = Binding(holds_text, self.loc(base + ("holds",)))
        else:
            holds = Binding("on", self.loc(base))
        ends = self.table(base + ("ends",))
        if len(ends) != 2:
            raise self.fail(base + ("ends",), f"the payload must have exactly 2 ends, not {len(ends)}")
        out = []
        for name in ends:
            path = base + ("ends", name)
            if not _NAME.match(name):
                raise self.fail(path, f"payload end name {name!r} must be a domain object name")
            if self.has(("robots", name)):
                raise self.fail(path, f"payload end {name!r} has the name of a robot")
            self.table(path, ("x", "y"))
            out.append(PayloadEnd(name, self.binding(path + ("x",)), self.binding(path + ("y",))))
        return Payload(length, tol, holds, (out[0], out[1]), self.loc(base))

    def unique_bindings(self, robots: Sequence[Robot], payload: Payload) -> None:
        seen: dict[str, str] = {}
        pairs = [(f"{r.name}.{axis}", getattr(r, axis)) for r in robots for axis in ("x", "y")]
        pairs += [(f"{e.name}.{axis}", getattr(e, axis)) for e in payload.ends for axis in ("x", "y")]
        for what, binding in pairs:
            if binding.fluent in seen:
                raise SceneError(f"fluent {binding.fluent} is bound twice: to {seen[binding.fluent]} "
                                 f"and to {what}", binding.location)
            seen[binding.fluent] = what




EXAMPLE_SCENE = '''
format = "cplus.scene/1"
[grid]
x_min = 0
x_max = 6
y_min = 0
y_max = 4
[[obstacles]]
name = "post"
points = [[2, -1], [3, -1], [3, 1], [2, 1], [2, -1]]
[robots.r1]
rail_origin = [0, -1]
rail_dir = [1, 0]
arm_length = 3
s_limits = [-4, 10]
theta_limits_deg = [5, 175]
bindings = { x = "xpos(r1)", y = "ypos(r1)" }
motors = [ { port = "A", joint = "s", deg_per_unit = 90 },
           { port = "B", joint = "theta", deg_per_unit = 5 } ]
[robots.r2]
rail_origin = [0, 5]
rail_dir = [1, 0]
arm_length = 3
s_limits = [-4, 10]
theta_limits_deg = [-175, -5]
bindings = { x = "xpos(r2)", y = "ypos(r2)" }
motors = [ { port = "A", joint = "s", deg_per_unit = 90 },
           { port = "B", joint = "theta", deg_per_unit = 5 } ]
[payload]
length = 3
tolerance_sq = 1
ends.pl1 = { x = "xpay(pl1)", y = "ypay(pl1)" }
ends.pl2 = { x = "xpay(pl2)", y = "ypay(pl2)" }
'''
"""A small, complete scene used by the examples and the tests."""
