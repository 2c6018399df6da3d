"""How closely the bricks followed the plan: the executed end-effector and payload paths
reconstructed by forward kinematics from the logged encoders, and the tracking error per robot.

Apart from :mod:`cplus.robot.execution.streams` because it only reads what came back: a log and
the trajectory it ran, never a brick.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

import nxt_link
import trajectory
from nxt_link.host.execlog import StartSkew, Stopped

__all__ = ["RobotTracking", "TrackingReport", "skew_verdict", "tracking_report"]


@dataclass(frozen=True, slots=True)
class RobotTracking:
    """Tracking of one robot over its measured ticks: per motor in degrees, end-effector in
    grid units (empty tuples and NaN when nothing was measured)."""

    name: str
    ports: tuple[str, ...]
    max_deg: tuple[int, ...]
    rms_deg: tuple[float, ...]
    max_grid: float
    rms_grid: float
    ticks_measured: int = 0
    ticks: int = 0
    reached: str = "done"


@dataclass(frozen=True, slots=True)
class TrackingReport:
    robots: tuple[RobotTracking, ...]
    executed_paths: Mapping[str, np.ndarray]
    payload: tuple[str, str] | None
    payload_length_max_grid: float | None
    payload_length_rms_grid: float | None
    payload_mid_max_grid: float | None
    start_skew_bound_s: float
    unit_mm: float | None = None
    start_skew: StartSkew | None = None
    start_offsets_s: Mapping[str, float] | None = None
    stopped: Stopped | None = None

    @property
    def complete(self) -> bool:
        return self.stopped is None

    def text(self, header: str = "") -> str:
        mm = (lambda v: f"  ({v * self.unit_mm:.1f} mm)") if self.unit_mm else (lambda v: "")
        lines = [header] if header else []
        if self.stopped is not None:
            who = f" (brick {self.stopped.brick})" if self.stopped.brick and not \
                self.stopped.reason.startswith(f"brick {self.stopped.brick}") else ""
            lines.append(f"INCOMPLETE: the execution stopped at {self.stopped.t_s:.2f} s{who}: "
                         f"{self.stopped.reason}")
            for r in self.robots:
                lines.append(f"  {r.name}: {r.ticks_measured} of {r.ticks} ticks measured and read "
                             f"back (reached: {r.reached})")
        lines.append("tracking error (measured at the end of each tick - setpoint of that tick):")
        lines.append(f"  {'robot':<6} {'motor':<5} {'max deg':>8} {'rms deg':>8}")
        for r in self.robots:
            if not r.max_deg:
                lines.append(f"  {r.name:<6} (no measurements)")
            for port, mx, rms in zip(r.ports, r.max_deg, r.rms_deg):
                lines.append(f"  {r.name:<6} {port:<5} {mx:>8d} {rms:>8.2f}")
        lines.append("end-effector error (executed by forward kinematics - planned), grid units:")
        lines.append(f"  {'robot':<6} {'max':>8} {'rms':>8}")
        for r in self.robots:
            if r.max_deg:
                lines.append(f"  {r.name:<6} {r.max_grid:>8.3f} {r.rms_grid:>8.3f}{mm(r.max_grid)}")
        if self.payload is not None and self.payload_length_max_grid is not None:
            a, b = self.payload
            lines.append(f"payload {a}-{b} (on the common clock): length error max "
                         f"{self.payload_length_max_grid:.3f}, rms {self.payload_length_rms_grid:.3f}; "
                         f"midpoint error max {self.payload_mid_max_grid:.3f} grid units")
        if self.start_skew is not None:
            sk = self.start_skew
            order = ""
            if self.start_offsets_s:
                first = min(self.start_offsets_s, key=lambda n: self.start_offsets_s[n])  # type: ignore[index]
                last = max(self.start_offsets_s, key=lambda n: self.start_offsets_s[n])  # type: ignore[index]
                if first != last:
                    order = f"{last} after {first}, "
            lines.append(f"start skew (measured from the log): {sk.estimate * 1000:.0f} ms ({order}"
                         f"between {sk.min * 1000:.0f} and {sk.max * 1000:.0f} ms)")
        else:
            lines.append(f"bricks started within {self.start_skew_bound_s * 1000:.0f} ms of each "
                         "other (upper bound)")
        return "\n".join(lines) + "\n"


def _offsets_ticks(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog) -> dict[str, float]:
    """When each brick started after the first one, in ticks (0 without a start interval)."""
    mids = {b.name: (b.start_s[0] + b.start_s[1]) / 2 for b in log.bricks if b.start_s is not None}
    if len(mids) < 2:
        return {r.name: 0.0 for r in traj.robots}
    first = min(mids.values())
    tick_s = traj.tick_ms / 1000.0
    return {r.name: (mids.get(r.name, first) - first) * log.time_scale / tick_s for r in traj.robots}


def _interp_rows(ticks: np.ndarray, rows: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Rows (one per known tick) at fractional tick indices ``at`` (clamped to the known range)."""
    return np.column_stack([np.interp(at, ticks, rows[:, j]) for j in range(rows.shape[1])])


