"""A world for the emulated brick to sense: Legolog's delivery robot on a line track.

Legolog's robot follows a black line with a light sensor to the next landmark, turns
180 degrees, raises and lowers a tray, and accepts button presses. :class:`World` is the
floor and the robot body around an emulated brick (attached with
``Firmware.attach``): every millisecond it

* moves the robot by the angles its two drive wheels turned (the motors are the
  emulator's motor physics; differential drive: ``ds = (dl + dr) / 2``,
  ``dtheta = (dr - dl) / axle``), so a robot driven too fast overshoots, a wheel with
  backlash lags, and so on;
* stops it at a *blocked stretch* of the track: the robot's centre cannot enter it, and
  while the wheels push towards it the drive motors are held (``MotorPhysics.blocked``),
  so the encoders stand still as on a robot against an obstacle; turning on the spot and
  backing off stay possible; a stretch can clear after it has blocked the robot ``times``
  times;
* sets the light sensor's A/D value to what a LEGO light sensor ``ahead_mm`` in front of
  the axle reads there: the floor, the line (a band ``width_mm`` wide along a polyline),
  or a landmark's bars (landmark *n* is *n* bright bars across the line, so the robot can
  tell landmarks apart by counting), blended over the sensor's spot, plus Gaussian noise;
* sets the touch sensor's A/D value: pressed during scheduled presses (at a simulated
  time, or a delay after the robot came to rest at a landmark) and interactive ones
  (:meth:`World.press`, thread-safe).

Units: millimetres, seconds, degrees; light in percent as an NXT light sensor reports it
in PCT_FULL_SCALE mode (the firmware's input module turns the A/D value back into it).
Positions along the track are arc lengths from its first point.

:class:`WorldSpec` is the validated description (``cplus.world/1`` files are read by
``cplus.robot.online.world_file``); :func:`delivery_world` is the default delivery track.
"""
from __future__ import annotations

import math
import random
import threading
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

from nxt_link.emulator.input_module import TOUCH_RAW_PRESSED, TOUCH_RAW_RELEASED, light_percent_to_raw

__all__ = ["MAX_PRESS_S", "Track", "Landmark", "Markers", "Start", "Ports", "RobotBody", "Press", "Blocked",
           "WorldSpec", "World", "Pose", "delivery_world"]


MAX_PRESS_S = 60.0
"""The longest press of the touch sensor :meth:`World.press` accepts: a finger held a minute."""


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, int | float) and value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be a positive number, got {value!r}")


def _percent(name: str, value: float) -> None:
    if not (isinstance(value, int | float) and 0 <= value <= 100):
        raise ValueError(f"{name} must be a percentage in 0..100, got {value!r}")


@dataclass(frozen=True, slots=True)
class Track:
    """A black line along a polyline of at least two points (mm)."""

    points_mm: tuple[tuple[float, float], ...]
    width_mm: float = 20.0
    line_percent: float = 30.0
    floor_percent: float = 60.0

    def __post_init__(self) -> None:
        if len(self.points_mm) < 2:
            raise ValueError("the track needs at least two points")
        for a, b in zip(self.points_mm, self.points_mm[1:]):
            if math.dist(a, b) <= 0:
                raise ValueError("two consecutive track points are equal")
        _positive("track width", self.width_mm)
        _percent("line_percent", self.line_percent)
        _percent("floor_percent", self.floor_percent)

    @property
    def length_mm(self) -> float:
        return sum(math.dist(a, b) for a, b in zip(self.points_mm, self.points_mm[1:]))


@dataclass(frozen=True, slots=True)
class Landmark:
    """Landmark ``number`` (that many bars) starting ``at_mm`` along the track.

    ``misses``: the first that many times the light sensor passes over it, its bars read
    too faint (worn tape, a shadow): the robot drives past it. ``visible=False``: always.
    """

    number: int
    at_mm: float
    name: str = ""
    visible: bool = True
    misses: int = 0

    def __post_init__(self) -> None:
        if not (isinstance(self.number, int) and 1 <= self.number <= 15):
            raise ValueError(f"landmark number must be an integer in 1..15, got {self.number!r}")
        if not (isinstance(self.misses, int) and self.misses >= 0):
            raise ValueError("misses must be an integer >= 0")


