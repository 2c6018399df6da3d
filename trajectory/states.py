"""`StepState`: what `trajectory` needs to know about one state of a plan.

The planner's glue reads the history through the scene's bindings and hands over one
`StepState` per step 0..m: where each end-effector and each payload end is, and which robot
holds which end (the domain's ``on(R,P)``). `trajectory` never sees C+ syntax; ``actions`` is
display text for plots and messages only.

>>> s = StepState(robots={"r1": (0, 0)}, payload={"pl1": (0, 0)}, holds={"pl1": "r1"})
>>> s.robots["r1"], s.holder("pl1")
((0.0, 0.0), 'r1')
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

from .errors import PlanStateError
from .geometry import Point2

__all__ = ["StepState", "validate_states"]


def _point(name: str, value: object) -> Point2:
    try:
        x, y = value  # type: ignore[misc]
        point = (float(x), float(y))  # type: ignore[has-type]
    except (TypeError, ValueError):
        raise PlanStateError(f"position of {name} must be a pair of numbers, not {value!r}") from None
    if not all(math.isfinite(c) for c in point):
        raise PlanStateError(f"position of {name} must be finite, not {value!r}")
    return point


@dataclass(frozen=True, slots=True)
class StepState:
    """One state of a plan: end-effector and payload-end positions, and who holds what.

    Positions are in grid units. ``holds`` maps each payload end to the robot holding it, or
    ``None``; an end missing from ``holds`` is not held. The mappings are stored read-only.
    """

    robots: Mapping[str, Point2]
    payload: Mapping[str, Point2]
    holds: Mapping[str, str | None] = field(default_factory=dict)
    actions: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        robots = {str(k): _point(str(k), v) for k, v in self.robots.items()}
        payload = {str(k): _point(str(k), v) for k, v in self.payload.items()}
        holds = {str(k): (None if v is None else str(v)) for k, v in self.holds.items()}
        object.__setattr__(self, "robots", MappingProxyType(robots))
        object.__setattr__(self, "payload", MappingProxyType(payload))
        object.__setattr__(self, "holds", MappingProxyType(holds))
        object.__setattr__(self, "actions", tuple(str(a) for a in self.actions))

    def holder(self, end: str) -> str | None:
        """The robot holding payload end ``end``, or ``None``."""
        return self.holds.get(end)

    def __hash__(self) -> int:
        return hash((tuple(sorted(self.robots.items())), tuple(sorted(self.payload.items())),
                     tuple(sorted(self.holds.items(), key=lambda kv: kv[0])), self.actions))


def validate_states(robot_names: Sequence[str], end_names: Sequence[str],
                    states: Sequence[StepState]) -> None:
    """Check that every state names exactly the scene's robots and payload ends.

    Raises
    ------
    PlanStateError
        Naming the step and the robot or end that is missing or unknown.
    """
    if not states:
        raise PlanStateError("a plan needs at least one state")
    robots, ends = set(robot_names), set(end_names)
    for i, state in enumerate(states):
        for what, have, want in (("robot", set(state.robots), robots),
                                 ("payload end", set(state.payload), ends)):
            missing = sorted(want - have)
            if missing:
                raise PlanStateError(f"step {i}: no position for {what} {missing[0]}")
            extra = sorted(have - want)
            if extra:
                raise PlanStateError(f"step {i}: {what} {extra[0]} is not in the scene")
        for end, robot in state.holds.items():
            if end not in ends:
                raise PlanStateError(f"step {i}: holds names unknown payload end {end}")
            if robot is not None and robot not in robots:
                raise PlanStateError(f"step {i}: payload end {end} is held by unknown robot {robot}")
