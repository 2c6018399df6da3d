"""The SAT solver behind a small facade (the only module that imports ``pysat.solvers``).

>>> with SatSolver() as s:
...     s.add_clause([1, 2]); s.add_clause([-1])
...     s.solve(), s.value(2)
(True, True)
"""
from __future__ import annotations

import functools

from pysat.solvers import Solver, SolverNames

from cplus.errors import CPlusError

__all__ = ["SatSolver", "SOLVERS", "DEFAULT_SOLVER"]

DEFAULT_SOLVER = "glucose4"
SOLVERS = tuple(sorted(n for n in vars(SolverNames) if not n.startswith("_")))


# pysat's backends add a clause through two Python layers around one C call; for the
# hundreds of thousands of clauses of a long horizon we call the C function directly.
_RAW_ADD = {
    "Glucose4": ("glucose41_add_cl", "glucose"), "Glucose3": ("glucose3_add_cl", "glucose"),
    "Cadical195": ("cadical195_add_cl", "cadical"), "Cadical153": ("cadical153_add_cl", "cadical"),
    "Minisat22": ("minisat22_add_cl", "minisat"), "MinisatGH": ("minisatgh_add_cl", "minisat"),
}


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
        self._raw = self._raw_adder()

    def _raw_adder(self):
        backend = self._s.solver
        spec = _RAW_ADD.get(type(backend).__name__)
        if spec is None:
            return backend.add_clause
        import pysolvers
        fn = getattr(pysolvers, spec[0], None)
        handle = getattr(backend, spec[1], None)
        if fn is None or handle is None:
            return backend.add_clause
        return functools.partial(fn, handle)

    def add_clause(self, clause: list[int]) -> None:
        self._raw(clause)
        self.count += 1

    def add_clauses(self, clauses) -> None:
        """Add many clauses (any iterable of integer lists)."""
        raw = self._raw
        n = 0
        for c in clauses:
            raw(c)
            n += 1
        self.count += n

    def solve(self, assumptions: list[int] = ()) -> bool:  # type: ignore[assignment]
        try:
            ok = self._s.solve(assumptions=list(assumptions))
        except Exception as exc:
            # A SIGINT caught inside the C solver comes back as pysat's own error; it is
            # still Ctrl-C, and the command line answers it with exit code 130.
            if "keyboard interrupt" in str(exc).lower():
                raise KeyboardInterrupt from None
            raise
        self._model = self._s.get_model() if ok else None
        return bool(ok)

    def value(self, var: int) -> bool:
        """Truth value of a variable in the last model (unassigned counts as false)."""
        m = self._model
        assert m is not None, "no model"
        return var <= len(m) and m[var - 1] > 0

    def core(self) -> list[int]:
        """After an unsatisfiable :meth:`solve`: assumptions that together cannot hold (a
        subset of those given; not necessarily minimal)."""
        return list(self._s.get_core() or [])

    @property
    def model(self) -> list[int]:
        assert self._model is not None, "no model"
        return self._model

    def delete(self) -> None:
        if self._s is not None:
            self._s.delete()
            self._s = None

    def __enter__(self) -> SatSolver:
        return self

    def __exit__(self, *exc) -> None:
        self.delete()

    def __del__(self) -> None:
        try:
            self.delete()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass
