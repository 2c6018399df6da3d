"""The execution log: what each brick was told to do and what its encoders said.

Schema ``cplus.execlog/1`` (JSON)::

    {
      "format": "cplus.execlog/1",
      "complete": true,
      "time_scale": 1,
      "start_skew_bound_s": 0.031,
      "bricks": [
        {
          "name": "r1",
          "ports": ["A", "B"],
          "tick_ms": 50,
          "reached": "done",
          "start_s": [1.204, 1.229],
          "reference_deg": [[0, 0], [3, -1], ...],
          "measured_deg":  [[0, 0], [2, -1], ...],
          "events": [{"t_s": 0.12, "event": "start acked", "detail": "GO seq 12"}, ...]
        }
      ]
    }

``reference_deg[k]`` is the setpoint row k the brick followed during tick k
(verified against the brick's checksum of what it stored); ``measured_deg[k]``
is the encoder angle (NXC RotationCount) at the end of tick k. Both have one
row per tick and one integer per port, in ``ports`` order. ``t_s`` counts from
the start of the execution on the PC's clock. ``start_s`` is the interval in
which the brick started following its setpoints, on the same clock, measured
from the start signal and the brick's progress reports; ``time_scale`` is how
many times faster the bricks' clocks ran (emulated bricks; 1 for real ones),
so a tick lasts ``tick_ms / time_scale`` on that clock. ``start_skew_bound_s``
bounds how far apart the bricks started (bricks' seconds).

A run that failed is still logged, marked ``"complete": false`` with
``"stopped": {"t_s": ..., "reason": "...", "brick": "r2"}`` (``brick`` is null
when no single brick caused it). Each brick then says how far it got
(``reached``: connect, upload, homing, start, run, log, done, stopped) and
``measured_deg`` holds the rows read back: it may be shorter than
``reference_deg``, and a row the brick logged but that could not be read back
is ``null``. Logs without ``complete`` are complete (older files).

The loader validates all of it and raises :class:`~nxt_link.wire.errors.ExecLogError`
naming the offending field.

>>> log = ExecutionLog((BrickLog("r1", ("A",), 50, ((0,), (5,)), ((0,), (4,)), ()),), 0.0)
>>> ExecutionLog.loads(log.dumps()) == log
True
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

from nxt_link.wire.errors import ExecLogError

__all__ = ["FORMAT", "PHASES", "LogEvent", "BrickLog", "Stopped", "StartSkew", "ExecutionLog"]

FORMAT = "cplus.execlog/1"
#: How far a brick got, in order.
PHASES = ("connect", "upload", "homing", "start", "run", "log", "done", "stopped")

Row = tuple[int, ...]


@dataclass(frozen=True, slots=True)
class LogEvent:
    t_s: float
    event: str
    detail: str = ""


@dataclass(frozen=True, slots=True)
class BrickLog:
    """Everything recorded for one brick.

    ``measured_deg`` has one row per tick in a complete log; after a failure it may
    be shorter, with ``None`` for rows the brick logged but that were not read back.
    """

    name: str
    ports: tuple[str, ...]
    tick_ms: int
    reference_deg: tuple[Row, ...]
    measured_deg: tuple[Row | None, ...]
    events: tuple[LogEvent, ...]
    start_s: tuple[float, float] | None = None
    reached: str = "done"

    def __post_init__(self) -> None:
        where = f"bricks[{self.name}]"
        if len(self.measured_deg) > len(self.reference_deg):
            raise ExecLogError(f"{where}: {len(self.reference_deg)} reference rows but "
                               f"{len(self.measured_deg)} measured rows")
        for field_name in ("reference_deg", "measured_deg"):
            for k, row in enumerate(getattr(self, field_name)):
                if row is None and field_name == "measured_deg":
                    continue
                if row is None or len(row) != len(self.ports):
                    raise ExecLogError(f"{where}.{field_name}[{k}]: "
                                       f"{0 if row is None else len(row)} values for "
                                       f"{len(self.ports)} ports")
        if self.start_s is not None and not self.start_s[0] <= self.start_s[1]:
            raise ExecLogError(f"{where}.start_s: [{self.start_s[0]}, {self.start_s[1]}] is "
                               "not an interval")
        if self.reached not in PHASES:
            raise ExecLogError(f"{where}.reached: {self.reached!r} is not one of "
                               f"{', '.join(PHASES)}")

    @property
    def complete(self) -> bool:
        """One measured row per tick, none missing."""
        return (len(self.measured_deg) == len(self.reference_deg)
                and all(r is not None for r in self.measured_deg))

    @property
    def measured_ticks(self) -> tuple[int, ...]:
        """The ticks whose measured row is known."""
        return tuple(k for k, r in enumerate(self.measured_deg) if r is not None)

    @property
    def tracking_error_deg(self) -> tuple[Row, ...]:
        """measured - reference, per measured tick (every tick of a complete log) and port."""
        return tuple(tuple(m - r for m, r in zip(mr, rr))
                     for mr, rr in zip(self.measured_deg, self.reference_deg) if mr is not None)


@dataclass(frozen=True, slots=True)
class Stopped:
    """Why and when an execution stopped before its end."""

    t_s: float
    reason: str
    brick: str | None = None


@dataclass(frozen=True, slots=True)
class StartSkew:
    """How far apart the bricks started, in the bricks' seconds.

    ``estimate`` compares the middles of the bricks' start intervals; the true
    skew lies in [``min``, ``max``].
    """

    estimate: float
    min: float
    max: float


@dataclass(frozen=True, slots=True)
class ExecutionLog:
    """Logs of all bricks of one execution (complete unless ``stopped`` says why not)."""

    bricks: tuple[BrickLog, ...]
    start_skew_bound_s: float = 0.0
    stopped: Stopped | None = None
    time_scale: float = 1.0

    def __post_init__(self) -> None:
        if self.stopped is None:
            for b in self.bricks:
                if not b.complete:
                    raise ExecLogError(f"bricks[{b.name}]: {len(b.reference_deg)} reference rows "
                                       f"but {len(b.measured_deg)} measured rows in a complete log"
                                       if len(b.measured_deg) != len(b.reference_deg) else
                                       f"bricks[{b.name}].measured_deg: a row is missing in a "
                                       "complete log")
        if not (math.isfinite(self.time_scale) and self.time_scale > 0):
            raise ExecLogError("time_scale: must be a number > 0")

    @property
    def complete(self) -> bool:
        return self.stopped is None

    def brick(self, name: str) -> BrickLog:
        for b in self.bricks:
            if b.name == name:
                return b
        raise KeyError(name)

    def start_skew(self) -> StartSkew | None:
        """The skew between the bricks' starts, from their start intervals.

        None when fewer than two bricks have a start interval.
        """
        windows = [b.start_s for b in self.bricks if b.start_s is not None]
        if len(windows) < 2:
            return None
        x = self.time_scale
        mids = [(lo + hi) / 2 for lo, hi in windows]
        upper = max(hi for _, hi in windows) - min(lo for lo, _ in windows)
        lower = max(0.0, max(lo for lo, _ in windows) - min(hi for _, hi in windows))
        return StartSkew((max(mids) - min(mids)) * x, lower * x, upper * x)

    # -- JSON ---------------------------------------------------------------------

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"format": FORMAT, "complete": self.complete}
        if self.stopped is not None:
            out["stopped"] = {"t_s": self.stopped.t_s, "reason": self.stopped.reason,
                              "brick": self.stopped.brick}
        out["time_scale"] = self.time_scale
        out["start_skew_bound_s"] = self.start_skew_bound_s
        bricks = []
        for b in self.bricks:
            entry: dict[str, Any] = {"name": b.name, "ports": list(b.ports), "tick_ms": b.tick_ms,
                                     "reached": b.reached}
            if b.start_s is not None:
                entry["start_s"] = list(b.start_s)
            entry["reference_deg"] = [list(r) for r in b.reference_deg]
            entry["measured_deg"] = [None if r is None else list(r) for r in b.measured_deg]
            entry["events"] = [{"t_s": e.t_s, "event": e.event, "detail": e.detail}
                               for e in b.events]
            bricks.append(entry)
        out["bricks"] = bricks
        return out

    def dumps(self) -> str:
        return json.dumps(self.to_json(), indent=1)

    @classmethod
    def loads(cls, text: str) -> ExecutionLog:
        """Parse and validate a ``cplus.execlog/1`` document.

        Raises:
            ExecLogError: invalid JSON or a field that does not validate.
        """
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ExecLogError(f"not JSON: {exc.msg} at line {exc.lineno}") from None
        except RecursionError:
            raise ExecLogError("not an execution log: JSON nested too deeply") from None
        return cls.from_json(data)

    @classmethod
    def from_json(cls, data: Any) -> ExecutionLog:
        if not isinstance(data, dict):
            raise ExecLogError("execution log must be a JSON object")
        if data.get("format") != FORMAT:
            raise ExecLogError(f"format: expected {FORMAT!r}, got {data.get('format')!r}")
        skew = data.get("start_skew_bound_s", 0.0)
        if not _is_number(skew) or skew < 0:
            raise ExecLogError("start_skew_bound_s: must be a number >= 0")
        scale = data.get("time_scale", 1)
        if not _is_number(scale) or scale <= 0:
            raise ExecLogError("time_scale: must be a number > 0")
        complete = data.get("complete", True)
        if not isinstance(complete, bool):
            raise ExecLogError("complete: must be true or false")
        stopped = None
        if not complete:
            st = data.get("stopped")
            if (not isinstance(st, dict) or not _is_number(st.get("t_s"))
                    or not isinstance(st.get("reason"), str)
                    or not isinstance(st.get("brick"), (str, type(None)))):
                raise ExecLogError("stopped: an incomplete log needs stopped.t_s (number), "
                                   "stopped.reason and stopped.brick (string or null)")
            stopped = Stopped(float(st["t_s"]), st["reason"], st["brick"])
        bricks = data.get("bricks")
        if not isinstance(bricks, list) or not bricks:
            raise ExecLogError("bricks: must be a non-empty list")
        out = []
        names: set[str] = set()
        for i, b in enumerate(bricks):
            out.append(_brick_from_json(b, f"bricks[{i}]", names, complete))
        return cls(tuple(out), float(skew), stopped, float(scale))


def _brick_from_json(b: Any, where: str, names: set[str], complete: bool) -> BrickLog:
    if not isinstance(b, dict):
        raise ExecLogError(f"{where}: must be an object")
    name = b.get("name")
    if not isinstance(name, str) or not name:
        raise ExecLogError(f"{where}.name: must be a non-empty string")
    if name in names:
        raise ExecLogError(f"{where}.name: duplicate brick {name!r}")
    names.add(name)
    ports = b.get("ports")
    if (not isinstance(ports, list) or not ports
            or not all(p in ("A", "B", "C") for p in ports) or len(set(ports)) != len(ports)):
        raise ExecLogError(f"{where}.ports: must be distinct names among A, B, C")
    tick = b.get("tick_ms")
    if not isinstance(tick, int) or isinstance(tick, bool) or tick <= 0:
        raise ExecLogError(f"{where}.tick_ms: must be a positive integer")
    reached = b.get("reached", "done")
    if reached not in PHASES:
        raise ExecLogError(f"{where}.reached: must be one of {', '.join(PHASES)}")
    start = b.get("start_s")
    if start is not None and (not isinstance(start, list) or len(start) != 2
                              or not all(_is_number(v) for v in start) or start[0] > start[1]):
        raise ExecLogError(f"{where}.start_s: must be [earliest, latest] (numbers)")
    rows: dict[str, tuple[Row | None, ...]] = {}
    for key in ("reference_deg", "measured_deg"):
        value = b.get(key)
        if not isinstance(value, list):
            raise ExecLogError(f"{where}.{key}: must be a list of rows")
        parsed: list[Row | None] = []
        for k, row in enumerate(value):
            if row is None and key == "measured_deg" and not complete:
                parsed.append(None)
                continue
            if (not isinstance(row, list) or len(row) != len(ports)
                    or not all(isinstance(v, int) and not isinstance(v, bool) for v in row)):
                raise ExecLogError(f"{where}.{key}[{k}]: must be {len(ports)} integers")
            parsed.append(tuple(row))
        rows[key] = tuple(parsed)
    reference = rows["reference_deg"]
    measured = rows["measured_deg"]
    if complete and len(measured) != len(reference):
        raise ExecLogError(f"{where}: {len(reference)} reference rows but {len(measured)} "
                           "measured rows")
    events = b.get("events", [])
    if not isinstance(events, list):
        raise ExecLogError(f"{where}.events: must be a list")
    evs = []
    for k, e in enumerate(events):
        if (not isinstance(e, dict) or not _is_number(e.get("t_s"))
                or not isinstance(e.get("event"), str)
                or not isinstance(e.get("detail", ""), str)):
            raise ExecLogError(f"{where}.events[{k}]: needs t_s (number), event, detail")
        evs.append(LogEvent(float(e["t_s"]), e["event"], e.get("detail", "")))
    try:
        return BrickLog(name, tuple(ports), tick, reference,  # type: ignore[arg-type]
                        measured, tuple(evs),
                        None if start is None else (float(start[0]), float(start[1])), reached)
    except ExecLogError as exc:
        raise ExecLogError(str(exc).replace(f"bricks[{name}]", where, 1)) from None


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
