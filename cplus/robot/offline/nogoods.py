"""What the refinement loop teaches the solver: nogoods, and where they go in the live horizon.

A :class:`Nogood` is a conjunction of constant values over a window of consecutive steps that
no plan may contain at any step: the positions a violation depends on (widened to ranges by
:func:`trajectory.widen`), or, in the paper's form, the actions executed where the bodies
are.  :class:`NogoodStore` keeps them in the solver at every step, present and future
(through :meth:`cplus.sat.horizon.Horizon.each_step`), optionally behind a guard literal, and
also holds the pre-check's payload-vector classes: the payload's length over a motion depends
only on the vector between its ends before and after (:func:`trajectory.failing_length_pairs`),
so one auxiliary variable per vector and step turns each failing pair of vectors into one
four-literal clause per step.
"""
from __future__ import annotations

from dataclasses import dataclass

from cplus.history import History, executed_actions, to_object
from cplus.output import Display
from cplus.signature import GroundConst

__all__ = ["Nogood", "NogoodStore", "position_nogood", "action_nogood"]


@dataclass(frozen=True)
class Nogood:
    """Values over consecutive steps that no plan may contain, at any step.

    ``conditions`` are ``(step offset, constant, value)``, a value being an inclusive range
    ``(min, max)`` for a widened coordinate.  The clause is ``lits``, each ``(step offset,
    signed atom)``: a value that differs, or for a range every value outside it (each
    constant has exactly one value).  ``form`` is ``positions`` (bound coordinates only, and
    holders where they matter) or ``actions`` (the paper's form: executed actions where the
    bodies are).
    """

    form: str
    text: str
    conditions: tuple[tuple[int, str, object], ...]
    lits: tuple[tuple[int, int], ...]
    span: int        # motions covered: 0 for one state, 1 for a motion between two steps, ...

    @property
    def key(self) -> tuple:
        return self.span, frozenset(self.lits)

    def to_json(self) -> dict:
        def cond(off: int, constant: str, v: object) -> dict:
            if isinstance(v, tuple):
                return {"step": off, "constant": constant, "min": v[0], "max": v[1]}
            return {"step": off, "constant": constant, "value": _json_value(v)}
        return {"form": self.form, "text": self.text, "conditions": [cond(*c) for c in self.conditions]}


def _json_value(v: object) -> object:
    if v in ("true", "false"):
        return v == "true"
    return v if isinstance(v, (int, str)) else str(v)


def position_nogood(task, box: dict, holds: list[dict] | None = None) -> Nogood:
    """"Never these bodies within these positions at consecutive steps".

    ``box`` maps ``(step offset, body, axis)`` (axis 0: x, 1: y) to an inclusive interval of
    values (:func:`trajectory.widen`); ``holds``, when given, is the state at each step of the
    window, whose ``holds`` fluents then take part (who holds what matters too)."""
    conds: list[tuple[int, GroundConst, object]] = []
    ranges: dict[tuple[int, GroundConst], tuple[int, int]] = {}
    for (off, body, axis), (lo, hi) in sorted(box.items()):
        gc = task.body_fluents(body)[axis]
        if lo == hi:
            conds.append((off, gc, lo))
        elif any(not lo <= v <= hi for v in gc.domain):
            ranges[(off, gc)] = (lo, hi)
    for k, state in enumerate(holds or []):
        for gc in task.holds.values():
            conds.append((k, gc, to_object(gc, state[gc])))
    if not conds and not ranges:    # every position fails: keep the exact ones (still sound)
        return position_nogood(task, {k: (lo, lo) for k, (lo, _) in box.items()}, holds)
    span = max(off for off, _, _ in box)
    return _nogood(task, "positions", _box_text(task, box, holds), conds, span, ranges)


def _box_text(task, box: dict, holds: list[dict] | None) -> str:
    span = max(off for off, _, _ in box)
    bodies = list(dict.fromkeys(body for _, body, _ in sorted(box)))

    def coord(off: int, body: str, axis: int) -> str:
        lo, hi = box[(off, body, axis)]
        return str(lo) if lo == hi else f"{lo}..{hi}"
    parts = []
    for body in bodies:
        points = [f"({coord(k, body, 0)},{coord(k, body, 1)})" for k in range(span + 1)]
        parts.append(f"{body} {'->'.join(points)}" if span else f"{body} at {points[0]}")
    text = " & ".join(parts)
    if holds:
        text += " & " + " & ".join(f"{gc.text}={to_object(gc, state[gc])}" for state in holds for gc in task.holds.values())
    return text


def action_nogood(task, hist: History, step: int) -> Nogood:
    """The paper's form: "never exactly these actions where the bodies are at ``step``" (each
    action's truth value and the attributes of the executed ones, and every bound
    coordinate)."""
    state, acts = hist.states[step], hist.actions[step]
    conds: list[tuple[int, GroundConst, object]] = []
    for gcs in list(task.robots.values()) + list(task.ends.values()):
        for gc in gcs:
            conds.append((0, gc, to_object(gc, state[gc])))
    where = [f"{name} at ({state[x]},{state[y]})"
             for name, (x, y) in list(task.robots.items()) + list(task.ends.items())]
    done = set(executed_actions(acts))
    for gc, v in acts.items():
        d = gc.decl
        if d.hidden or d.kind not in ("exogenousAction", "action", "attribute"):
            continue
        if d.kind == "attribute":
            parent = d.parent.instances.get(gc.args[:d.parent.arity])  # type: ignore[union-attr]
            if parent not in done:
                continue
        conds.append((0, gc, to_object(gc, v)))
    acts_text = "  ".join(Display(task.domain.program).action_atoms(acts)) or "no action"
    return _nogood(task, "actions", f"{{{acts_text}}} where {', '.join(where)}", conds, 0)


def _nogood(task, form: str, text: str, conds: list[tuple[int, GroundConst, object]], span: int,
            ranges: dict | None = None) -> Nogood:
    """The clause: a value that differs, or (for a range) one outside it."""
    atoms = task.domain.theory.atoms
    lits = []
    for off, gc, v in conds:
        a = atoms.lit(gc, v)
        if a == 0:
            raise AssertionError(f"{gc.text}={v} is no atom")  # values come from models and the grid
        lits.append((off, -a))
    shown: list[tuple[int, str, object]] = [(off, gc.text, v) for off, gc, v in conds]
    for (off, gc), (lo, hi) in (ranges or {}).items():
        lits.extend((off, atoms.lit(gc, v)) for v in gc.domain if not lo <= v <= hi)
        shown.append((off, gc.text, (lo, hi)))
    return Nogood(form, text, tuple(sorted(shown, key=lambda c: (c[0], c[1]))), tuple(lits), span)


