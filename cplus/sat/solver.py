"""The SAT solver behind a small facade (the only module that talks to pysat).

>>> with SatSolver() as s:
...     s.add_clause([1, 2]); s.add_clause([-1])
...     s.solve(), s.value(2)
(True, True)

The common backends (Glucose 4 by default, Glucose 3, CaDiCaL 1.9.5, MiniSat 2.2) are driven
through pysat's C module ``pysolvers`` directly: ``pysat.solvers`` costs a fifth of the start-up
of a small domain (it imports ``tempfile``, ``random`` and pysat's formula classes), and its
Python layers around each added clause cost more than the C call for the hundreds of thousands
of clauses of a long horizon.  Every other solver pysat knows goes through ``pysat.solvers``.

Ctrl-C while a solver runs: pysolvers catches SIGINT inside the C code and raises its own
``pysolvers.error``; the facade turns that into :class:`KeyboardInterrupt`, which the command
reports as "interrupted" with exit code 130.
"""
from __future__ import annotations

import collections
import functools
import itertools
import threading

from cplus.errors import CPlusError

__all__ = ["SatSolver", "DEFAULT_SOLVER", "solver_names", "is_solver"]

DEFAULT_SOLVER = "glucose4"

# pysat's names for the backends driven natively -> the prefix of their pysolvers functions
_NATIVE = {
    **dict.fromkeys(("g4", "g41", "glucose4", "glucose41"), "glucose41"),
    **dict.fromkeys(("g3", "g30", "glucose3", "glucose30"), "glucose3"),
    **dict.fromkeys(("cd19", "cd195", "cdl19", "cdl195", "cadical195"), "cadical195"),
    **dict.fromkeys(("m22", "msat22", "minisat22"), "minisat22"),
}


def is_solver(name: str) -> bool:
    """Whether pysat has a solver of this name (a native backend's is known without importing
    ``pysat.solvers``, so that checking the default costs no start-up)."""
    return name in _NATIVE or name in solver_names()


_NOT_INCREMENTAL = frozenset({"kissat404", "kissat4", "kissat", "ks4", "ks"})
"""Backends pysat offers that ignore assumptions (with a warning): the horizon's activation
literals would be dropped and the first horizon's wrong "plan" printed, so they are not offered."""


def solver_names() -> tuple[str, ...]:
    """Every solver name pysat accepts that can solve under assumptions (imports ``pysat.solvers``)."""
    from pysat.solvers import SolverNames
    return tuple(sorted(n for n in vars(SolverNames) if not n.startswith("_") and n not in _NOT_INCREMENTAL))


def __getattr__(name: str):  # SOLVERS stays importable without paying for it at start-up
    if name == "SOLVERS":
        return solver_names()
    raise AttributeError(name)


def _interrupted(exc: Exception) -> bool:
    return "interrupt" in str(exc).lower()


class _Native:
    """One pysolvers backend: new / add_cl / solve / model / del."""

    def __init__(self, prefix: str) -> None:
        import pysolvers
        self._mod = pysolvers
        self._prefix = prefix
        self.handle = getattr(pysolvers, prefix + "_new")()
        self._assumptions: list[int] = []
        self.add_clause = functools.partial(getattr(pysolvers, prefix + "_add_cl"), self.handle)
        self._solve = getattr(pysolvers, prefix + "_solve")
        self._model = getattr(pysolvers, prefix + "_model")

    def solve(self, assumptions: list[int]) -> bool:
        main = int(threading.current_thread() is threading.main_thread())
        self._assumptions = assumptions
        return bool(self._solve(self.handle, assumptions, main))

    def solve_limited(self, assumptions: list[int], propagations: int) -> bool | None:
        budget = getattr(self._mod, self._prefix + "_pbudget", None)
        if budget is None:                          # CaDiCaL has no propagation budget
            return self.solve(assumptions)
        budget(self.handle, max(1, propagations))
        main = int(threading.current_thread() is threading.main_thread())
        self._assumptions = assumptions
        ok = getattr(self._mod, self._prefix + "_solve_lim")(self.handle, assumptions, main, 0)
        return None if ok is None else bool(ok)

    def solve_conflicts(self, assumptions: list[int], conflicts: int) -> bool | None:
        budget = getattr(self._mod, self._prefix + "_cbudget", None)
        if budget is None:
            return self.solve(assumptions)
        budget(self.handle, max(1, conflicts))
        main = int(threading.current_thread() is threading.main_thread())
        self._assumptions = assumptions
        lim = getattr(self._mod, self._prefix + "_solve_lim")
        if self._prefix.startswith("cadical"):      # 0: unknown, 1: satisfiable, -1: not
            status = lim(self.handle, assumptions, main)
            return None if not status else status > 0
        ok = lim(self.handle, assumptions, main, 0)
        return None if ok is None else bool(ok)

    def budget_kind(self) -> str | None:
        if hasattr(self._mod, self._prefix + "_pbudget"):
            return "propagations"
        return "conflicts" if hasattr(self._mod, self._prefix + "_cbudget") else None

    def propagations(self) -> int:
        stats = getattr(self._mod, self._prefix + "_acc_stats", None)
        return int(stats(self.handle).get("propagations", 0)) if stats else 0

    def get_model(self) -> list[int]:
        return self._model(self.handle) or []

    def get_core(self) -> list[int]:
        fn = getattr(self._mod, self._prefix + "_core")
        if self._prefix.startswith("cadical"):      # CaDiCaL asks which assumptions to test
            return fn(self.handle, self._assumptions) or []
        return fn(self.handle) or []

    def delete(self) -> None:
        if self.handle is not None:
            fn = getattr(self._mod, self._prefix + "_del")
            if self._prefix.startswith("cadical"):
                fn(self.handle, None)
            else:
                fn(self.handle)
            self.handle = None


class _Generic:
    """Any other solver pysat knows, through ``pysat.solvers.Solver``."""

    def __init__(self, name: str) -> None:
        from pysat.solvers import Solver
        self._s = Solver(name=name)
        self.add_clause = self._s.add_clause

    def solve(self, assumptions: list[int]) -> bool:
        return bool(self._s.solve(assumptions=assumptions))

    def solve_limited(self, assumptions: list[int], propagations: int) -> bool | None:
        try:
            self._s.prop_budget(max(1, propagations))
        except NotImplementedError:     # pysat's word for a backend without budgets: solve to the end
            return self.solve(assumptions)
        ok = self._s.solve_limited(assumptions=assumptions)
        return None if ok is None else bool(ok)

    def solve_conflicts(self, assumptions: list[int], conflicts: int) -> bool | None:
        try:
            self._s.conf_budget(max(1, conflicts))
        except NotImplementedError:
            return self.solve(assumptions)
        ok = self._s.solve_limited(assumptions=assumptions)
        return None if ok is None else bool(ok)

    def budget_kind(self) -> str | None:
        return "conflicts"      # every pysat backend but a few bounds conflicts; the rest solve to the end

    def propagations(self) -> int:
        try:
            return int((self._s.accum_stats() or {}).get("propagations", 0))
        except NotImplementedError:     # a backend that does not count them
            return 0

    def get_model(self) -> list[int]:
        return self._s.get_model() or []

    def get_core(self) -> list[int]:
        return self._s.get_core() or []

    def delete(self) -> None:
        self._s.delete()


class SatSolver:
    """An incremental solver: add clauses, solve under assumptions, read the model."""

    def __init__(self, name: str = DEFAULT_SOLVER) -> None:
        self.name = name
        self._model: list[int] | None = None
        self.count = 0
        self._b: _Native | _Generic | None
        if name in _NOT_INCREMENTAL:
            self._b = None
            raise CPlusError(f"SAT solver '{name}' cannot solve under assumptions, which planning needs "
                             f"(choose one of: {', '.join(solver_names())})")
        try:
            prefix = _NATIVE.get(name)
            self._b = _Native(prefix) if prefix else _Generic(name)
        except Exception:  # pysat raises a bare ValueError-like error for unknown names
            self._b = None
            raise CPlusError(f"unknown SAT solver '{name}' (choose one of: {', '.join(solver_names())})") from None
        self._raw = self._b.add_clause

    def add_clause(self, clause: list[int]) -> None:
        self._raw(clause)
        self.count += 1

    def add_clauses(self, clauses) -> None:
        """Add many clauses (any iterable of iterables of integers), without a Python-level
        step per clause: the count comes from a counter zipped after the calls."""
        counted = itertools.count()
        collections.deque(zip(map(self._raw, clauses), counted), maxlen=0)
        self.count += next(counted)

    def _answer(self, call, assumptions, *budget) -> bool | None:
        """One call of the backend (``solve``, or one with a budget), Ctrl-C as KeyboardInterrupt
        and the model kept when it found one."""
        try:
            ok = call(list(assumptions), *budget)
        except Exception as exc:   # pysolvers reports Ctrl-C as its own error
            if _interrupted(exc):
                raise KeyboardInterrupt from None
            raise
        self._model = self._b.get_model() if ok else None  # type: ignore[union-attr]
        return ok

    def solve(self, assumptions: list[int] = ()) -> bool:  # type: ignore[assignment]
        assert self._b is not None
        return self._answer(self._b.solve, assumptions) is True   # a full solve always answers

    def solve_limited(self, assumptions: list[int], propagations: int) -> bool | None:
        """:meth:`solve`, giving up after about ``propagations`` unit propagations (None: no
        answer yet). Propagations measure the solver's work the way time does, but a budget of
        them gives the same answer on a loaded machine. (A backend without such a budget,
        CaDiCaL, solves without one.)"""
        assert self._b is not None
        return self._answer(self._b.solve_limited, assumptions, propagations)

    def solve_conflicts(self, assumptions: list[int], conflicts: int) -> bool | None:
        """:meth:`solve_limited` with a budget of conflicts, for backends that have no
        propagation budget (CaDiCaL): how :mod:`cplus.parallel` time-shares them."""
        assert self._b is not None
        return self._answer(self._b.solve_conflicts, assumptions, conflicts)

    @property
    def budget_kind(self) -> str | None:
        """What this backend's budgets count: ``"propagations"``, ``"conflicts"`` (CaDiCaL), or
        ``None`` (no budget: a limited solve runs to the end)."""
        assert self._b is not None
        return self._b.budget_kind()

    @property
    def propagations(self) -> int:
        """Unit propagations so far, over every call (what :meth:`solve_limited` budgets)."""
        assert self._b is not None
        return self._b.propagations()

    def value(self, var: int) -> bool:
        """Truth value of a variable in the last model (unassigned counts as false)."""
        m = self._model
        assert m is not None, "no model"
        return var <= len(m) and m[var - 1] > 0

    def core(self) -> list[int]:
        """After an unsatisfiable :meth:`solve`: assumptions that together cannot hold (a
        subset of those given; not necessarily minimal)."""
        assert self._b is not None
        return list(self._b.get_core() or [])

    @property
    def model(self) -> list[int]:
        assert self._model is not None, "no model"
        return self._model

    def delete(self) -> None:
        if self._b is not None:
            self._b.delete()
            self._b = None

    def __enter__(self) -> SatSolver:
        return self

    def __exit__(self, *exc) -> None:
        self.delete()

    def __del__(self) -> None:
        try:
            self.delete()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass
