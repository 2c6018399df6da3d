"""Histories: what a model of the causal theory says, in source names.

A :class:`History` of length m holds the rigid constants, the states 0..m (every fluent's
value) and the actions 0..m-1 (every action constant's value), keyed by ground constants.
A Boolean constant's value is a Python ``bool`` (so ``[a for a, v in h.actions[0].items()
if v]`` are the actions done); the grounder and the solver's atoms know the objects
``"true"``/``"false"``, which :func:`to_object` gives back where atoms are looked up.
"""
from __future__ import annotations

from cplus.record import Record
from cplus.signature import GroundConst, render_value

__all__ = ["History", "decode_history", "executed_actions", "json_value", "to_object", "from_object"]


def json_value(gc: GroundConst, v: object):
    """A value as ``cplus.plan/1`` JSON and the API's name-keyed views give it: a Boolean
    constant's value is ``True``/``False``, integers and names stay, constructor objects are
    their text (``cell(2)``)."""
    if gc.boolean:
        return v is True or v == "true"
    if isinstance(v, (int, str)):
        return v
    return render_value(v)  # type: ignore[arg-type]


def to_object(gc: GroundConst, v: object) -> object:
    """A value as a :class:`History` holds it, as the grounder's object: a Boolean constant's
    ``True``/``False`` is ``"true"``/``"false"`` (what :meth:`AtomTable.lit` takes); other
    values are already objects."""
    if gc.boolean and isinstance(v, bool):
        return "true" if v else "false"
    return v


def from_object(gc: GroundConst, v: object) -> object:
    """The grounder's object as a :class:`History` holds it (the inverse of :func:`to_object`)."""
    return v == "true" if gc.boolean else v


class History(Record):
    """The tables are keyed by ground constants; a Boolean constant's value is ``True`` or
    ``False``, any other constant's the object the grounder knows (an integer, a name such as
    ``"none"``, a tuple for ``cell(2)``).  :meth:`value` and :meth:`state_values` speak by name
    and give values as the JSON output does."""

    _fields = ("maxstep", "rigid", "states", "actions")

    maxstep: int
    rigid: dict[GroundConst, object]
    states: tuple[dict[GroundConst, object], ...]
    actions: tuple[dict[GroundConst, object], ...]

    def __init__(
            self,
            maxstep: int,
            rigid: dict[GroundConst, object],
            states: tuple[dict[GroundConst, object], ...],
            actions: tuple[dict[GroundConst, object], ...]) -> None:
        self.maxstep = maxstep
        self.rigid = rigid
        self.states = states
        self.actions = actions

    def value(self, text: str, step: int | None = None) -> object:
        """Value of a ground constant given by its text (``"loc(d1)"``) at a step (rigid
        constants: no step), as in the JSON output."""
        if step is None:
            for gc, v in self.rigid.items():
                if gc.text == text:
                    return json_value(gc, v)
            raise KeyError(text)
        for table in (self.states[step], self.actions[step] if step < len(self.actions) else {}):
            for gc, v in table.items():
                if gc.text == text:
                    return json_value(gc, v)
        raise KeyError(text)

    def state_values(self, step: int) -> dict[str, object]:
        """Every fluent's value at a step, by name (``{"lit": True}``), as in the JSON output."""
        return {gc.text: json_value(gc, v) for gc, v in self.states[step].items()}

    def key(self) -> tuple:
        """A hashable identity of the history (two equal keys = the same history)."""
        return (tuple(sorted((gc.id, render_value(v)) for gc, v in self.rigid.items())),  # type: ignore[arg-type]
                tuple(tuple(sorted((gc.id, render_value(v)) for gc, v in s.items())) for s in self.states),  # type: ignore[arg-type]
                tuple(tuple(sorted((gc.id, render_value(v)) for gc, v in a.items())) for a in self.actions))  # type: ignore[arg-type]


def executed_actions(actions: dict[GroundConst, object]) -> list[GroundConst]:
    """Action constants that are 'done': Boolean ones true, others not none (attributes and
    hidden constants excluded)."""
    out = []
    for gc, v in actions.items():
        d = gc.decl
        if d.hidden or d.kind == "attribute":
            continue
        if v is True or (not gc.boolean and v != "none"):
            out.append(gc)
    return out


def decode_history(session) -> History:
    """Read the current model of a :class:`~cplus.sat.horizon.QuerySession`."""
    h = session.horizon
    s = h.solver
    atoms = session.atoms
    m = h.m
    rigid: dict = {}
    states: list[dict] = [dict() for _ in range(m + 1)]
    actions: list[dict] = [dict() for _ in range(m)]
    for gc in session.sig.ground:
        d = gc.decl
        if d.hidden:
            continue
        pairs = atoms.head_lits(gc)
        if d.kind == "rigid":
            rigid[gc] = _read(s, h, pairs, gc, None)
        elif d.is_action:
            for t in range(m):
                actions[t][gc] = _read(s, h, pairs, gc, t)
        else:
            for t in range(m + 1):
                states[t][gc] = _read(s, h, pairs, gc, t)
    return History(m, rigid, tuple(states), tuple(actions))


def _read(s, h, pairs, gc: GroundConst, t: int | None) -> object:
    if gc.boolean:
        return bool(s.value(h.var(pairs[0][0], t)))
    for aid, v in pairs:
        if s.value(h.var(aid, t)):
            return v
    raise AssertionError(f"no value for {gc.text} at {t}")  # exactly-one makes this impossible