@dataclass(frozen=True, slots=True)
class Markers:
    """How landmarks look: bars ``bar_mm`` long with equal gaps, ``half_width_mm`` each side."""

    bar_mm: float = 10.0
    bar_percent: float = 90.0
    faint_percent: float = 62.0
    half_width_mm: float = 40.0

    def __post_init__(self) -> None:
        _positive("bar length", self.bar_mm)
        _positive("marker half width", self.half_width_mm)
        _percent("bar_percent", self.bar_percent)
        _percent("faint_percent", self.faint_percent)


@dataclass(frozen=True, slots=True)
class Start:
    """Where the robot starts: its centre at ``at_mm`` along the track, or standing at
    ``landmark`` (centre over the marker's far end, where FOLLOW stops: the sensor is past
    the bars), facing ``direction`` (+1: towards the track's end), its light sensor on the
    line's left edge."""

    at_mm: float | None = None
    landmark: int | None = None
    direction: int = 1

    def __post_init__(self) -> None:
        if self.direction not in (1, -1):
            raise ValueError("start direction must be +1 (forward) or -1 (backward)")
        if (self.at_mm is None) == (self.landmark is None):
            raise ValueError("the start needs exactly one of at_mm and landmark")


@dataclass(frozen=True, slots=True)
class Ports:
    """Where the robot's sensors and motors are plugged in (0-based: S1 = 0, A = 0)."""

    touch: int = 0
    light: int = 2
    left: int = 1
    right: int = 2
    tray: int = 0

    def __post_init__(self) -> None:
        if not (0 <= self.touch <= 3 and 0 <= self.light <= 3) or self.touch == self.light:
            raise ValueError("touch and light need two different input ports (1..4)")
        outs = (self.left, self.right, self.tray)
        if not all(0 <= p <= 2 for p in outs) or len(set(outs)) != 3:
            raise ValueError("left, right and tray need three different output ports (A..C)")


@dataclass(frozen=True, slots=True)
class RobotBody:
    """Geometry of the robot (the LEGO 56 mm wheel, a 112 mm axle, sensor 70 mm ahead)."""

    wheel_diameter_mm: float = 56.0
    axle_track_mm: float = 112.0
    sensor_ahead_mm: float = 70.0
    spot_radius_mm: float = 4.0

    def __post_init__(self) -> None:
        for name in ("wheel_diameter_mm", "axle_track_mm", "sensor_ahead_mm", "spot_radius_mm"):
            _positive(name, getattr(self, name))


@dataclass(frozen=True, slots=True)
class Press:
    """A press of the touch sensor lasting ``hold_s``: at simulated time ``at_s``, or
    ``delay_s`` after the robot's ``visit``-th arrival at landmark ``at_landmark``
    (coming to rest within ``near_mm`` of it after having been farther away)."""

    at_s: float | None = None
    at_landmark: int | None = None
    visit: int = 1
    delay_s: float = 0.5
    hold_s: float = 0.3
    near_mm: float = 150.0

    def __post_init__(self) -> None:
        if (self.at_s is None) == (self.at_landmark is None):
            raise ValueError("a press needs exactly one of at_s and at_landmark")
        if self.at_s is not None and self.at_s < 0:
            raise ValueError("a press time must be >= 0 s")
        if self.visit < 1:
            raise ValueError("visit must be >= 1")
        if not (math.isfinite(self.delay_s) and self.delay_s >= 0):
            raise ValueError("delay_s must be >= 0")
        _positive("hold_s", self.hold_s)
        if not (isinstance(self.near_mm, int | float) and 0 <= self.near_mm and math.isfinite(self.near_mm)):
            raise ValueError(f"near_mm must be a distance >= 0 mm, got {self.near_mm!r}")


