"""Which horizons run at once, and what share of a worker's time each gets (Rintanen's
evaluation strategies; pure functions, no processes).

* ``sequential`` (Rintanen's S): one horizon at a time, the next once it is proved empty;
  the baseline, run through the same machinery;
* ``A``: n horizons at once (n = the number of workers), all with the same share; when one is
  proved empty the next horizon not yet started takes its place;
* ``B``: horizon k+i gets the share γ^i of the shortest unfinished horizon k's time; every
  horizon whose share is at least :data:`B_FLOOR` runs (at most :data:`B_MAX` of them, since
  each holds a solver with all its steps), placed on the worker with the least share.

The scheduler of :mod:`cplus.parallel.dispatch` asks these functions and nothing else, so a
strategy is one place here.
"""
from __future__ import annotations

from enum import StrEnum

from cplus.options import available_cores

__all__ = ["Strategy", "B_FLOOR", "B_MAX", "in_flight", "share", "DEFAULT_GAMMA", "available_cores"]

DEFAULT_GAMMA = 0.8
"""γ of strategy B unless told: the plasp paper's worked example (S 46, A 40, B 38 time units)."""

B_FLOOR = 0.2
"""Strategy B leaves out horizons whose share γ^i would be below this (γ 0.8: 8 horizons).
Each horizon in flight is a solver with every step up to it, encoded in Python: with a
floor of 1/20 (14 horizons) B spent 8 times the sequential processor time on ferryman-25-4,
most of it encoding steps for horizons above the plan (bench/bench_parallel.py)."""

B_MAX = 16
"""At most this many horizons at once under strategy B, whatever γ (memory: a solver each)."""


class Strategy(StrEnum):
    SEQUENTIAL = "sequential"
    A = "A"
    B = "B"


def in_flight(strategy: Strategy, workers: int, gamma: float) -> int:
    """How many horizons may run at once."""
    if strategy is Strategy.SEQUENTIAL:
        return 1
    if strategy is Strategy.A:
        return workers
    n = 1
    while n < B_MAX and gamma ** n >= B_FLOOR:
        n += 1
    return max(n, workers)


def share(strategy: Strategy, gamma: float, offset: int) -> float:
    """The share of the horizon ``offset`` above the shortest unfinished one."""
    return gamma ** offset if strategy is Strategy.B else 1.0


def window_based(strategy: Strategy) -> bool:
    """B keeps the horizons k..k+W-1 running (a window over the shortest unfinished k); S and A
    keep a count of horizons running, the next one started as one is proved empty."""
    return strategy is Strategy.B


