"""The planner's options and their bounds, in one place: ``cplus plan``'s command line, a
batch's job files (``options = {...}``, ``timeout``, ``memory``, ``portfolio``) and the Python
API (:meth:`cplus.api.Domain.solve`, :func:`cplus.parallel.solve_parallel`) all check a value
here, so that a value one of them refuses is refused by the others, with the same words.

Every check takes the value as it arrived (a number from TOML or JSON, a Python argument, or
the text of a command-line flag after :func:`from_text`) and returns it checked, or raises
:class:`OptionError` with a message that says what is expected and what was given; the caller
adds where (``--jobs``, ``jobs.toml:3: option 'jobs'``).  A number is either honoured or
refused: nothing is clamped here.  How many worker processes actually start is the search's
bound on top (:func:`worker_bound`): never more than there are horizons to run at once, nor
more than :data:`WORKERS_PER_CORE` per core.

>>> check_jobs(4), check_jobs("auto")
(4, 'auto')
>>> check_gamma(0)
Traceback (most recent call last):
...
cplus.options.OptionError: must be > 0 and at most 1, got 0
>>> check_plan_options({"jobs": 2, "strategy": "B", "gamma": 0.5})
{'jobs': 2, 'strategy': 'B', 'gamma': 0.5}
"""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from typing import Any

from cplus.errors import CPlusError

__all__ = ["OptionError", "MAX_JOBS", "WORKERS_PER_CORE", "MAX_TIMEOUT_S", "MAX_MEMORY_MB", "MAX_HORIZON",
           "STRATEGIES", "check_jobs", "check_gamma", "check_timeout", "check_time_limit", "check_memory",
           "check_solutions", "check_max_horizon", "check_max_iterations", "check_strategy", "check_solver",
           "check_portfolio", "check_label", "check_term", "check_plan_options", "PLAN_OPTIONS", "worker_bound",
           "available_cores", "from_text", "named"]

MAX_JOBS = 1024
"""The largest ``--jobs N`` (or ``jobs``, ``--workers``) accepted: more worker processes than
any machine this runs on has cores for.  Fewer start when fewer can work (:func:`worker_bound`)."""

WORKERS_PER_CORE = 4
"""At most this many worker processes per core of this process (its affinity mask), whatever
``--jobs`` says: each is a solver competing for the same cores, and beyond a few per core they
only add memory and switching."""

MAX_TIMEOUT_S = 1_000_000.0
"""The longest time limit (seconds, about 11.6 days): a kernel timer takes whole seconds in a C
``long``, and ``1e300`` would wrap to a timer that fires at once."""

MAX_MEMORY_MB = 1 << 24
"""The largest memory limit (MB: 16 TiB), so that the limit in bytes fits ``RLIMIT_AS``."""

MAX_HORIZON = 100_000
"""The largest ``--max-horizon``: a hundred thousand steps, far beyond what the memory of any
machine holds for the smallest domain (the planner's size checks refuse long before)."""

STRATEGIES = ("sequential", "A", "B")
"""The parallel search's strategies (:class:`cplus.parallel.Strategy`), also portfolio entries."""


class OptionError(CPlusError, ValueError):
    """A planner option outside its bounds (the message says what is expected and what came;
    the caller says which option, or ``key`` does).  A :class:`ValueError` too, for callers of
    the API."""

    def __init__(self, message: str, key: str | None = None) -> None:
        super().__init__(message)
        self.key = key


def _shown(value: object) -> str:
    """A value for a message: text quoted, an enormous integer by its size."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"an integer of {len(str(abs(value)))} digits" if value.bit_length() < 14000 else "an enormous integer"
    if isinstance(value, str):
        return repr(value[:60])
    return repr(value) if not isinstance(value, float) else f"{value:g}"


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _whole(value: object, least: int, most: int | None, what: str) -> int:
    if not _is_int(value) or value < least or (most is not None and value > most):  # type: ignore[operator]
        sign = "non-negative" if least == 0 else "positive"
        span = f" up to {most:,}" if most is not None else ""
        raise OptionError(f"expected a {sign} {what}{span}, got {_shown(value)}")
    return value  # type: ignore[return-value]


def check_jobs(value: object) -> int | str:
    """``jobs``: a whole number of worker processes from 1 to :data:`MAX_JOBS`, or ``"auto"``."""
    if value == "auto":
        return "auto"
    if not _is_int(value) or not 1 <= value <= MAX_JOBS:  # type: ignore[operator]
        raise OptionError(f"expected a positive integer up to {MAX_JOBS} (worker processes), or auto, "
                          f"got {_shown(value)}")
    return value  # type: ignore[return-value]


def check_gamma(value: object) -> float:
    """``gamma``: strategy B's rate, 0 < G <= 1."""
    if not _is_number(value) or not 0 < value <= 1:  # type: ignore[operator]
        raise OptionError(f"must be > 0 and at most 1, got {_shown(value)}")
    return float(value)  # type: ignore[arg-type]


def _seconds(value: object) -> float:
    if not _is_number(value) or not 0 < value <= MAX_TIMEOUT_S:  # type: ignore[operator]
        raise OptionError(f"must be > 0 and at most {MAX_TIMEOUT_S:,.0f} seconds, got {_shown(value)}")
    return float(value)  # type: ignore[arg-type]


def check_timeout(value: object) -> float:
    """A job's time limit (seconds): > 0 and at most :data:`MAX_TIMEOUT_S`."""
    return _seconds(value)


def check_time_limit(value: object) -> float:
    """``--time-limit`` of ``--minimize`` (seconds), as :func:`check_timeout`."""
    return _seconds(value)


def check_memory(value: object) -> int:
    """A job's memory limit: whole megabytes from 1 to :data:`MAX_MEMORY_MB` (a float that is
    whole, as JSON may write it, is taken)."""
    if isinstance(value, float) and math.isfinite(value) and value == int(value):
        value = int(value)
    return _whole(value, 1, MAX_MEMORY_MB, "whole number of megabytes")


def check_solutions(value: object) -> int:
    """``n``: how many solutions, 0 for all."""
    if not _is_int(value) or value < 0:  # type: ignore[operator]
        raise OptionError(f"must be a non-negative integer (0: every history), not {value!r}")
    return value  # type: ignore[return-value]


def check_max_horizon(value: object) -> int | None:
    """``max_horizon``: where an open maxstep range stops (None: not given)."""
    if value is None:
        return None
    return _whole(value, 0, MAX_HORIZON, "maxstep")


def check_max_iterations(value: object) -> int:
    """``max_iterations`` of a robot task's refinement (0: no limit)."""
    return _whole(value, 0, None, "number of iterations (0: no limit)")


def check_strategy(value: object) -> str:
    """``strategy``: one of :data:`STRATEGIES`."""
    if value not in STRATEGIES:
        raise OptionError(f"expected one of {', '.join(STRATEGIES)}, got {_shown(value)}")
    return value


def _choice(*choices: str) -> Callable[[object], str]:
    def check(value: object) -> str:
        if value not in choices:
            raise OptionError(f"expected one of {', '.join(choices)}, got {_shown(value)}")
        return value
    return check


def check_solver(value: object) -> str:
    """A SAT solver's name, one pysat knows (checked before anything is loaded or printed)."""
    from cplus.sat.solver import _NOT_INCREMENTAL, is_solver, solver_names
    if not isinstance(value, str) or not is_solver(value):
        names = solver_names()
        if value in _NOT_INCREMENTAL:
            raise OptionError(f"SAT solver {_shown(value)} cannot solve under assumptions, which planning needs "
                              f"(solvers: {', '.join(names)})")
        if isinstance(value, str) and value.strip() == "":
            raise OptionError(f"an empty solver name (solvers: {', '.join(names)})")
        hint = _close(value, names)
        raise OptionError(f"unknown SAT solver {_shown(value)}{hint} (solvers: {', '.join(names)})")
    return value


def check_portfolio(value: object) -> list[str]:
    """A portfolio: distinct solver or strategy names, at least one, at most as many as there
    are distinct names (so at most that many variants of a job run at once)."""
    from cplus.sat.solver import solver_names
    names = (*solver_names(), *STRATEGIES)
    if not isinstance(value, list) or not value:
        raise OptionError("expected a non-empty list of solver or strategy names")
    seen: set[str] = set()
    for name in value:
        if not isinstance(name, str) or name not in names:
            hint = _close(name, names) if isinstance(name, str) else ""
            raise OptionError(f"unknown solver or strategy {_shown(name)}{hint} (solvers: "
                              f"{', '.join(solver_names())}; strategies: {', '.join(STRATEGIES)})")
        if name in seen:
            raise OptionError(f"{name!r} twice: each variant runs once")
        seen.add(name)
    return list(value)


