"""The execution log: what each brick was told to do and what its encoders said.

Schema ``cplus.execlog/1`` (JSON)::

    {
      "format": "cplus.execlog/1",
      "start_skew_bound_s": 0.031,
      "bricks": [
        {
          "name": "r1",
          "ports": ["A", "B"],
          "tick_ms": 50,
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
the start of the execution. ``start_skew_bound_s`` bounds how far apart the
bricks started. The loader validates all of it and raises
:class:`~nxt_link.errors.ExecLogError` naming the offending field.

>>> log = ExecutionLog((BrickLog("r1", ("A",), 50, ((0,), (5,)), ((0,), (4,)), ()),), 0.0)
>>> ExecutionLog.loads(log.dumps()) == log
True
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

from nxt_link.errors import ExecLogError

__all__ = ["FORMAT", "LogEvent", "BrickLog", "ExecutionLog"]

FORMAT = "cplus.execlog/1"


@dataclass(frozen=True, slots=True)
class LogEvent:
    t_s: float
    event: str
    detail: str = ""


@dataclass(frozen=True, slots=True)
class BrickLog:
    """Everything recorded for one brick."""

    name: str
    ports: tuple[str, ...]
    tick_ms: int
    reference_deg: tuple[tuple[int, ...], ...]
    measured_deg: tuple[tuple[int, ...], ...]
    events: tuple[LogEvent, ...]

    def __post_init__(self) -> None:
        where = f"bricks[{self.name}]"
        if len(self.reference_deg) != len(self.measured_deg):
            raise ExecLogError(f"{where}: {len(self.reference_deg)} reference rows but "
                               f"{len(self.measured_deg)} measured rows")
        for field_name in ("reference_deg", "measured_deg"):
            for k, row in enumerate(getattr(self, field_name)):
                if len(row) != len(self.ports):
                    raise ExecLogError(f"{where}.{field_name}[{k}]: {len(row)} values for "
                                       f"{len(self.ports)} ports")

    @property
    def tracking_error_deg(self) -> tuple[tuple[int, ...], ...]:
        """measured - reference, per tick and port."""
        return tuple(tuple(m - r for m, r in zip(mr, rr))
                     for mr, rr in zip(self.measured_deg, self.reference_deg))


@dataclass(frozen=True, slots=True)
class ExecutionLog:
    """Logs of all bricks of one execution."""

    bricks: tuple[BrickLog, ...]
    start_skew_bound_s: float = 0.0

    def brick(self, name: str) -> BrickLog:
        for b in self.bricks:
            if b.name == name:
                return b
        raise KeyError(name)

    # -- JSON ---------------------------------------------------------------------

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "start_skew_bound_s": self.start_skew_bound_s,
            "bricks": [
                {
                    "name": b.name,
                    "ports": list(b.ports),
                    "tick_ms": b.tick_ms,
                    "reference_deg": [list(r) for r in b.reference_deg],
                    "measured_deg": [list(r) for r in b.measured_deg],
                    "events": [{"t_s": e.t_s, "event": e.event, "detail": e.detail}
                               for e in b.events],
                }
                for b in self.bricks
            ],
        }

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
        bricks = data.get("bricks")
        if not isinstance(bricks, list) or not bricks:
            raise ExecLogError("bricks: must be a non-empty list")
        out = []
        names: set[str] = set()
        for i, b in enumerate(bricks):
            where = f"bricks[{i}]"
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
            rows = {}
            for key in ("reference_deg", "measured_deg"):
                value = b.get(key)
                if not isinstance(value, list):
                    raise ExecLogError(f"{where}.{key}: must be a list of rows")
                for k, row in enumerate(value):
                    if (not isinstance(row, list) or len(row) != len(ports)
                            or not all(isinstance(v, int) and not isinstance(v, bool) for v in row)):
                        raise ExecLogError(f"{where}.{key}[{k}]: must be {len(ports)} integers")
                rows[key] = tuple(tuple(r) for r in value)
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
            out.append(BrickLog(name, tuple(ports), tick, rows["reference_deg"],
                                rows["measured_deg"], tuple(evs)))
        return cls(tuple(out), float(skew))


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
