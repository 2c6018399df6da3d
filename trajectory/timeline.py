"""A run over time, as the pictures need it: per brick, its setpoints and encoder readings
tick by tick, when it started, and what happened to it; for the run, where it stopped.

`trajectory` never reads an execution log itself (the log's format belongs to ``nxt_link``);
the command-line glue converts one into a `RunTimeline`, and `plot_execution` and
`animate_run` draw it. An online run's log becomes `CycleFrame` s for `animate_cycles`. Times are seconds on one clock (the PC's, from the start of the
execution); a tick lasts ``tick_s`` on that clock.

>>> b = BrickTimeline("r1", ("A",), 0.1, [[0], [5]], [[0], [4]], start_s=(1.0, 1.02))
>>> b.tick_end_s.round(2).tolist(), b.error_deg.tolist()
([1.11, 1.21], [[0.0], [-1.0]])
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
import numpy.typing as npt

from .errors import TrajectoryError

__all__ = ["BrickTimeline", "CycleFrame", "RunTimeline", "MILESTONES", "STALL_ERROR_DEG"]

#: Events that mark a brick's phases (drawn as the phase bars, not as separate marks).
MILESTONES = ("program started", "link ok", "upload verified", "homing", "ready", "start sent",
              "start acked", "log read")

FloatArray = npt.NDArray[np.float64]

#: A tracking error beyond this many degrees is a motor that is not following (stalled,
#: caught, held): the threshold the online payload monitor re-plans at
#: (``cplus.robot.online.payload_monitor.TRACKING_THRESHOLD_DEG``; a test holds them equal),
#: so that the picture of a run marks what the monitor would have acted on.
STALL_ERROR_DEG = 30.0


def _rows(name: str, what: str, values: npt.ArrayLike, width: int) -> FloatArray:
    rows = np.asarray(values, dtype=float)
    if rows.size == 0:
        rows = rows.reshape(0, width)
    if rows.ndim != 2 or rows.shape[1] != width:
        raise TrajectoryError(f"brick {name}: {what} must have one value per motor ({width}) in every row")
    return rows


@dataclass(frozen=True, slots=True, eq=False)
class BrickTimeline:
    """One brick's run: ``setpoint_deg[k]`` the row it followed during tick ``k``,
    ``measured_deg[k]`` its encoders at the end of tick ``k`` (NaN: not read back; fewer rows
    than setpoints: the run stopped). ``start_s`` is the interval in which it started following
    (None: it never started); ``events`` are ``(t_s, event, detail)``."""

    name: str
    ports: tuple[str, ...]
    tick_s: float
    setpoint_deg: FloatArray
    measured_deg: FloatArray
    start_s: tuple[float, float] | None = None
    events: tuple[tuple[float, str, str], ...] = ()
    reached: str = "done"

    def __post_init__(self) -> None:
        object.__setattr__(self, "ports", tuple(self.ports))
        width = len(self.ports)
        setpoints = _rows(self.name, "setpoints", self.setpoint_deg, width)
        measured = _rows(self.name, "measurements", self.measured_deg, width)
        if len(measured) > len(setpoints):
            raise TrajectoryError(f"brick {self.name}: {len(measured)} measured rows for {len(setpoints)} ticks")
        padded = np.full(setpoints.shape, np.nan)
        padded[:len(measured)] = measured
        object.__setattr__(self, "setpoint_deg", setpoints)
        object.__setattr__(self, "measured_deg", padded)
        if not (math.isfinite(self.tick_s) and self.tick_s > 0):
            raise TrajectoryError(f"brick {self.name}: a tick must last a positive time, not {self.tick_s}")
        object.__setattr__(self, "events", tuple((float(t), str(e), str(d)) for t, e, d in self.events))

    @property
    def start_mid_s(self) -> float | None:
        """The middle of the start interval: when tick 0 began, as well as the log knows."""
        return None if self.start_s is None else (self.start_s[0] + self.start_s[1]) / 2

    @property
    def tick_end_s(self) -> FloatArray:
        """When each tick ended (NaN for every tick when the brick never started)."""
        k = np.arange(1, len(self.setpoint_deg) + 1, dtype=float)
        start = self.start_mid_s
        return np.full(k.shape, np.nan) if start is None else start + k * self.tick_s

    @property
    def error_deg(self) -> FloatArray:
        """measured - setpoint per tick and motor (NaN where nothing was measured)."""
        return self.measured_deg - self.setpoint_deg

    def stall_spans(self, threshold_deg: float = STALL_ERROR_DEG) -> list[tuple[str, float, float]]:
        """``(port, from_s, to_s)`` for every run of ticks in which a motor's error is beyond
        ``threshold_deg``: where it was not following (from the end of the tick before the
        first such tick to the end of the last).

        >>> b = BrickTimeline("r1", ("A", "B"), 0.1, [[0, 0], [40, 5], [80, 9], [90, 9]],
        ...                   [[0, 0], [2, 5], [3, 9], [88, 9]], start_s=(1.0, 1.0))
        >>> [(p, round(a, 2), round(z, 2)) for p, a, z in b.stall_spans()]
        [('A', 1.1, 1.3)]
        """
        out: list[tuple[str, float, float]] = []
        t = self.tick_end_s
        err = np.abs(self.error_deg)
        for j, port in enumerate(self.ports):
            over = np.concatenate(([False], np.nan_to_num(err[:, j]) > threshold_deg, [False]))
            edges = np.flatnonzero(over[1:] != over[:-1])
            for a, z in zip(edges[::2], edges[1::2]):      # ticks a .. z-1 are over
                out.append((port, float(t[a] - self.tick_s), float(t[z - 1])))
        return [s for s in out if math.isfinite(s[1])]

    @property
    def measured_ticks(self) -> int:
        """How many ticks have a measurement."""
        return int(np.all(np.isfinite(self.measured_deg), axis=1).sum())


@dataclass(frozen=True, slots=True, eq=False)
class RunTimeline:
    """Every brick of one execution; ``stopped`` is ``(t_s, reason)`` when it ended early, and
    ``skew_s`` the start skew measured from the log, ``(estimate, min, max)``, when known.
    ``clock`` names the clock of its times, as the time axes say it: ``"PC clock"``, or
    ``"simulated clock"`` for emulated bricks on simulated time (no wall clock involved)."""

    bricks: tuple[BrickTimeline, ...]
    stopped: tuple[float, str] | None = None
    skew_s: tuple[float, float, float] | None = None
    clock: str = "PC clock"
    names: tuple[str, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "bricks", tuple(self.bricks))
        if not self.bricks:
            raise TrajectoryError("a run timeline needs at least one brick")
        object.__setattr__(self, "names", tuple(b.name for b in self.bricks))
        if len(set(self.names)) != len(self.names):
            raise TrajectoryError("a run timeline names a brick twice")

    def brick(self, name: str) -> BrickTimeline:
        """The brick called ``name``; `KeyError` if there is none."""
        for b in self.bricks:
            if b.name == name:
                return b
        raise KeyError(name)

    @property
    def first_start_s(self) -> float | None:
        """When the first brick started (None: none did)."""
        starts = [b.start_mid_s for b in self.bricks if b.start_mid_s is not None]
        return min(starts) if starts else None

    def span_s(self) -> tuple[float, float]:
        """From 0 to the last thing known: an event, a tick's end or the stop."""
        ends = [0.0]
        for b in self.bricks:
            ends += [t for t, _, _ in b.events]
            ticks = b.tick_end_s
            if len(ticks) and np.isfinite(ticks[-1]):
                ends.append(float(ticks[-1]))
        if self.stopped is not None:
            ends.append(self.stopped[0])
        return 0.0, max(ends)

    def run_span_s(self) -> tuple[float, float] | None:
        """From the first brick's start to the end of the last tick of any brick that started
        (None: none did)."""
        start = self.first_start_s
        if start is None:
            return None
        ends = [float(b.tick_end_s[-1]) for b in self.bricks if b.start_mid_s is not None and len(b.setpoint_deg)]
        return start, max([start + 1e-3, *ends])



@dataclass(frozen=True, slots=True)
class CycleFrame:
    """One cycle of an online run, as a replay draws it: when, the state (fluent -> value
    text), where the scene's bodies are (robot and payload-end names -> grid position; empty
    when the run has no scene), the run's trace of this cycle (``lines``: actions, events,
    the re-plan and its reason, a failure), and whether it re-planned or failed; ``ended``
    marks the frame of the run's end (after its last cycle). ``actions`` are the actions the
    cycle executed, as text (``"follow"``, ``"move(r1,right,steps=1) x2"``)."""

    cycle: int
    time_s: float
    state: Mapping[str, str]
    positions: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    lines: tuple[str, ...] = ()
    replanned: bool = False
    failed: bool = False
    ended: bool = False
    actions: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "state", MappingProxyType({str(k): str(v) for k, v in self.state.items()}))
        object.__setattr__(self, "positions", MappingProxyType(
            {str(k): (float(v[0]), float(v[1])) for k, v in self.positions.items()}))
        object.__setattr__(self, "lines", tuple(str(x) for x in self.lines))
        object.__setattr__(self, "actions", tuple(str(x) for x in self.actions))
