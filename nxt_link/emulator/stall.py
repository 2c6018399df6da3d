"""A motor that stalls mid-trajectory: ``cplus brick --stall PORT@SECONDS[+DURATION]``.

For the payload arms' execution monitoring: a joint that gets caught (on a cable, a
hand, an obstacle the plan did not know) holds its motor still however hard the brick
program drives it, so the tracking error grows until the PC notices. :class:`Stall`
blocks one output port's motor (``MotorPhysics.blocked``) from ``after_s`` seconds of
simulated time after that motor *first turned* (so the stall lands at the same point of
a trajectory however long the connection and the upload took), for ``duration_s``
seconds or for good.

>>> Stall.parse("A@2.5"), Stall.parse("b@1+0.5")
(Stall(port=0, after_s=2.5, duration_s=None), Stall(port=1, after_s=1.0, duration_s=0.5))
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from nxt_link.emulator.firmware import Firmware

__all__ = ["Stall", "StallSchedule"]

_SYNTAX = re.compile(r"^\s*([A-Ca-c])\s*@\s*([0-9.]+)\s*(?:\+\s*([0-9.]+))?\s*$")


@dataclass(frozen=True, slots=True)
class Stall:
    """Block output ``port`` (0 = A) ``after_s`` after it first turned, ``duration_s`` long."""

    port: int
    after_s: float
    duration_s: float | None = None

    def __post_init__(self) -> None:
        if self.port not in (0, 1, 2):
            raise ValueError("a stall needs an output port A, B or C")
        if not (math.isfinite(self.after_s) and self.after_s >= 0):
            raise ValueError("a stall's time must be >= 0 s")
        if self.duration_s is not None and not (math.isfinite(self.duration_s)
                                                and self.duration_s > 0):
            raise ValueError("a stall's duration must be > 0 s")

    @classmethod
    def parse(cls, text: str) -> Stall:
        """``PORT@SECONDS`` or ``PORT@SECONDS+DURATION`` (port A, B or C).

        Raises:
            ValueError: with a one-line message.
        """
        m = _SYNTAX.match(text)
        if m is None:
            raise ValueError(f"expected PORT@SECONDS[+DURATION] with PORT in A, B, C, "
                             f"got {text!r}")
        try:
            after = float(m.group(2))
            duration = float(m.group(3)) if m.group(3) is not None else None
        except ValueError:
            raise ValueError(f"not a number of seconds in {text!r}") from None
        return cls("ABC".index(m.group(1).upper()), after, duration)

    def __str__(self) -> str:
        tail = "" if self.duration_s is None else f"+{self.duration_s:g}"
        return f"{'ABC'[self.port]}@{self.after_s:g}{tail}"


@dataclass(slots=True)
class StallSchedule:
    """The environment (``Firmware.attach``) that applies one :class:`Stall`."""

    stall: Stall
    moved_at_ms: int | None = None
    started_at_ms: int | None = None
    ended: bool = False
    _origin: float | None = field(default=None, repr=False)

    def step(self, fw: Firmware) -> None:
        motor = fw.outputs[self.stall.port].motor
        now = fw.now_ms
        if self._origin is None:
            self._origin = motor.motor_deg
        if self.moved_at_ms is None:
            if abs(motor.motor_deg - self._origin) >= 1.0:
                self.moved_at_ms = now
            return
        if self.ended:
            return
        if self.started_at_ms is None:
            if now - self.moved_at_ms >= self.stall.after_s * 1000.0:
                self.started_at_ms = now
                motor.blocked = True
            return
        if self.stall.duration_s is not None and \
                now - self.started_at_ms >= self.stall.duration_s * 1000.0:
            motor.blocked = False
            self.ended = True
        else:
            motor.blocked = True

    @property
    def active(self) -> bool:
        return self.started_at_ms is not None and not self.ended
