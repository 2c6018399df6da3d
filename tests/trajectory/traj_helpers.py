"""Helpers for the trajectory tests: scene paths, carried states, hand-made payload plans."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from trajectory import StepState

REPO = Path(__file__).resolve().parents[2]
PAYLOAD_SCENE = REPO / "domains" / "payload" / "scene.toml"

Point = tuple[float, float]


def carried(p1: Point, p2: Point, actions: Sequence[str] = ()) -> StepState:
    """A state where r1 holds pl1 at p1 and r2 holds pl2 at p2."""
    return StepState({"r1": p1, "r2": p2}, {"pl1": p1, "pl2": p2}, {"pl1": "r1", "pl2": "r2"},
                     tuple(actions))


def plan(*pairs: tuple[Point, Point]) -> list[StepState]:
    """Carried states from (r1, r2) position pairs."""
    return [carried(p, q) for p, q in pairs]


# A plan the payload domain allows (every grid-point law holds) and the continuous check
# accepts: found by a discrete simulation of the domain with Algorithm 1 (see scene.toml).
CLEAN_PAYLOAD_PLAN = [
    ((0, 0), (0, 5)), ((0, 0), (0, 5)), ((1, 1), (1, 6)), ((2, 2), (2, 7)), ((6, 2), (5, 7)),
    ((7, 1), (6, 6)), ((8, 0), (7, 5)), ((9, -1), (8, 4)), ((10, 0), (9, 5)), ((10, 0), (10, 5)),
]

# The first plan of that simulation: grid-point clean, but from step 3 to 4 the stick is
# rotated from (2,2)-(2,7) to (6,2)-(3,6) and its squared length dips to 22.5 < 23 mid-way.
FIRST_PAYLOAD_PLAN = [
    ((0, 0), (0, 5)), ((0, 0), (0, 5)), ((1, 1), (1, 6)), ((2, 2), (2, 7)), ((6, 2), (3, 6)),
    ((7, 1), (4, 5)), ((8, 0), (5, 4)), ((9, 0), (6, 4)), ((10, 0), (9, 5)), ((10, 0), (10, 5)),
]
