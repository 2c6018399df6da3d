"""World files (``cplus.world/1``): the track an emulated delivery robot drives on.

A world file is TOML beside a domain (``domains/delivery/world.toml``); it describes
what the emulator's sensors read (:class:`nxt_link.emulator.world.WorldSpec`): a black line along
a polyline, landmarks (landmark *n* = *n* bright bars across the line), where the robot
starts, which ports the sensors and motors are on, touch-sensor presses at given times or
at landmarks, and stretches where the robot gets stuck. Lengths in millimetres, times in
seconds, light in percent (as the NXT light sensor reports it)::

    format = "cplus.world/1"
    name = "delivery"
    seed = 1                          # noise and fault randomness (optional)
    noise_percent = 1.0               # light sensor noise, standard deviation

    [track]
    points = [[0, 0], [4000, 0]]      # the line's centre, a polyline
    width_mm = 20                     # default 20
    line_percent = 30                 # what the sensor reads on the line (default 30)
    floor_percent = 60                # ... on the floor (default 60)

    [[landmarks]]
    number = 1                        # 1..15: that many bars
    at_mm = 400                       # where the first bar starts, along the track
    name = "office1"                  # optional
    misses = 0                        # the robot overlooks it the first N passes
    visible = true                    # false: always overlooked

    [start]
    landmark = 1                      # or at_mm = 350
    direction = "forward"             # or "backward"

    [ports]                           # optional; these are the defaults
    touch = 1                         # input ports 1..4
    light = 3
    left = "B"                        # output ports A..C
    right = "C"
    tray = "A"

    [robot]                           # optional geometry
    wheel_diameter_mm = 56
    axle_track_mm = 112
    sensor_ahead_mm = 70
    spot_radius_mm = 4

    [markers]                         # optional: how landmarks look
    bar_mm = 10
    bar_percent = 90
    faint_percent = 62
    half_width_mm = 40

    [[presses]]                       # at a simulated time ...
    at_s = 12.0
    hold_s = 0.3
    [[presses]]                       # ... or after the robot came to rest at a landmark
    at_landmark = 3
    visit = 1
    delay_s = 1.0

    [[blocked]]                       # the robot gets stuck entering this stretch
    from_mm = 2600
    to_mm = 2700
    times = 1                         # clears after blocking it once (default: never)

Every problem is a :class:`WorldFileError` located at ``file:line:col``.
"""
from __future__ import annotations

import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import nxt_link.emulator.world as w
from cplus.errors import CPlusError, Location, Source
from nxt_link.emulator import legolog_constants
from trajectory.toml_locations import (
    MAX_INTEGER,
    MAX_NUMBER,
    KeyPath,
    KeyPathReader,
    integer_problem,
    locate_keys,
    nearest_location,
    number_problem,
    parse_toml,
    toml_error,
)

__all__ = ["WORLD_FORMAT", "WorldFileError", "load_world", "parse_world"]

WORLD_FORMAT = "cplus.world/1"

_TOP = ("format", "name", "seed", "noise_percent", "track", "landmarks", "start", "ports",
        "robot", "markers", "presses", "blocked")


class WorldFileError(CPlusError):
    """A world file is malformed or inconsistent."""