def check_label(value: object) -> str:
    """A query label (``--query``, ``-q``, a job's ``query``): text, not empty."""
    if _is_int(value):
        return str(value)
    if not isinstance(value, str) or not value.strip():
        raise OptionError(f"expected a query label, got {_shown(value) if value != '' else 'an empty one'}")
    return value


def check_term(value: object) -> str:
    """``--minimize TERM``: text, not empty (what it names is checked against the domain)."""
    if not isinstance(value, str) or not value.strip():
        raise OptionError("expected a term to minimize (an integer fluent, or a sum of them), got an empty one")
    return value


def _bool(value: object) -> bool:
    if not isinstance(value, bool):
        raise OptionError(f"expected true or false, got {_shown(value)}")
    return value


def _paths(value: object) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(x, str) and x for x in value):
        raise OptionError("expected a list of file names")
    return list(value)


PLAN_OPTIONS: dict[str, Callable[[Any], Any]] = {
    "n": check_solutions, "max_horizon": check_max_horizon, "jobs": check_jobs, "strategy": check_strategy,
    "gamma": check_gamma, "any_length": _bool, "nogoods": _choice("positions", "actions"),
    "eager": _choice("auto", "yes", "no"), "max_iterations": check_max_iterations, "extern": _paths}
"""``cplus plan``'s options a batch job may set (the flags, with ``_`` for ``-``), each with its check."""


def check_plan_options(options: Mapping[str, object]) -> dict[str, Any]:
    """A job's ``options`` table checked: every value (:data:`PLAN_OPTIONS`), then what does
    not go together, as ``cplus plan`` refuses it (``gamma`` applies to strategy B;
    ``strategy``, ``gamma`` and ``any_length`` to ``jobs``).  The message of an
    :class:`OptionError` starts with the option's name."""
    out: dict[str, Any] = {}
    for key, value in options.items():
        check = PLAN_OPTIONS.get(key)
        if check is None:
            raise OptionError(f"unknown option {key!r}{_close(key, PLAN_OPTIONS)} "
                              f"(options: {', '.join(sorted(PLAN_OPTIONS))})", key)
        try:
            out[key] = check(value)
        except OptionError as exc:
            raise OptionError(f"option {key!r}: {exc.message}", key) from None
    if "gamma" in out and out.get("strategy") != "B":
        raise OptionError("option 'gamma' applies to strategy B (give strategy = \"B\")", "gamma")
    for key in ("strategy", "gamma", "any_length"):
        if key in out and out.get("jobs") is None and out[key] is not False:
            raise OptionError(f"option {key!r} applies with 'jobs' (worker processes)", key)
    return out


def _close(word: object, names) -> str:
    """``" (did you mean 'x'?)"`` for a near miss, else ``""``."""
    if not isinstance(word, str) or not word:
        return ""
    import difflib
    match = difflib.get_close_matches(word, list(names), n=1, cutoff=0.75)
    return f" (did you mean {match[0]!r}?)" if match else ""


def named(name: str, check: Callable[[object], Any], value: object) -> Any:
    """``check(value)``, its refusal naming the argument (``gamma must be > 0 ...``,
    ``solver: unknown SAT solver ...``): for the API's callers."""
    try:
        return check(value)
    except OptionError as exc:
        sep = " " if exc.message.startswith("must") else ": "
        raise OptionError(f"{name}{sep}{exc.message}", name) from None


def from_text(check: Callable[[object], Any], kind: type = int) -> Callable[[str], Any]:
    """``check`` for the text of a command-line flag: converted to ``kind`` first (a text that
    is no such number is given to the check as it is, which refuses it with its own words)."""
    def parse(text: str) -> Any:
        value: object = text
        if kind is int:
            try:
                value = int(text)
            except ValueError:
                pass
        elif kind is float:
            try:
                value = float(text)
            except ValueError:
                pass
        return check(value)
    parse.__name__ = check.__name__.removeprefix("check_")
    return parse


def available_cores() -> int:
    """The cores this process may run on (its affinity mask, not the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:    # pragma: no cover - not Linux
        return os.cpu_count() or 1


def worker_bound(asked: int, useful: int | None = None) -> int:
    """How many worker processes start for ``asked`` (``--jobs``, ``--workers``, a portfolio):
    at most ``useful`` (the horizons that can run at once, the jobs to run, the variants),
    at most :data:`WORKERS_PER_CORE` per core, at least 1."""
    n = min(asked, WORKERS_PER_CORE * available_cores())
    if useful is not None:
        n = min(n, useful)
    return max(1, n)
