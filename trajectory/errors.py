"""The exception tree of the `trajectory` package.

Every error a user can cause (a bad scene file, a point no arm can reach, a malformed
trajectory file, a plan whose states do not match the scene) is a `TrajectoryError`. When the
error comes from a file, it carries a `Location` and renders as
``file:line:col: error: message`` so the CLI can print it as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

from .violations import Violation

__all__ = [
    "Location",
    "TrajectoryError",
    "SceneError",
    "UnreachableError",
    "JointLimitError",
    "PlanStateError",
    "PlanViolationError",
    "TrajectoryFormatError",
]


@dataclass(frozen=True, slots=True)
class Location:
    """A position in a source file: 1-based line and column."""

    file: str
    line: int
    col: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


class TrajectoryError(Exception):
    """Root of every error raised by `trajectory` for bad input.

    ``message`` is the bare text; ``location`` (optional) says where in which file.
    ``str(err)`` is ``file:line:col: error: message`` when located, else ``error: message``.

    >>> str(TrajectoryError("robot r3 is not in the scene"))
    'error: robot r3 is not in the scene'
    >>> err = SceneError("payload.length must be positive", Location("scene.toml", 12, 10))
    >>> str(err), err.message
    ('scene.toml:12:10: error: payload.length must be positive', 'payload.length must be positive')
    """

    def __init__(self, message: str, location: Location | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.location = location

    def __str__(self) -> str:
        if self.location is None:
            return f"error: {self.message}"
        return f"{self.location}: error: {self.message}"


class SceneError(TrajectoryError):
    """A scene file is malformed or inconsistent (missing field, open polygon, ...)."""


class UnreachableError(TrajectoryError):
    """A point lies outside an arm's reach (its distance from the rail exceeds the arm)."""


class JointLimitError(TrajectoryError):
    """A point is within reach, but no IK branch keeps the joints inside their limits."""


class PlanStateError(TrajectoryError):
    """The plan states handed to `trajectory` do not match the scene (unknown robot, ...)."""


class TrajectoryFormatError(TrajectoryError):
    """A trajectory file does not follow `cplus.trajectory/1`; the message names the field.

    ``field`` is the offending field's path (``robots[0].samples.x``) when there is one.
    """

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class PlanViolationError(TrajectoryError):
    """A plan was asked to become a trajectory but the continuous check rejects it."""

    def __init__(self, violation: Violation) -> None:
        super().__init__(violation.message)
        self.violation = violation
