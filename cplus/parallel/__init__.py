"""More than one core for one query: horizons on worker processes (Rintanen's strategies).

* :func:`solve_parallel` — a plain domain's query, the shortest plan by default
  (:mod:`.plan`);
* :func:`search`, :class:`Work` — the search itself, for callers whose models may be refuted
  (a robot task's refinement plugs in here) (:mod:`.dispatch`, :mod:`.work`; a worker
  process: :mod:`.worker`);
* :class:`Strategy` — ``sequential``, ``A``, ``B`` (:mod:`.strategy`).

Imported only by ``cplus plan --jobs`` and ``cplus batch`` (``multiprocessing`` is not part of
the planner's start-up).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from cplus.parallel.plan import AUTO_SWITCH_S, ParallelResult, parallel_info, resolve_jobs, solve_parallel
from cplus.parallel.strategy import DEFAULT_GAMMA, Strategy, available_cores

if TYPE_CHECKING:
    from cplus.parallel.dispatch import MAX_REPLACEMENTS, search
    from cplus.parallel.work import Outcome, Work

_SEARCH = ("MAX_REPLACEMENTS", "Outcome", "Work", "search")


def __getattr__(name: str):
    """The search's names, imported when first used: ``--jobs auto`` on an easy instance never
    starts a worker and should not pay for the module that does (16 ms of imports)."""
    if name in _SEARCH:
        from cplus.parallel import dispatch, work
        return getattr(dispatch if name in ("MAX_REPLACEMENTS", "search") else work, name)
    raise AttributeError(name)


__all__ = ["AUTO_SWITCH_S", "DEFAULT_GAMMA", "MAX_REPLACEMENTS", "Outcome", "ParallelResult", "Strategy", "Work",
           "available_cores", "parallel_info", "resolve_jobs", "search", "solve_parallel"]