def load_world(path: str | Path) -> w.WorldSpec:
    """Read and validate a world file; its ports must be those ``cplus_legolog.rxe`` uses.

    Raises:
        WorldFileError: located at ``file:line:col``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise WorldFileError(f"cannot read world file {p}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise WorldFileError(f"world file {p} is not UTF-8 text: {exc.reason}") from None
    return parse_world(text, str(p))


def parse_world(text: str, filename: str = "world.toml") -> w.WorldSpec:
    """Parse and validate the text of a ``cplus.world/1`` file (see the module docstring)."""
    source = Source(filename, text)
    try:
        data = parse_toml(text)
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        raise WorldFileError(message, _at(source, line, col)) from None
    return _Reader(source, data, locate_keys(text)).world()


def _at(source: Source, line: int, col: int) -> Location:
    starts = [0] + [i + 1 for i, ch in enumerate(source.text) if ch == "\n"]
    offset = starts[min(line, len(starts)) - 1] + col - 1
    offset = min(offset, len(source.text))
    return Location(source, offset, offset + 1)


class _Reader(KeyPathReader):
    """Reads the parsed TOML with type checks; every complaint names its position."""

    def __init__(self, source: Source, data: dict[str, Any],
                 locations: dict[KeyPath, tuple[int, int]]) -> None:
        super().__init__(data, locations)
        self.source = source

    # -- helpers ------------------------------------------------------------------------------

    def fail(self, path: KeyPath, message: str) -> WorldFileError:
        line, col = nearest_location(self.locations, path)
        return WorldFileError(message, _at(self.source, line, col))

    def table(self, path: KeyPath, allowed: Sequence[str]) -> dict[str, Any]:
        value = self.require(path)
        if not isinstance(value, dict):
            raise self.fail(path, f"{self.show(path)} must be a table")
        for key in value:
            if key not in allowed:
                raise self.fail(path + (key,), f"unknown field '{key}' in {self.show(path)}; "
                                               f"expected one of: {', '.join(allowed)}")
        return value

    def tables(self, key: str, allowed: Sequence[str]) -> list[KeyPath]:
        if not self.has((key,)):
            return []
        items = self.get((key,))
        if not isinstance(items, list):
            raise self.fail((key,), f"{key} must be an array of tables ([[{key}]])")
        paths: list[KeyPath] = [(key, i) for i in range(len(items))]
        for p in paths:
            self.table(p, allowed)
        return paths

    def number(self, path: KeyPath, default: float | None = None, lo: float = -MAX_NUMBER) -> float:
        """A finite number in ``lo..MAX_NUMBER``: every length, time and percentage of a world
        is one, and lengths and times are never negative (``lo=0``)."""
        if default is not None and not self.has(path):
            return default
        value = self.require(path)
        problem = number_problem(value, lo)
        if problem is not None:
            raise self.fail(path, f"{self.show(path)} {problem}")
        return float(value)

    def optional_number(self, path: KeyPath, lo: float = -MAX_NUMBER) -> float | None:
        return self.number(path, lo=lo) if self.has(path) else None

    def integer(self, path: KeyPath, default: int | None = None, lo: int = -MAX_INTEGER,
                hi: int = MAX_INTEGER) -> int:
        if default is not None and not self.has(path):
            return default
        value = self.require(path)
        problem = integer_problem(value, lo, hi)
        if problem is not None:
            raise self.fail(path, f"{self.show(path)} {problem}")
        return value

    def optional_integer(self, path: KeyPath, lo: int = -MAX_INTEGER, hi: int = MAX_INTEGER) -> int | None:
        return self.integer(path, lo=lo, hi=hi) if self.has(path) else None

    def string(self, path: KeyPath, default: str | None = None) -> str:
        if default is not None and not self.has(path):
            return default
        value = self.require(path)
        if not isinstance(value, str):
            raise self.fail(path, f"{self.show(path)} must be a string, not {_kind(value)}")
        return value

    def boolean(self, path: KeyPath, default: bool) -> bool:
        if not self.has(path):
            return default
        value = self.get(path)
        if not isinstance(value, bool):
            raise self.fail(path, f"{self.show(path)} must be true or false, not {_kind(value)}")
        return value

    def build(self, path: KeyPath, make: Callable[..., Any], *args: Any, **kw: Any) -> Any:
        """Call a constructor that validates; its ValueError becomes a located error."""
        try:
            return make(*args, **kw)
        except ValueError as exc:
            raise self.fail(path, f"{self.show(path)}: {exc}" if path else str(exc)) from None

    # -- sections -------------------------------------------------------------------------------

    def world(self) -> w.WorldSpec:
        for key in self.data:
            if key not in _TOP:
                raise self.fail((key,), f"unknown top-level field '{key}'; expected one of: "
                                        f"{', '.join(_TOP)}")
        fmt = self.string(("format",))
        if fmt != WORLD_FORMAT:
            raise self.fail(("format",), f"unsupported world format {fmt!r}; expected "
                                         f"{WORLD_FORMAT!r}")
        name = self.string(("name",), default=Path(self.source.path).stem)
        seed = self.optional_integer(("seed",))
        noise = self.number(("noise_percent",), default=1.0)
        if not 0 <= noise <= 20:
            raise self.fail(("noise_percent",), f"noise_percent must be in 0..20, not {noise:g}")
        track = self.track()
        markers = self.markers()
        landmarks = self.landmarks()
        for lm, path in zip(landmarks, self._landmark_paths.values()):
            end = lm.at_mm + (2 * lm.number - 1) * markers.bar_mm
            if lm.at_mm < 0 or end > track.length_mm:
                raise self.fail(path + ("at_mm",), f"landmark {lm.number} ({lm.at_mm:g}..{end:g}"
                                                   f" mm) is not on the track (0..{track.length_mm:g}"
                                                   " mm)")
        start = self.start()
        blocked = self.blocked()
        # what only the whole world can check (the start on the track, not in a blocked
        # stretch) is located at the start
        return self.build(("start",), w.WorldSpec,
                          track=track, landmarks=landmarks, start=start, ports=self.ports(),
                          robot=self.robot(), markers=markers, presses=self.presses(),
                          blocked=blocked, noise_percent=noise, seed=seed, name=name)

    def track(self) -> w.Track:
        base: KeyPath = ("track",)
        self.table(base, ("points", "width_mm", "line_percent", "floor_percent"))
        pts = self.require(base + ("points",))
        if not isinstance(pts, list) or len(pts) < 2:
            raise self.fail(base + ("points",), "track.points must be a list of at least two "
                                                "[x, y] points (mm)")
        points = []
        for i, pt in enumerate(pts):
            path = base + ("points", i)
            if not isinstance(pt, list) or len(pt) != 2:
                raise self.fail(path, f"{self.show(path)} must be a point [x, y]")
            points.append((self.number(path + (0,)), self.number(path + (1,))))
        return self.build(base, w.Track, tuple(points), self.number(base + ("width_mm",), 20.0),
                          self.number(base + ("line_percent",), 30.0),
                          self.number(base + ("floor_percent",), 60.0))

    def landmarks(self) -> tuple[w.Landmark, ...]:
        out = []
        numbers: dict[int, KeyPath] = {}
        for p in self.tables("landmarks", ("number", "at_mm", "name", "visible", "misses")):
            number = self.integer(p + ("number",), lo=1, hi=15)
            if number in numbers:
                raise self.fail(p + ("number",), f"landmark {number} is defined twice")
            numbers[number] = p
            out.append(self.build(p, w.Landmark, number, self.number(p + ("at_mm",), lo=0),
                                  self.string(p + ("name",), ""),
                                  self.boolean(p + ("visible",), True),
                                  self.integer(p + ("misses",), 0, lo=0)))
        self._landmark_paths = numbers
        return tuple(out)

    def start(self) -> w.Start:
        base: KeyPath = ("start",)
        self.table(base, ("at_mm", "landmark", "direction"))
        direction = self.string(base + ("direction",), "forward")
        if direction not in ("forward", "backward"):
            raise self.fail(base + ("direction",), f"start.direction must be \"forward\" or "
                                                   f"\"backward\", not {direction!r}")
        landmark = self.optional_integer(base + ("landmark",))
        if landmark is not None and landmark not in self._landmark_paths:
            raise self.fail(base + ("landmark",), f"start.landmark: no landmark {landmark}")
        return self.build(base, w.Start, self.optional_number(base + ("at_mm",), lo=0), landmark,
                          1 if direction == "forward" else -1)

    def ports(self) -> w.Ports:
        base: KeyPath = ("ports",)
        if not self.has(base):
            return w.Ports()
        self.table(base, ("touch", "light", "left", "right", "tray"))
        d = w.Ports()

        def sensor(key: str, default: int) -> int:
            if not self.has(base + (key,)):
                return default
            v = self.integer(base + (key,))
            if not 1 <= v <= 4:
                raise self.fail(base + (key,), f"ports.{key} must be an input port 1..4, not {v}"
                                + (" (sensors go on input ports; motors on A..C)"
                                   if v in (0, 5) else ""))
            return v - 1

        def motor(key: str, default: int) -> int:
            if not self.has(base + (key,)):
                return default
            value = self.get(base + (key,))
            if not isinstance(value, str) or value.upper() not in ("A", "B", "C"):
                raise self.fail(base + (key,), f"ports.{key} must be an output port \"A\", "
                                               f"\"B\" or \"C\", not {value!r}")
            return "ABC".index(value.upper())

        ports = self.build(base, w.Ports, sensor("touch", d.touch), sensor("light", d.light),
                           motor("left", d.left), motor("right", d.right), motor("tray", d.tray))
        program = {"touch": legolog_constants.PORT_TOUCH, "light": legolog_constants.PORT_LIGHT,
                   "left": legolog_constants.PORT_LEFT, "right": legolog_constants.PORT_RIGHT,
                   "tray": legolog_constants.PORT_TRAY}
        for key, want in program.items():
            if getattr(ports, key) != want:
                shown = str(want + 1) if key in ("touch", "light") else "ABC"[want]
                raise self.fail(base + (key,), f"ports.{key}: the brick program "
                                               f"cplus_legolog.rxe uses port {shown} for it")
        return ports

    def robot(self) -> w.RobotBody:
        base: KeyPath = ("robot",)
        if not self.has(base):
            return w.RobotBody()
        keys = ("wheel_diameter_mm", "axle_track_mm", "sensor_ahead_mm", "spot_radius_mm")
        self.table(base, keys)
        d = w.RobotBody()
        return self.build(base, w.RobotBody, *(self.number(base + (k,), getattr(d, k))
                                                for k in keys))

    def markers(self) -> w.Markers:
        base: KeyPath = ("markers",)
        if not self.has(base):
            return w.Markers()
        keys = ("bar_mm", "bar_percent", "faint_percent", "half_width_mm")
        self.table(base, keys)
        d = w.Markers()
        return self.build(base, w.Markers, *(self.number(base + (k,), getattr(d, k))
                                              for k in keys))

    def presses(self) -> tuple[w.Press, ...]:
        out = []
        d = w.Press(at_s=0.0)
        for p in self.tables("presses", ("at_s", "at_landmark", "visit", "delay_s", "hold_s",
                                         "near_mm")):
            at_landmark = self.optional_integer(p + ("at_landmark",))
            if at_landmark is not None and at_landmark not in self._landmark_paths:
                raise self.fail(p + ("at_landmark",), f"{self.show(p)}.at_landmark: no "
                                                      f"landmark {at_landmark}")
            out.append(self.build(
                p, w.Press, self.optional_number(p + ("at_s",), lo=0), at_landmark,
                self.integer(p + ("visit",), d.visit, lo=1), self.number(p + ("delay_s",), d.delay_s, lo=0),
                self.number(p + ("hold_s",), d.hold_s, lo=0), self.number(p + ("near_mm",), d.near_mm, lo=0)))
        return tuple(out)

    def blocked(self) -> tuple[w.Blocked, ...]:
        return tuple(self.build(p, w.Blocked, self.number(p + ("from_mm",), lo=0),
                                self.number(p + ("to_mm",), lo=0), self.optional_integer(p + ("times",), lo=1))
                     for p in self.tables("blocked", ("from_mm", "to_mm", "times")))


def _kind(value: object) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "a table"
    return type(value).__name__
