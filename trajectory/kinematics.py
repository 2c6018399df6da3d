"""Forward and inverse kinematics of a rail-mounted arm, and exact joint-limit checks on segments.

The paper's robot (its equations (1)-(4)) is a prismatic base ``s`` on a rail plus one arm of
length ``l`` at angle ``theta``: ``x = s + l cos(theta)``, ``y = l sin(theta)``. Here the rail
may sit anywhere and point anywhere: it starts at ``rail_origin`` ``o`` and runs along the unit
vector ``d``; ``n = (-d_y, d_x)`` is ``d`` turned a quarter left, and ``theta`` is measured
from ``d`` towards ``n``::

    p = o + s d + l (cos(theta) d + sin(theta) n)

With ``o = (0, 0)`` and ``d = (1, 0)`` this is exactly the paper's (1)-(2). In rail
coordinates ``along = (p - o) . d`` and ``across = (p - o) . n`` the inverse is

    s = along - b sqrt(l^2 - across^2),    theta = atan2(across, b sqrt(l^2 - across^2))

with the branch ``b`` = +1 (the hand ahead of the carriage along ``d``) or -1 (behind it).
These are the paper's (3)-(4) with their coupled signs (the paper prints ``atan2``'s arguments
in the other order; with ``y = l sin(theta)`` the first argument must be ``y``). A point is
out of reach when ``|across| > l``; then no branch exists, and this module raises
`UnreachableError` instead of returning NaN.

Joint angles are real numbers, not angles modulo 360 degrees: a joint whose limits are
[-170, 170] degrees cannot pass through 180. Along one branch ``theta`` is a continuous,
monotonic function of ``across``; the lifted branch angle is ``asin(across / l)`` in
[-90, 90] degrees for ``b = +1`` and ``180 - asin(across / l)`` in [90, 270] for ``b = -1``,
plus ``turns`` whole turns chosen so that it lands inside the joint limits (limits must span
less than a full turn, so there is at most one such choice per point). A `BranchChoice`
``(branch, turns)`` fixed for a whole path therefore gives a continuous joint path, and a
robot switches branch only by stopping where both coincide, which plans never need.

Along a straight segment ``across`` is linear in the motion parameter ``u``, so the angle
limits become an interval of ``across``, and ``s(u) = along(u) - b sqrt(l^2 - across(u)^2)``
equals a bound only at a root of a quadratic. `segment_exit` finds the first ``u`` where a
segment leaves the reachable, joint-limited set exactly from those roots.

>>> arm = Arm(rail_origin=(0.0, -2.0), rail_dir=(1.0, 0.0), length=7.0,
...           s_limits=(-10.0, 20.0), theta_limits_rad=(0.1, 3.0))
>>> s, theta = inverse(arm, 3.0, 0.0, BranchChoice(1, 0))
>>> [round(float(c), 12) for c in forward(arm, s, theta)]
[3.0, 0.0]
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._format import fmt as _fmt
from .errors import TrajectoryError, UnreachableError
from .geometry import EPS, Point2, Quadratic, first_failing_interval, lerp, quadratic_roots

__all__ = [
    "Arm",
    "BranchChoice",
    "JointState",
    "SegmentExit",
    "forward",
    "inverse",
    "ik_solutions",
    "choices_at",
    "point_problem",
    "segment_exit",
    "surviving_choices",
]

FloatArray = npt.NDArray[np.float64]
ArrayLike = float | npt.ArrayLike

_TWO_PI = 2.0 * math.pi
_BRANCH_RANGE = {1: (-0.5 * math.pi, 0.5 * math.pi), -1: (0.5 * math.pi, 1.5 * math.pi)}


@dataclass(frozen=True, slots=True)
class Arm:
    """One robot's kinematic model, in grid units and radians (see the module docstring)."""

    rail_origin: Point2
    rail_dir: Point2
    length: float
    s_limits: tuple[float, float]
    theta_limits_rad: tuple[float, float]

    def __post_init__(self) -> None:
        dx, dy = self.rail_dir
        if not math.isclose(math.hypot(dx, dy), 1.0, rel_tol=1e-9):
            raise TrajectoryError(f"rail direction {self.rail_dir} is not a unit vector")
        if not (math.isfinite(self.length) and self.length > 0.0):
            raise TrajectoryError(f"arm length must be positive, not {self.length}")
        if not self.s_limits[0] < self.s_limits[1]:
            raise TrajectoryError(f"s limits {self.s_limits} are not increasing")
        lo, hi = self.theta_limits_rad
        if not (lo < hi and hi - lo < _TWO_PI):
            raise TrajectoryError(
                f"theta limits {self.theta_limits_rad} must increase and span less than a turn"
            )

    @property
    def rail_normal(self) -> Point2:
        """``d`` turned a quarter turn left: the direction of ``theta`` = +90 degrees."""
        return (-self.rail_dir[1], self.rail_dir[0])

    def rail_frame(self, x: ArrayLike, y: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """``(along, across)``: a point in rail coordinates (vectorised)."""
        px = np.asarray(x, dtype=float) - self.rail_origin[0]
        py = np.asarray(y, dtype=float) - self.rail_origin[1]
        dx, dy = self.rail_dir
        return px * dx + py * dy, -px * dy + py * dx

    @property
    def scale(self) -> float:
        """A length scale for tolerances."""
        return max(1.0, self.length, abs(self.rail_origin[0]), abs(self.rail_origin[1]),
                   abs(self.s_limits[0]), abs(self.s_limits[1]))


@dataclass(frozen=True, slots=True)
class BranchChoice:
    """An IK branch (``+1`` hand ahead of the carriage, ``-1`` behind) and whole turns."""

    branch: int
    turns: int = 0

    def __str__(self) -> str:
        return f"branch {self.branch:+d}" + (f" (turns {self.turns:+d})" if self.turns else "")


@dataclass(frozen=True, slots=True)
class JointState:
    """Joint values of one arm: carriage position ``s`` (grid units), arm angle (radians)."""

    s: float
    theta_rad: float


def forward(arm: Arm, s: ArrayLike, theta_rad: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """End-effector ``(x, y)`` from joint values (vectorised); the paper's (1)-(2)."""
    s_arr = np.asarray(s, dtype=float)
    th = np.asarray(theta_rad, dtype=float)
    dx, dy = arm.rail_dir
    nx, ny = arm.rail_normal
    c = arm.length * np.cos(th)
    sn = arm.length * np.sin(th)
    x = arm.rail_origin[0] + s_arr * dx + c * dx + sn * nx
    y = arm.rail_origin[1] + s_arr * dy + c * dy + sn * ny
    return x, y


def _reach_slack(arm: Arm) -> float:
    return EPS * arm.scale


def _reach_root(arm: Arm, across: FloatArray) -> FloatArray:
    """``sqrt(l^2 - across^2)``, computed as ``sqrt((l - |a|)(l + |a|))`` for accuracy at full reach."""
    a = np.abs(across)
    return np.sqrt(np.maximum((arm.length - a) * (arm.length + a), 0.0))


def _branch_angle(arm: Arm, branch: int, across: FloatArray) -> FloatArray:
    """The lifted branch angle: in [-90, 90] deg for ``+1``, in [90, 270] deg for ``-1``."""
    angle = np.arctan2(across, branch * _reach_root(arm, across))
    if branch == -1:
        angle = np.where(angle < 0.0, angle + _TWO_PI, angle)
    return angle


def inverse(arm: Arm, x: ArrayLike, y: ArrayLike, choice: BranchChoice) -> tuple[FloatArray, FloatArray]:
    """Joint values ``(s, theta_rad)`` reaching ``(x, y)`` on one branch (vectorised).

    Joint limits are not checked here (see `segment_exit` and `choices_at`).

    Raises
    ------
    UnreachableError
        If any point is farther from the rail than the arm is long; never returns NaN.
    """
    if choice.branch not in (1, -1):
        raise TrajectoryError(f"IK branch must be +1 or -1, not {choice.branch}")
    along, across = arm.rail_frame(x, y)
    too_far = np.abs(across) > arm.length + _reach_slack(arm)
    if np.any(too_far):
        k = int(np.flatnonzero(too_far)[0])
        xs = np.broadcast_to(np.asarray(x, dtype=float), too_far.shape)
        ys = np.broadcast_to(np.asarray(y, dtype=float), too_far.shape)
        raise UnreachableError(
            f"point ({_fmt(xs.flat[k])}, {_fmt(ys.flat[k])}) is out of reach: it is "
            f"{_fmt(abs(float(across.flat[k])))} from the rail, the arm is {_fmt(arm.length)} long"
        )
    reach = _reach_root(arm, across) * choice.branch
    theta = _branch_angle(arm, choice.branch, across) + _TWO_PI * choice.turns
    return along - reach, theta


def ik_solutions(arm: Arm, x: float, y: float) -> tuple[JointState, JointState]:
    """Both IK solutions ``(branch +1, branch -1)`` of a point, ignoring joint limits."""
    out = []
    for b in (1, -1):
        s, th = inverse(arm, x, y, BranchChoice(b, 0))
        out.append(JointState(float(s), float(th)))
    return out[0], out[1]


def _turns_for(arm: Arm, branch: int, base_angle: float) -> int | None:
    """The whole turns putting the lifted branch angle inside the limits, if any."""
    lo, hi = arm.theta_limits_rad
    tol = EPS
    k = math.ceil((lo - tol - base_angle) / _TWO_PI)
    return k if base_angle + _TWO_PI * k <= hi + tol else None


def point_problem(arm: Arm, x: float, y: float, branch: int) -> tuple[bool, str] | None:
    """Why branch ``branch`` cannot hold the arm at ``(x, y)``: ``(out_of_reach, text)``.

    Returns ``None`` when the branch reaches the point within the joint limits.
    """
    along, across = (float(c) for c in arm.rail_frame(x, y))
    if abs(across) > arm.length + _reach_slack(arm):
        return True, f"{_fmt(abs(across))} from the rail, beyond the arm's {_fmt(arm.length)}"
    base = float(_branch_angle(arm, branch, np.asarray(across)))
    if _turns_for(arm, branch, base) is None:
        lo, hi = (math.degrees(t) for t in arm.theta_limits_rad)
        return False, (f"theta = {_fmt(math.degrees(base))} deg is outside the limits "
                       f"[{_fmt(lo)}, {_fmt(hi)}]")
    s = along - branch * math.sqrt(max(arm.length**2 - across**2, 0.0))
    lo_s, hi_s = arm.s_limits
    if not lo_s - _reach_slack(arm) <= s <= hi_s + _reach_slack(arm):
        return False, f"s = {_fmt(s)} is outside the limits [{_fmt(lo_s)}, {_fmt(hi_s)}]"
    return None


_MEMO = 1 << 16
"""Entries kept by each memoised function below: the refinement loop checks the same points
and motions in plan after plan (and the pre-check and widening ask again), and the answers
are pure functions of immutable arguments."""


def choices_at(arm: Arm, x: float, y: float) -> tuple[BranchChoice, ...]:
    """The branch choices that hold the arm at ``(x, y)`` within its joint limits (memoised)."""
    return _choices_at(arm, float(x), float(y))


@functools.lru_cache(maxsize=_MEMO)
def _choices_at(arm: Arm, x: float, y: float) -> tuple[BranchChoice, ...]:
    out = []
    for b in (1, -1):
        if point_problem(arm, x, y, b) is None:
            _, across = arm.rail_frame(x, y)
            base = float(_branch_angle(arm, b, np.asarray(across)))
            turns = _turns_for(arm, b, base)
            assert turns is not None  # point_problem checked it
            out.append(BranchChoice(b, turns))
    return tuple(out)


@dataclass(frozen=True, slots=True)
class SegmentExit:
    """Where a straight motion first leaves what one branch can do, and why."""

    u: float
    point: Point2
    out_of_reach: bool
    reason: str


def segment_exit(arm: Arm, p0: Point2, p1: Point2, choice: BranchChoice) -> SegmentExit | None:
    """First ``u`` in [0, 1] where the motion p0->p1 leaves the branch's feasible set.

    Feasible means: within reach (``|across| <= l``), ``theta`` (lifted by ``choice.turns``)
    inside its limits, and ``s`` inside its limits. Exact: the breakpoints are the roots of the
    linear ``across(u)`` against its bounds and of the quadratics ``s(u) = s_min, s_max``
    (squared; spurious roots only add breakpoints), and each interval between breakpoints is
    classified by its midpoint. Memoised.
    """
    return _segment_exit(arm, (float(p0[0]), float(p0[1])), (float(p1[0]), float(p1[1])), choice)


@functools.lru_cache(maxsize=_MEMO)
def _segment_exit(arm: Arm, p0: Point2, p1: Point2, choice: BranchChoice) -> SegmentExit | None:
    b = choice.branch
    arm_len = arm.length
    (al0, al1), (ac0, ac1) = (tuple(float(c) for c in arr) for arr in arm.rail_frame(
        [p0[0], p1[0]], [p0[1], p1[1]]))
    alpha, beta = al1 - al0, ac1 - ac0
    tol = _reach_slack(arm)

    lo_t, hi_t = (t - _TWO_PI * choice.turns for t in arm.theta_limits_rad)
    r_lo, r_hi = _BRANCH_RANGE[b]
    t_lo, t_hi = max(lo_t, r_lo), min(hi_t, r_hi)
    if t_lo > t_hi + EPS:
        v_lo, v_hi = math.inf, -math.inf  # no admissible angle on this branch at all
    else:
        v_lo, v_hi = sorted((arm_len * math.sin(t_lo), arm_len * math.sin(t_hi)))
        # theta's limit reached exactly at a branch end: the bound is the reach itself
        v_lo, v_hi = max(v_lo, -arm_len), min(v_hi, arm_len)

    breaks: list[float] = []
    if beta != 0.0:
        for target in (-arm_len, arm_len, v_lo, v_hi):
            if math.isfinite(target):
                breaks.append((target - ac0) / beta)
    s_lo, s_hi = arm.s_limits
    for bound in (s_lo, s_hi):
        c0 = al0 - bound
        q = Quadratic(alpha * alpha + beta * beta, 2.0 * (alpha * c0 + beta * ac0),
                      c0 * c0 + ac0 * ac0 - arm_len * arm_len)
        roots = quadratic_roots(q, EPS * arm.scale**2)
        if roots:
            breaks.extend(roots)

    lo_deg, hi_deg = (_fmt(math.degrees(t)) for t in arm.theta_limits_rad)

    def problem(u: float) -> tuple[bool, str] | None:
        """What is broken at ``u`` (a probe inside a failing interval), with the value there."""
        across = ac0 + beta * u
        at = f"u = {_fmt(round(u, 4))}"
        if abs(across) > arm_len + tol:
            return True, (f"the point leaves the arm's reach {_fmt(arm_len)} from the rail "
                          f"({_fmt(abs(across))} at {at})")
        if not v_lo - tol <= across <= v_hi + tol:
            theta = math.degrees(float(_branch_angle(arm, b, np.asarray(across))) + _TWO_PI * choice.turns)
            return False, f"theta leaves its limits [{lo_deg}, {hi_deg}] deg ({_fmt(theta)} at {at})"
        s = al0 + alpha * u - b * math.sqrt(max(arm_len * arm_len - across * across, 0.0))
        if not s_lo - tol <= s <= s_hi + tol:
            return False, f"s leaves its limits [{_fmt(s_lo)}, {_fmt(s_hi)}] ({_fmt(s)} at {at})"
        return None

    found = first_failing_interval(breaks, lambda u: problem(u) is not None)
    if found is None:
        return None
    start, probe = found
    why = problem(probe)
    assert why is not None
    return SegmentExit(start, lerp(p0, p1, start), why[0], why[1])


def surviving_choices(
    arm: Arm, choices: Sequence[BranchChoice], p0: Point2, p1: Point2
) -> tuple[tuple[BranchChoice, ...], tuple[tuple[BranchChoice, SegmentExit], ...]]:
    """Split ``choices`` into those that can follow p0->p1 and those that cannot (with why)."""
    alive: list[BranchChoice] = []
    dead: list[tuple[BranchChoice, SegmentExit]] = []
    for choice in choices:
        exit_ = segment_exit(arm, p0, p1, choice)
        if exit_ is None:
            alive.append(choice)
        else:
            dead.append((choice, exit_))
    return tuple(alive), tuple(dead)