@dataclass(frozen=True, slots=True)
class Blocked:
    """A stretch ``[from_mm, to_mm]`` of the track the robot cannot enter; it clears after
    blocking the robot ``times`` times (None: never)."""

    from_mm: float
    to_mm: float
    times: int | None = None

    def __post_init__(self) -> None:
        if not self.from_mm < self.to_mm:
            raise ValueError("a blocked stretch needs from_mm < to_mm")
        if self.times is not None and self.times < 1:
            raise ValueError("times must be >= 1")


@dataclass(frozen=True, slots=True)
class WorldSpec:
    """Everything that defines a world; validated on creation (ValueError)."""

    track: Track
    landmarks: tuple[Landmark, ...] = ()
    start: Start = field(default_factory=lambda: Start(at_mm=0.0))
    ports: Ports = field(default_factory=Ports)
    robot: RobotBody = field(default_factory=RobotBody)
    markers: Markers = field(default_factory=Markers)
    presses: tuple[Press, ...] = ()
    blocked: tuple[Blocked, ...] = ()
    noise_percent: float = 1.0
    seed: int | None = None
    name: str = "world"

    def __post_init__(self) -> None:
        length = self.track.length_mm
        numbers = [lm.number for lm in self.landmarks]
        if len(set(numbers)) != len(numbers):
            raise ValueError("two landmarks have the same number")
        for lm in self.landmarks:
            end = lm.at_mm + self.marker_length_mm(lm.number)
            if lm.at_mm < 0 or end > length:
                raise ValueError(f"landmark {lm.number} ({lm.at_mm:g}..{end:g} mm) is not on "
                                 f"the track (0..{length:g} mm)")
        if self.start.landmark is not None and self.start.landmark not in numbers:
            raise ValueError(f"the robot starts at landmark {self.start.landmark}: no such "
                             "landmark")
        start = self.start_mm
        if not 0 <= start <= length:
            raise ValueError(f"the start ({start:g} mm) is not on the track (0..{length:g} mm)")
        for b in self.blocked:
            if b.from_mm <= start <= b.to_mm:
                raise ValueError("the robot starts inside a blocked stretch")
        for p in self.presses:
            if p.at_landmark is not None and p.at_landmark not in numbers:
                raise ValueError(f"a press at landmark {p.at_landmark}: no such landmark")
        if not (0 <= self.noise_percent <= 20):
            raise ValueError("noise_percent must be in 0..20")

    @property
    def start_mm(self) -> float:
        """The robot's starting position along the track."""
        if self.start.landmark is None:
            assert self.start.at_mm is not None
            return self.start.at_mm
        lm = self.landmark(self.start.landmark)
        if self.start.direction > 0:
            return lm.at_mm + self.marker_length_mm(lm.number)
        return lm.at_mm

    def marker_length_mm(self, number: int) -> float:
        return (2 * number - 1) * self.markers.bar_mm

    def landmark(self, number: int) -> Landmark:
        for lm in self.landmarks:
            if lm.number == number:
                return lm
        raise KeyError(number)


def delivery_world(seed: int | None = None) -> WorldSpec:
    """The default delivery track: a 4 m straight line, landmarks 1..4 every metre, the
    robot at landmark 1 facing landmark 2."""
    return WorldSpec(
        name="delivery",
        track=Track(((0.0, 0.0), (4000.0, 0.0))),
        landmarks=tuple(Landmark(n, 400.0 + 1000.0 * (n - 1), f"office{n}") for n in range(1, 5)),
        start=Start(landmark=1),
        seed=seed)


# ---------------------------------------------------------------------------------------
# the simulation


@dataclass(slots=True)
class Pose:
    """The robot's centre (mid-axle, mm) and heading (radians, 0 = +x)."""

    x: float
    y: float
    theta: float


class _Polyline:
    def __init__(self, points: Sequence[tuple[float, float]]) -> None:
        self.points = [tuple(map(float, p)) for p in points]
        self.segments = []
        s = 0.0
        for (ax, ay), (bx, by) in zip(self.points, self.points[1:]):
            length = math.hypot(bx - ax, by - ay)
            self.segments.append((ax, ay, (bx - ax) / length, (by - ay) / length, length, s))
            s += length
        self.length = s

    def project(self, x: float, y: float) -> tuple[float, float, float]:
        """(arc length of the nearest point, distance to it, signed lateral offset: > 0 left)."""
        best = (0.0, math.inf, 0.0)
        for ax, ay, ux, uy, length, s0 in self.segments:
            dx, dy = x - ax, y - ay
            t = dx * ux + dy * uy
            lateral = ux * dy - uy * dx
            tc = min(length, max(0.0, t))
            dist = math.hypot(dx - tc * ux, dy - tc * uy)
            if dist < best[1]:
                best = (s0 + tc, dist, lateral)
        return best

    def at(self, s: float) -> tuple[float, float, float]:
        """(x, y, tangent angle) at arc length ``s`` (clamped to the line)."""
        s = min(self.length, max(0.0, s))
        for ax, ay, ux, uy, length, s0 in self.segments:
            if s <= s0 + length or (ax, ay, ux, uy, length, s0) == self.segments[-1]:
                t = s - s0
                return ax + t * ux, ay + t * uy, math.atan2(uy, ux)
        raise AssertionError("unreachable")


class _Stretch:
    def __init__(self, spec: Blocked) -> None:
        self.spec = spec
        self.contacts = 0
        self.cleared = False
        self.side = 0  # +1: the robot touches it from below from_mm, -1: from above to_mm

    def inside(self, s: float) -> bool:
        return not self.cleared and self.spec.from_mm <= s <= self.spec.to_mm


