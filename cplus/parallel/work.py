"""What a parallel search needs from a domain, and what it found.

:class:`Work` is built in the parent before the workers are forked (whatever it holds is in
every worker without being sent) and is the one place a caller plugs in: the plain planner's
answers every model, a robot task's refinement refutes some and shares what it learned.
:class:`Outcome` is the search's result. Histories cross the pipes as indices into the ground
constants' domains (constants are interned per process), by :meth:`Work.encode`/``decode``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from cplus.history import History, from_object, to_object
from cplus.sat.horizon import QuerySession

__all__ = ["Work", "Outcome"]


class Work:
    """What the search needs from a domain inside a worker, and what a model means there.

    The plain planner's: a model is the horizon's answer.  Built in the parent before the
    workers are forked, so whatever it holds is in every worker without being sent."""

    def __init__(self, session: QuerySession) -> None:
        self.first: QuerySession | None = session      # ready for its first solve: one worker slot's
        self.theory = session.theory
        self.query = session.query
        self.solver = session._solver_name
        self.max_horizon = session.max_horizon
        h = session.horizon
        self.templates = (h.layout, h.t_rigid, h.t_init, h.t_trans)
        self.template_s = h.template_s
        self.index = {gc: i for i, gc in enumerate(self.theory.sig.ground)}

    def new_session(self) -> QuerySession:
        """A session for one more horizon in this worker (the inherited one first)."""
        if self.first is not None:
            s, self.first = self.first, None
            return s
        s = QuerySession(self.theory, self.query, self.solver, self.max_horizon, templates=self.templates)
        self.prepare(s)
        return s

    def prepare(self, session: QuerySession) -> None:
        """Whatever a new session must be taught before its first solve (robot: nogoods); the
        first session was given to the constructor and is the caller's to prepare."""

    def on_model(self, session: QuerySession, m: int, sessions: list[QuerySession]) -> tuple[bool, object]:
        """A model at horizon m: ``(True, payload)`` when it answers the horizon, ``(False,
        learned)`` when it is refuted and ``learned`` (already taught to ``sessions``, this
        worker's) goes to the other workers; the horizon is then solved again."""
        return True, None

    def learn(self, sessions: list[QuerySession], learned: object) -> None:
        """Teach this worker's sessions what another worker learned."""

    def on_unsat(self, session: QuerySession, m: int) -> object:
        """Extra facts about a horizon proved empty, for the parent (robot: were there plans)."""
        return None

    # histories travel as indices: ground constants are interned per process (identity is equality)
    def encode(self, hist: History) -> tuple:
        ix = self.index

        def table(t: dict) -> list:
            return [(ix[gc], gc.domain.index(to_object(gc, v))) for gc, v in t.items()]
        return hist.maxstep, table(hist.rigid), [table(s) for s in hist.states], [table(a) for a in hist.actions]

    def decode(self, data: tuple) -> History:
        ground = self.theory.sig.ground
        m, rigid, states, actions = data

        def table(rows: list) -> dict:
            return {ground[i]: from_object(ground[i], ground[i].domain[j]) for i, j in rows}
        return History(m, table(rigid), tuple(table(s) for s in states), tuple(table(a) for a in actions))


@dataclass
class Outcome:
    """What a search found.  ``records``: one per (worker, horizon) that ran, in the order they
    ended (``result``: ``unsat``, ``sat``, ``dropped`` for one cancelled by a shorter plan,
    ``taken`` for one handed to strategy B's first worker
    (:func:`~cplus.parallel.strategy.chained`), ``stopped`` for one still running at the end)."""

    maxstep: int | None
    histories: list[History]
    proved: list[int]               # horizons proved empty, ascending
    unproved: list[int]             # below maxstep and not proved empty (only with any_length)
    records: list[dict] = field(default_factory=list)
    extras: dict[int, object] = field(default_factory=dict)    # Work.on_unsat's, by horizon
    payload: object = None          # Work.on_model's for the answer
    learned: list[tuple[int, int, object]] = field(default_factory=list)   # (worker, maxstep, learned)
    workers: int = 0
    replaced: int = 0
    stopped_early: bool = False     # a hook ended the search (robot: --max-iterations)
