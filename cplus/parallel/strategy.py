"""Which horizons run at once, and what share of a worker's time each gets (Rintanen's
evaluation strategies; pure functions, no processes).

* ``sequential`` (Rintanen's S): one horizon at a time, the next once it is proved empty;
  the baseline, run through the same machinery;
* ``A``: n horizons at once (n = the number of workers), all with the same share; when one is
  proved empty the next horizon not yet started takes its place;
* ``B``: horizon k+i gets the share γ^i of the shortest unfinished horizon k's time; every
  horizon whose share is at least :data:`B_FLOOR` runs (at most :data:`B_MAX` of them, since
  each holds a solver with all its steps), placed on the worker with the least share.  On two
  workers or more (:func:`chained`) horizon k runs alone on the first worker, which takes
  each next k over from the worker that held it, so that its solver goes up one horizon at a
  time as the sequential search's does; k+1, k+2, ... share the other workers, γ^i as above.

The scheduler of :mod:`cplus.parallel.dispatch` asks these functions and nothing else, so a
strategy is one place here.
"""
from __future__ import annotations

from enum import StrEnum

from cplus.options import available_cores

__all__ = ["Strategy", "B_FLOOR", "B_MAX", "in_flight", "share", "chained", "DEFAULT_GAMMA", "DEFAULT_STRATEGY", "available_cores"]

DEFAULT_STRATEGY = "B"
"""What ``--jobs N`` runs without ``--strategy`` (and ``solve_parallel``, a batch's ``jobs``):
B, measured best on two workers (docs/parallel.md, issue 37: ferryman-30-4 0.76× against A's
0.43×, hanoi-7 1.01× against 0.85×, bw-18-s5 0.76× against 0.77×, at load 4 to 6).  Robot
tasks' refinement keeps A (not measured with B)."""

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




def chained(strategy: Strategy, workers: int) -> bool:
    """Whether the shortest unfinished horizon k runs alone on the first worker (strategy B on
    two workers or more), taken over there from whichever worker held it when k reached it.

    Why: what makes the sequential search fast on long plans is that each horizon's solver has
    just proved the horizon below empty.  On ferryman-30-4, horizon 56 is proved empty in
    0.10 s by a solver that proved 55, 0.27 s after 54, 1.13 s after 48 and 1.69 s by a fresh
    one (docs/parallel.md).  B's shares put 8 horizons in flight and give k a share
    1/(1 + γ + ... + γ^7) of the machine, about half a core on two workers, and its solver had
    last seen k-8: each proof took ten times the sequential one.  With the chain, k has a core
    and a solver one horizon behind, as in the sequential search, and the horizons above it
    run on what is left; with one worker there is nothing left, so B time-shares as before."""
    return strategy is Strategy.B and workers >= 2