class NogoodStore:
    """Nogoods in a live horizon, at every step (existing and future), each optionally behind
    a guard (a solver variable that must be assumed for the clause to bind)."""

    def __init__(self, horizon, atoms) -> None:
        self.h = horizon
        self.atoms = atoms
        self.windows: list[tuple[Nogood, int | None]] = []
        self.vectors: _Vectors | None = None
        horizon.each_step(self._step)

    def add(self, nogood: Nogood, guard: int | None = None) -> None:
        self.windows.append((nogood, guard))
        for t in range(self.h.m - nogood.span + 1):
            self._window(nogood, t, guard)

    def add_vector_pairs(self, task, pairs: list, guard: int | None = None) -> None:
        """Forbid the payload's end vector (``end2 - end1``) going from ``d0`` to ``d1`` in one
        motion, for every ``(d0, d1)`` of ``pairs``."""
        (x1, y1), (x2, y2) = task.ends.values()
        self.vectors = _Vectors(task.domain.theory.atoms, (x1, y1, x2, y2), pairs, guard)
        for t in range(self.h.m + 1):
            self.vectors.step(self.h, t)

    def excludes(self, history) -> str | None:
        """What in the store forbids a history (a :class:`~cplus.history.History`, such as a
        refinement's ``first_history``, or its ``states``: ground fluent -> value per step),
        as text, or ``None``: the solver's view of the clauses, evaluated in Python (to tell
        why a plan cannot be proposed, and to test the store). TypeError for anything else
        (a trajectory's ``StepState`` s, a result's ``states``, say which plan they are but
        not its fluents)."""
        given = list(history.states) if isinstance(history, History) else \
            list(history) if isinstance(history, (list, tuple)) else None
        wrong = type(history).__name__ if given is None else \
            next((f"a {type(history).__name__} of {type(s).__name__}" for s in given if not isinstance(s, dict)), None)
        if given is None or wrong is not None:
            raise TypeError(f"excludes() takes a History (such as result.history or result.first_history) or its "
                            f"states (list(history.states)), not {wrong}")
        states: list[dict] = given
        for nogood, _ in self.windows:
            for t in range(len(states) - nogood.span):
                if not any(self._holds(states, t, lit) for lit in nogood.lits):
                    return f"{nogood.text} (at step {t})"
        if self.vectors is not None:
            (x1, y1, x2, y2) = self.vectors.fluents
            turns = set(self.vectors.pairs)
            vec = [(s[x2] - s[x1], s[y2] - s[y1]) for s in states]
            for t in range(len(states) - 1):
                if (vec[t], vec[t + 1]) in turns:
                    return f"payload turn {vec[t]} -> {vec[t + 1]} (at step {t})"
        return None

    def _holds(self, states: list[dict], t: int, lit: tuple[int, int]) -> bool:
        off, a = lit
        gc, value = self.atoms.gc_of[abs(a)], self.atoms.value_of[abs(a)]
        v = states[t + off][gc]
        true = (v is True or v == "true") if value is None else to_object(gc, v) == value
        return true == (a > 0)

    def _step(self, t: int) -> None:
        for nogood, guard in self.windows:
            if t >= nogood.span:
                self._window(nogood, t - nogood.span, guard)
        if self.vectors is not None:
            self.vectors.step(self.h, t)

    def _window(self, nogood: Nogood, t: int, guard: int | None) -> None:
        var = self.h.var
        clause = [var(a, t + off) if a > 0 else -var(-a, t + off) for off, a in nogood.lits]
        if guard is not None:
            clause.append(-guard)
        self.h.solver.add_clause(clause)


class _Vectors:
    """Per step t and component value ``a``: a variable forced true when ``end2 - end1`` has
    that component (only this direction is needed: a forced variable fires a nogood)."""

    def __init__(self, atoms, fluents: tuple, pairs: list, guard: int | None) -> None:
        self.atoms = atoms
        self.fluents = fluents
        self.pairs = pairs
        self.guard = guard
        self.dx = sorted({d[0] for pair in pairs for d in pair})
        self.dy = sorted({d[1] for pair in pairs for d in pair})
        self.vars: list[tuple[dict[int, int], dict[int, int]]] = []

    def step(self, h, t: int) -> None:
        x1, y1, x2, y2 = self.fluents
        comps = []
        for first, second, values in ((x1, x2, self.dx), (y1, y2, self.dy)):
            table = {}
            for a in values:
                v = h.new_var()
                table[a] = v
                for c in first.domain:
                    lit2 = self.atoms.lit(second, c + a) if c + a in second.domain else 0
                    if lit2:
                        h.solver.add_clause([-h.var(self.atoms.lit(first, c), t), -h.var(lit2, t), v])
            comps.append(table)
        self.vars.append((comps[0], comps[1]))
        if t == 0:
            return
        (bx, by), (cx, cy) = self.vars[t - 1], self.vars[t]
        tail = [] if self.guard is None else [-self.guard]
        for (d0, d1) in self.pairs:
            h.solver.add_clause([-bx[d0[0]], -by[d0[1]], -cx[d1[0]], -cy[d1[1]], *tail])