def tracking_report(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog,
                    unit_mm: float | None = None) -> TrackingReport:
    """Compare an execution log (complete or not) with the trajectory it executed.

    Per robot, on its own clock: the measured angle of tick k (taken when tick k ends) against
    the setpoint of tick k, and its end-effector position (forward kinematics) against the
    planned position of tick k, over the ticks measured. The payload is the segment between
    the first two robots' end-effectors (they hold its ends in the payload task); its length
    and midpoint are compared with the plan's on a common clock: each robot's log is shifted by
    how much later its brick started (measured from the log) and interpolated, so a late start
    shows as the payload error it causes.
    """
    robots = []
    executed: dict[str, np.ndarray] = {}
    common: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # name -> (common ticks, xy)
    offsets = _offsets_ticks(traj, log)
    n = traj.ticks
    for robot in traj.robots:
        blog = log.brick(robot.name)
        known = np.array(blog.measured_ticks, dtype=int)
        if len(known) == 0:
            robots.append(RobotTracking(robot.name, tuple(blog.ports), (), (), math.nan, math.nan,
                                        0, n, blog.reached))
            executed[robot.name] = np.zeros((0, 2))
            continue
        measured = np.asarray([blog.measured_deg[k] for k in known], dtype=float)
        reference = np.asarray(blog.reference_deg, dtype=float)[known]
        err = np.abs(measured - reference)
        x, y = robot.xy_from_motor_deg(measured)
        dist = np.hypot(x - robot.x[known], y - robot.y[known])
        robots.append(RobotTracking(
            robot.name, tuple(blog.ports), tuple(int(v) for v in err.max(axis=0)),
            tuple(float(v) for v in np.sqrt((err ** 2).mean(axis=0))),
            float(dist.max()), float(math.sqrt(float((dist ** 2).mean()))),
            len(known), n, blog.reached))
        # on the common clock: at common tick j this brick was at its own (fractional) tick
        # j - offset; beyond its last known tick there is nothing to say
        last = min(n - 1, int(math.floor(known[-1] + offsets[robot.name] + 1e-9)))
        js = np.arange(last + 1)
        own = np.clip(js - offsets[robot.name], 0, n - 1)
        cx, cy = robot.xy_from_motor_deg(_interp_rows(known.astype(float), measured, own))
        common[robot.name] = (js, np.column_stack([cx, cy]))
        executed[robot.name] = common[robot.name][1]
    pair = None
    lmax = lrms = mid = None
    if len(traj.robots) >= 2:
        ra, rb = traj.robots[0], traj.robots[1]
        pair = (ra.name, rb.name)
        if ra.name in common and rb.name in common:
            m = min(len(common[ra.name][0]), len(common[rb.name][0]))
            if m:
                ea, eb = common[ra.name][1][:m], common[rb.name][1][:m]
                pa, pb = ra.path[:m], rb.path[:m]
                dl = np.abs(np.hypot(*(ea - eb).T) - np.hypot(*(pa - pb).T))
                lmax, lrms = float(dl.max()), float(math.sqrt(float((dl ** 2).mean())))
                mid = float(np.hypot(*(((ea + eb) - (pa + pb)) / 2).T).max())
    skew = log.start_skew()
    start_offsets = {name: off * traj.tick_ms / 1000.0 for name, off in offsets.items()} \
        if skew is not None else None
    return TrackingReport(tuple(robots), executed, pair, lmax, lrms, mid, log.start_skew_bound_s,
                          unit_mm, skew, start_offsets, log.stopped)


def skew_verdict(traj: trajectory.Trajectory, log: nxt_link.ExecutionLog
                 ) -> tuple[str | None, str | None]:
    """``(error, warning)`` about the bricks' start skew compared with one tick.

    An error when the bricks certainly started more than a tick apart (the lower bound
    measured from the log exceeds it), a warning when they probably did (the estimate does).
    """
    skew = log.start_skew()
    if skew is None:
        return None, None
    tick = traj.tick_ms / 1000.0
    text = (f"{skew.estimate * 1000:.0f} ms apart (between {skew.min * 1000:.0f} and "
            f"{skew.max * 1000:.0f} ms), more than one tick ({traj.tick_ms} ms)")
    if skew.min > tick:
        return f"the bricks started {text}", None
    if skew.estimate > tick:
        return None, f"the bricks probably started {text}"
    return None, None
