"""The Python API: load a domain, run its queries, iterate over plans.

>>> from cplus import Domain
>>> d = Domain.from_text('''
... :- constants lit :: inertialFluent; flip :: exogenousAction.
... flip causes lit.
... :- query label :: on; maxstep :: 0..3; 0: -lit; maxstep: lit.''')
>>> d.labels
['on']
>>> r = d.solve("on")
>>> r.maxstep, r.histories[0].value("flip", 0), r.histories[0].state_values(1)
(1, True, {'lit': True})
>>> print(d.format(r).strip())
No solution with maxstep 0.
<BLANKLINE>
<BLANKLINE>
0:
<BLANKLINE>
ACTIONS:  flip
<BLANKLINE>
1:  lit
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

from cplus.errors import Diagnostics, QueryError
from cplus.ground.atoms import AtomTable
from cplus.ground.restrict import fixed_at_zero
from cplus.ground.theory import GroundTheory, ground_program
from cplus.history import History
from cplus.load import load_program, load_text
from cplus.output import Display, format_result, result_json
from cplus.planner import QueryResult, QuerySession, Session, find_horizon, iter_histories, run_query, states_query
from cplus.program import Program, QuerySpec
from cplus.resolve import Externals
from cplus.sat.solver import DEFAULT_SOLVER

if TYPE_CHECKING:
    from cplus.sat.optimize import OptimalResult

__all__ = ["Domain"]


class Domain:
    """A C+ domain description with its queries, grounded on first use."""

    def __init__(self, program: Program, path: str) -> None:
        self.program = program
        self.path = path
        self._theory: GroundTheory | None = None
        self._templates: tuple | None = None
        self._for_state: dict[frozenset[int], GroundTheory] = {}

    @classmethod
    def load(cls, path: str, externals: Externals | None = None) -> Domain:
        """Read a C+ file (and its includes); raises :class:`~cplus.errors.CPlusError`."""
        return cls(load_program(path, externals), path)

    @classmethod
    def from_text(cls, text: str, name: str = "<input>", externals: Externals | None = None) -> Domain:
        return cls(load_text(text, name, externals), name)

    @property
    def diagnostics(self) -> Diagnostics:
        return self.program.diagnostics

    @property
    def theory(self) -> GroundTheory:
        if self._theory is None:
            self._theory = ground_program(self.program)
        return self._theory

    def theory_for(self, query: QuerySpec) -> GroundTheory:
        """The grounding a query is answered with: :attr:`theory` once that is built, else
        only what can happen from the state the query fixes at step 0 (see
        :mod:`cplus.ground.restrict`; built once per such state).  The histories are the same
        either way; a restricted grounding is much smaller when most values of the domain's
        integer fluents cannot be reached from that state."""
        if self._theory is not None:
            return self._theory
        fixed = fixed_at_zero(self.program.signature, AtomTable(self.program.signature), query)
        if not fixed:
            return self.theory
        key = frozenset(fixed)
        theory = self._for_state.get(key)
        if theory is None:
            theory = self._for_state[key] = ground_program(self.program, fixed)
        return theory

    @property
    def templates(self) -> tuple:
        """The step templates of :attr:`theory` (built once): pass them to
        :class:`~cplus.sat.horizon.QuerySession` to start solvers without rebuilding them."""
        if self._templates is None:
            from cplus.sat.templates import build_templates
            self._templates = build_templates(self.theory)
        return self._templates

    @property
    def labels(self) -> list[str]:
        return [q.label for q in self.program.queries]

    @property
    def nm_labels(self) -> list[str]:
        """The labels of the file's nmqueries (a namespace apart from :attr:`labels`)."""
        return [q.label for q in self.program.nmqueries]

    def query(self, label: str) -> QuerySpec:
        """The query with this label; ``"states"`` is every state (maxstep 0, no conditions).

        Raises:
            QueryError: no query has this label.
            CPlusError: the query's own located error, when it could not be resolved (the
                file's other queries are answered, as CCALC answers them).
        """
        q = self.program.query(label)
        if q is not None:
            if q.error is not None:
                raise q.error
            return q
        if label == "states":
            return states_query()
        known = ", ".join(self.labels) or "none"
        hint = " (there is an nmquery of that label: --nmquery)" if self.program.nmquery(label) else ""
        raise QueryError(f"no query with label '{label}' ({_did_you_mean(label, self.labels)}"
                         f"this file's labels: {known}){hint}")

    def nmquery(self, label: str) -> QuerySpec:
        """The nmquery with this label (CCALC's ``nmquery label``); raises as :meth:`query`."""
        q = self.program.nmquery(label)
        if q is not None:
            if q.error is not None:
                raise q.error
            return q
        known = ", ".join(self.nm_labels) or "none"
        raise QueryError(f"no nmquery with label '{label}' ({_did_you_mean(label, self.nm_labels)}"
                         f"this file's nmquery labels: {known})")

    def spec(self, label: str, nmquery: bool = False) -> QuerySpec:
        """The query (or, with ``nmquery``, the nmquery) with this label."""
        return self.nmquery(label) if nmquery else self.query(label)

    def _searchable(self, label: str, nmquery: bool = False) -> QuerySpec:
        """The query (or nmquery) ``label``, unless it is a ``maxstep :: any`` query: that one
        is proved (:meth:`prove`), never searched horizon by horizon."""
        query = self.spec(label, nmquery)
        if query.invariant is not None:
            raise QueryError(f"query '{label}' has 'maxstep :: any': it is a proof that no plan exists "
                             "(Domain.prove), not a search", query.loc)
        return query

    def solve(self, label: str = "0", solutions: int = 1, solver: str = DEFAULT_SOLVER,
              max_horizon: int | None = None, on_horizon: Callable | None = None,
              nmquery: bool = False) -> QueryResult:
        """Run a query (with ``nmquery``, the nmquery of that label): the shortest maxstep in
        its range with a history, and up to ``solutions`` histories there (0 = all)."""
        _checked(solutions=solutions, solver=solver, max_horizon=max_horizon)
        query = self._searchable(label, nmquery)
        return run_query(self.theory_for(query), query, solutions, solver, max_horizon, on_horizon)

    def plans(self, label: str = "0", solver: str = DEFAULT_SOLVER,
              max_horizon: int | None = None, nmquery: bool = False) -> Iterator[History]:
        """Every history at the shortest maxstep with one, lazily."""
        _checked(solver=solver, max_horizon=max_horizon)
        query = self._searchable(label, nmquery)
        session = QuerySession(self.theory_for(query), query, solver, max_horizon, commit=True)
        find_horizon(session)
        if session.found is not None:
            yield from iter_histories(session)

    def session(self, label: str = "0", solver: str = DEFAULT_SOLVER,
                max_horizon: int | None = None, nmquery: bool = False) -> Session:
        """A live solver for a query (:class:`~cplus.planner.Session`), for callers that
        enumerate histories themselves or add constraints between solves: ``solve_at(m)``,
        ``history()``, ``block_current()``, ``resolve()``, ``histories(m)``.  What is blocked
        stays blocked when the same horizon is solved again."""
        _checked(solver=solver, max_horizon=max_horizon)
        query = self._searchable(label, nmquery)
        return Session(self.theory_for(query), query, solver, max_horizon)

    def minimize(self, label: str, term: str, solutions: int = 1, over_lengths: bool = False,
                 time_limit: float | None = None, solver: str = DEFAULT_SOLVER, max_horizon: int | None = None,
                 nmquery: bool = False) -> OptimalResult:
        """The cheapest plan of a query, as ``cplus plan --minimize TERM`` finds it: TERM is an
        integer fluent (an additive cost) or a sum of them with ``+``, read at the last step.
        The shortest length with a plan, then the cheapest plan of that length; with
        ``over_lengths`` the cheapest over the query's whole maxstep range (an open range
        needs ``max_horizon``).  The result is :meth:`solve`'s with ``optimum``
        (:class:`~cplus.sat.optimize.Optimum`: ``value``, ``proved``, ``lower_bound``; None
        when there is no plan); ``solutions`` other than 1 gives every plan of the optimal
        cost (0: all).  ``time_limit`` (seconds) stops the search for cheaper plans, never
        the first: the best plan so far is returned, ``proved`` false.

        A method of its own, not ``plans(minimize=...)``: :meth:`plans` yields histories
        lazily with no status, and an optimum is one result with a proof status."""
        if isinstance(solutions, bool) or not isinstance(solutions, int) or solutions < 0:
            raise ValueError(f"solutions must be a non-negative integer (0: every plan of the optimal cost), "
                             f"not {solutions!r}")
        if time_limit is not None and not time_limit > 0:
            raise ValueError(f"time_limit must be a positive number of seconds, not {time_limit!r}")
        from cplus.sat.optimize import Objective, run_optimal
        query = self._searchable(label, nmquery)
        objective = Objective.parse(term, self.program.signature, option="")
        return run_optimal(self.theory_for(query), query, objective, solutions, solver, max_horizon,
                           over_lengths, time_limit)

    def prove(self, label: str, solver: str | None = None):
        """The proof of a ``maxstep :: any`` query that no plan of any length exists
        (:func:`cplus.invariant.prove`: an :class:`~cplus.invariant.InvariantResult`)."""
        from cplus.invariant import prove
        query = self.query(label)
        if query.invariant is None:
            raise QueryError(f"query '{label}' has no invariant (only a 'maxstep :: any' query is proved)",
                             query.loc)
        return prove(self.theory, query, solver)

    def format_proof(self, proof) -> str:
        from cplus.invariant import format_proof
        return format_proof(Display(self.program), proof)

    def proof_json(self, proof) -> dict:
        from cplus.invariant import proof_json
        return {"format": "cplus.plan/1", "file": self.path, **proof_json(proof, self.query(proof.label))}

    def format(self, result: QueryResult, numbered: bool | None = None) -> str:
        """CCALC's text for a result, as ``cplus plan`` prints it: each history headed
        ``Solution k:`` when there are several, as CCALC numbers them (``numbered`` overrides)."""
        text = format_result(Display(self.program), result.failed, result.histories, numbered)
        if getattr(result, "optimum", None) is not None:      # a result of minimize: its cost line
            from cplus.sat.optimize import optimum_text
            text += optimum_text(result)  # type: ignore[arg-type]
        return text

    def to_json(self, result: QueryResult) -> dict:
        """The ``cplus.plan/1`` document of a result (with ``"optimum"`` for one of :meth:`minimize`)."""
        doc = result_json(self.path, result, self.spec(result.label, result.nm))
        if hasattr(result, "optimum"):
            from cplus.sat.optimize import optimum_json
            doc["optimum"] = optimum_json(result)  # type: ignore[arg-type]
        return doc


def _did_you_mean(label: str, labels: list[str]) -> str:
    """``did you mean 'x'? `` for the label closest to a mistyped one (difflib), or nothing."""
    import difflib

    close = difflib.get_close_matches(label, labels, n=1)
    return f"did you mean '{close[0]}'? " if close else ""


def _checked(**given: object) -> None:
    """The planner's options of an API call, checked as ``cplus plan`` checks its flags
    (:mod:`cplus.options`).

    Raises:
        cplus.options.OptionError: a :class:`ValueError` naming the argument.
    """
    from cplus.options import check_max_horizon, check_solutions, check_solver, named
    checks = {"solutions": check_solutions, "solver": check_solver, "max_horizon": check_max_horizon}
    for name, value in given.items():
        named(name, checks[name], value)
