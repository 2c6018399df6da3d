"""The SAT solver behind a small facade (the only module that imports ``pysat.solvers``).

>>> with SatSolver() as s:
...     s.add_clause([1, 2]); s.add_clause([-1])
...     s.solve(), s.value(2)
(True, True)
"""
from __future__ import annotations

from pysat.solvers import Solver, SolverNames

from cplus.errors import CPlusError

__all__ = ["SatSolver", "SOLVERS", "DEFAULT_SOLVER"]

DEFAULT_SOLVER = "glucose4"
SOLVERS = tuple(sorted(n for n, aliases in vars(SolverNames).items() if not n.startswith("_")))


class SatSolver:
    """An incremental solver: add clauses, solve under assumptions, read the model."""

    def __init__(self, name: str = DEFAULT_SOLVER) -> None:
        try:
            self._s = Solver(name=name)
        except Exception:  # pysat raises a bare ValueError-like error for unknown names
            raise CPlusError(f"unknown SAT solver '{name}' (choose one of: {', '.join(SOLVERS)})") from None
        self.name = name
        self._model: list[int] | None = None
        self.count = 0

    def add_clause(self, clause: list[int]) -> None:
        self._s.add_clause(clause)
        self.count += 1

    def solve(self, assumptions: list[int] = ()) -> bool:  # type: ignore[assignment]
        ok = self._s.solve(assumptions=list(assumptions))
        self._model = self._s.get_model() if ok else None
        return bool(ok)

    def value(self, var: int) -> bool:
        """Truth value of a variable in the last model (unassigned counts as false)."""
        m = self._model
        assert m is not None, "no model"
        return var <= len(m) and m[var - 1] > 0

    @property
    def model(self) -> list[int]:
        assert self._model is not None, "no model"
        return self._model

    def delete(self) -> None:
        if self._s is not None:
            self._s.delete()
            self._s = None  # type: ignore[assignment]

    def __enter__(self) -> "SatSolver":
        return self

    def __exit__(self, *exc) -> None:
        self.delete()

    def __del__(self) -> None:
        try:
            self.delete()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass
