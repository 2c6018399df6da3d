"""What the continuous checker reports: one :class:`Violation` per problem of a motion.

Its own module so that :mod:`trajectory.errors` (which wraps a violation in an error) and
:mod:`trajectory.checker` (which finds them) need not import each other.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = ["Violation", "ViolationKind"]

Point2 = tuple[float, float]


class ViolationKind(enum.Enum):
    """What went wrong; the order is the tie-break between violations at the same time."""

    DETACHED = "detached"
    OUT_OF_REACH = "out-of-reach"
    JOINT_LIMIT = "joint-limit"
    EFFECTOR_COLLISION = "effector-collision"
    PAYLOAD_COLLISION = "payload-collision"
    PAYLOAD_LENGTH = "payload-length"


_ORDER = {kind: k for k, kind in enumerate(ViolationKind)}


@dataclass(frozen=True, slots=True)
class Violation:
    """One problem of the motion from state ``step`` to state ``step + 1``.

    ``u`` in [0, 1] is when it starts within that motion (0 = at state ``step``) and
    ``point`` where. ``subject`` is ``"payload"``, a robot name or a payload-end name;
    ``obstacle`` names the obstacle hit, if any.

    >>> v = Violation(2, ViolationKind.PAYLOAD_LENGTH, 0.25, (3.0, 4.0), "payload", "too short")
    >>> v.time_s(step_time_s=2.0)   # a quarter into the motion from state 2 to 3
    4.5
    >>> w = Violation(2, ViolationKind.DETACHED, 0.25, (3.0, 4.0), "pl1", "dropped")
    >>> [x.kind.value for x in sorted([v, w], key=lambda x: x.sort_key)]   # same time: by kind
    ['detached', 'payload-length']
    """

    step: int
    kind: ViolationKind
    u: float
    point: Point2
    subject: str
    message: str
    obstacle: str | None = None

    @property
    def sort_key(self) -> tuple[int, float, int, str]:
        return (self.step, self.u, _ORDER[self.kind], self.subject)

    def time_s(self, step_time_s: float) -> float:
        """Seconds from the start of the plan, when each step takes ``step_time_s``."""
        return (self.step + self.u) * step_time_s