class World:
    """The simulation of one :class:`WorldSpec` around one brick (see the module docstring).

    Args:
        spec: the world.
        seed: overrides ``spec.seed`` (the emulator passes its fault seed when given).
    """

    #: wheel speeds below this (mm/s) count as standing still
    REST_MM_S = 5.0

    def __init__(self, spec: WorldSpec, seed: int | None = None) -> None:
        self.spec = spec
        self._rng = random.Random(spec.seed if seed is None else seed)
        self._line = _Polyline(spec.track.points_mm)
        body = spec.robot
        self._mm_per_deg = math.pi * body.wheel_diameter_mm / 360.0
        x, y, tangent = self._line.at(spec.start_mm)
        heading = tangent if spec.start.direction > 0 else tangent + math.pi
        half = spec.track.width_mm / 2.0
        # start with the light sensor on the line's left edge (as seen in the direction of travel)
        x -= half * math.sin(heading)
        y += half * math.cos(heading)
        self.pose = Pose(x, y, _wrap(heading))
        self._wheels: tuple[float, float] | None = None
        self._stretches = [_Stretch(b) for b in spec.blocked]
        self._contact: _Stretch | None = None
        self._presses_due: list[tuple[float, float]] = []  # (start s, end s) of presses
        for p in spec.presses:
            if p.at_s is not None:
                self._presses_due.append((p.at_s, p.at_s + p.hold_s))
        self._requests: deque[float] = deque()  # interactive presses (hold seconds)
        self._lock = threading.Lock()
        self._visits: dict[int, int] = {lm.number: 0 for lm in spec.landmarks}
        self.passes: dict[int, int] = {lm.number: 0 for lm in spec.landmarks}
        self._over: int | None = None  # the landmark under the light sensor
        self._away: dict[int, bool] = {lm.number: True for lm in spec.landmarks}
        self._rest_ms = 0
        self.now_s = 0.0
        self.distance_mm = 0.0
        self.light_percent = spec.track.floor_percent
        self.touch_pressed = False
        self.presses = 0  # presses so far (overlapping ones count once)

    # -- inspection ------------------------------------------------------------------------

    @property
    def position_mm(self) -> float:
        """Arc length of the robot's centre along the track."""
        return self._line.project(self.pose.x, self.pose.y)[0]

    def nearest_landmark(self, within_mm: float = 150.0) -> int | None:
        """The landmark whose marker middle is within ``within_mm`` of the robot's centre."""
        s = self.position_mm
        best: tuple[float, int] | None = None
        for lm in self.spec.landmarks:
            mid = lm.at_mm + self.spec.marker_length_mm(lm.number) / 2.0
            d = abs(s - mid)
            if d <= within_mm and (best is None or d < best[0]):
                best = (d, lm.number)
        return None if best is None else best[1]

    def stuck_contacts(self) -> int:
        return sum(st.contacts for st in self._stretches)

    # -- interaction -----------------------------------------------------------------------

    def press(self, hold_s: float = 0.3) -> None:
        """Press the touch sensor for ``hold_s`` from the next millisecond (any thread)."""
        if not 0 < hold_s <= MAX_PRESS_S:     # also refuses NaN, which compares false
            raise ValueError(f"a press lasts more than 0 and at most {MAX_PRESS_S:g} s, not {hold_s!r}")
        with self._lock:
            self._requests.append(hold_s)

    # -- the millisecond ---------------------------------------------------------------------

    def step(self, fw: object) -> None:
        """Environment hook: called by the firmware once per millisecond."""
        from nxt_link.emulator.firmware import Firmware

        assert isinstance(fw, Firmware)
        ports = self.spec.ports
        self.now_s = fw.now_ms / 1000.0
        left, right = fw.outputs[ports.left], fw.outputs[ports.right]
        wheels = (left.motor.output_deg, right.motor.output_deg)
        if self._wheels is None:
            self._wheels = wheels
        dl = (wheels[0] - self._wheels[0]) * self._mm_per_deg
        dr = (wheels[1] - self._wheels[1]) * self._mm_per_deg
        self._wheels = wheels
        self._move(dl, dr, _drive(left), _drive(right), (left.motor, right.motor))
        self._arrivals(abs(dl) + abs(dr))
        self.light_percent = self._light()
        fw.inputs[ports.light].raw = light_percent_to_raw(self.light_percent)
        self.touch_pressed = self._touch()
        fw.inputs[ports.touch].raw = TOUCH_RAW_PRESSED if self.touch_pressed else TOUCH_RAW_RELEASED

    def _move(self, dl: float, dr: float, power_l: int, power_r: int,
              motors: tuple[object, object]) -> None:
        p = self.pose
        ds = (dl + dr) / 2.0
        dtheta = (dr - dl) / self.spec.robot.axle_track_mm
        mid = p.theta + dtheta / 2.0
        nx, ny = p.x + ds * math.cos(mid), p.y + ds * math.sin(mid)
        s_old = self._line.project(p.x, p.y)[0]
        s_new = self._line.project(nx, ny)[0]
        hit = next((st for st in self._stretches if st.inside(s_new) and not st.inside(s_old)),
                   None)
        if hit is not None:
            # the centre stops at the obstacle; only the rotation happens
            if self._contact is not hit:
                hit.contacts += 1
                hit.side = 1 if s_old < hit.spec.from_mm else -1
                self._contact = hit
            nx, ny = p.x, p.y
        else:
            self.distance_mm += abs(ds)
        p.x, p.y, p.theta = nx, ny, _wrap(p.theta + dtheta)
        contact = self._contact
        if contact is None:
            return
        # pushing towards the stretch keeps the wheels held; anything else releases them
        tangent = self._line.at(s_old)[2]
        along = math.cos(p.theta - tangent) * (power_l + power_r)
        pushing = along * contact.side > 0
        for m in motors:
            m.blocked = pushing  # type: ignore[attr-defined]
        if not pushing:
            if contact.spec.times is not None and contact.contacts >= contact.spec.times:
                contact.cleared = True
            self._contact = None

    def _arrivals(self, moved_mm: float) -> None:
        """Count arrivals at landmarks (for presses scheduled at a landmark)."""
        if moved_mm / 0.001 > self.REST_MM_S * 2:  # per-ms motion to mm/s (both wheels)
            self._rest_ms = 0
            return
        self._rest_ms += 1
        if self._rest_ms != 50:  # at rest for 50 ms: an arrival (once per rest)
            return
        s = self.position_mm
        for p in self.spec.presses:
            if p.at_landmark is None:
                continue
            lm = self.spec.landmark(p.at_landmark)
            mid = lm.at_mm + self.spec.marker_length_mm(lm.number) / 2.0
            near = abs(s - mid) <= p.near_mm
            if near and self._away[lm.number]:
                self._away[lm.number] = False
                self._visits[lm.number] += 1
                # every press of this landmark and visit fires now
                for q in self.spec.presses:
                    if q.at_landmark == lm.number and q.visit == self._visits[lm.number]:
                        start = self.now_s + q.delay_s
                        self._presses_due.append((start, start + q.hold_s))
            elif not near:
                self._away[lm.number] = True

    def _touch(self) -> bool:
        with self._lock:
            while self._requests:
                hold = self._requests.popleft()
                self._presses_due.append((self.now_s, self.now_s + hold))
        pressed = False
        keep = []
        for start, end in self._presses_due:
            if start <= self.now_s < end:
                pressed = True
            if self.now_s < end:
                keep.append((start, end))
        self._presses_due = keep
        if pressed and not self.touch_pressed:
            self.presses += 1
        return pressed

    def _light(self) -> float:
        spec = self.spec
        p = self.pose
        ahead = spec.robot.sensor_ahead_mm
        sx, sy = p.x + ahead * math.cos(p.theta), p.y + ahead * math.sin(p.theta)
        s, dist, lateral = self._line.project(sx, sy)
        r = spec.robot.spot_radius_mm
        half = spec.track.width_mm / 2.0
        cover = min(1.0, max(0.0, (half + r - dist) / (2.0 * r)))
        value = spec.track.line_percent * cover + spec.track.floor_percent * (1.0 - cover)
        bar = None
        if abs(lateral) <= spec.markers.half_width_mm and dist <= spec.markers.half_width_mm:
            bar = self._bar_cover(s, r)
        if bar is None:
            self._over = None
        else:
            value = bar[1] * bar[0] + value * (1.0 - bar[0])
        if spec.noise_percent:
            value += self._rng.gauss(0.0, spec.noise_percent)
        return min(100.0, max(0.0, value))

    def _bar_cover(self, s: float, r: float) -> tuple[float, float] | None:
        """(fraction of the spot on a bar, the bar's brightness) at arc length ``s``."""
        m = self.spec.markers
        for lm in self.spec.landmarks:
            start = lm.at_mm
            end = start + self.spec.marker_length_mm(lm.number)
            if s + r < start or s - r > end:
                continue
            if self._over != lm.number:  # the sensor arrives over this marker: one pass
                self._over = lm.number
                self.passes[lm.number] += 1
            covered = 0.0
            for j in range(lm.number):
                a = start + 2 * j * m.bar_mm
                b = a + m.bar_mm
                covered += max(0.0, min(b, s + r) - max(a, s - r))
            seen = lm.visible and self.passes[lm.number] > lm.misses
            return covered / (2.0 * r), (m.bar_percent if seen else m.faint_percent)
        return None


def _drive(port: object) -> int:
    """The power a port drives its motor with (0 when released or coasting)."""
    from nxt_link.emulator.output_module import OutputPort
    from nxt_link.wire.telegram import OutputMode, RunState

    assert isinstance(port, OutputPort)
    if not port.mode & OutputMode.MOTORON or port.run_state == RunState.IDLE:
        return 0
    return port.power


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi
