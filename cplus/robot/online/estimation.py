"""State estimation and planning from a state: the SAT side of the online loop.

The online loop (:mod:`cplus.robot.online.loop`) keeps one state ``s_k`` (every fluent with a
value) and asks an :class:`OnlineModel` three questions. All of them are answered with the
domain's ground theory and step templates, built once per run:

* :meth:`OnlineModel.initial_state`: the states at step 0 that the goal query's step-0
  conditions and the values sensed before anything moved allow;
* :meth:`OnlineModel.estimate`: the successors ``s_{k+1}`` of ``s_k`` under the actions
  executed and the events observed, agreeing with every sensed value. This is a horizon-1 query
  on one live solver kept for the whole run, with everything fixed by assumptions. One
  successor: carry on. None: the unsatisfiable core names the observations the model cannot
  explain. Several: the fluents left open are named;
* :meth:`OnlineModel.plan`: the shortest history from ``s_k`` that satisfies the goal (the
  query's conditions other than its step-0 ones), with every event false at every step: a plan
  never counts on an event.

Action constants have one of three *roles* (:class:`Roles`), given by the binding file or by
the caller. **Agent** actions are the robot's: the planner chooses them and the estimate fixes
them as executed. **Observed** events are reported by a sensor, a brick or an input channel:
false in plans, and in an estimate true exactly when they were observed. **Inferred** events
are never reported (a line follower that drives past a landmark): false in plans, free in an
estimate, so that sensing decides whether they happened. Attributes follow their action;
abnormalities and the grounder's hidden constants are left to the laws.

>>> from cplus.api import Domain
>>> d = Domain.from_text('''
... :- constants lit :: inertialFluent; flip, kick :: exogenousAction.
... flip causes lit.  kick causes -lit.
... :- query label :: on; maxstep :: 0..3; 0: -lit; maxstep: lit.''')
>>> m = OnlineModel(d, "on", Roles.of(d, observed=["kick"]))
>>> s0 = m.initial_state().state
>>> p = m.plan(s0)
>>> [[a.text for a in step] for step in p.steps]
[['flip']]
>>> m.estimate(s0, p.steps[0]).state.text()
{'lit': True}
>>> e = m.estimate(s0, p.steps[0], events=["kick"])
>>> e.status.value, e.unexplained
('none', ['event kick'])
"""
from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum

from cplus import ir
from cplus.errors import QueryError
from cplus.ground.theory import template_lit
from cplus.history import History, decode_history, to_object
from cplus.planner import find_horizon
from cplus.program import QuerySpec
from cplus.sat.horizon import Horizon, QuerySession
from cplus.sat.solver import DEFAULT_SOLVER
from cplus.signature import GroundConst, render_value

__all__ = ["Act", "Estimate", "EstimateStatus", "OnlineModel", "Plan", "Roles", "State", "json_value",
           "DEFAULT_MAX_HORIZON", "MAX_STATES"]

DEFAULT_MAX_HORIZON = 40
"""How long a plan may be when the goal query's maxstep range is open (``N..infinity``)."""

MAX_STATES = 16
"""How many distinct states an ambiguous estimate enumerates to name the fluents left open."""

_AGENT_KINDS = ("exogenousAction", "action")


def json_value(gc: GroundConst, value: object) -> object:
    """A value as JSON: ``true``/``false`` for a Boolean constant, integers and names as they
    are, constructor objects as CCALC prints them."""
    if gc.boolean:
        return value == "true"
    if isinstance(value, (int, str)):
        return value
    return render_value(value)  # type: ignore[arg-type]


class State(Mapping[GroundConst, object]):
    """Every fluent (and rigid constant) of the domain with a value: one point of a history."""

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[GroundConst, object]) -> None:
        self._values = dict(values)

    def __getitem__(self, gc: GroundConst) -> object:
        return self._values[gc]

    def __iter__(self):
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, State) and self._values == other._values

    def __hash__(self) -> int:
        return hash(frozenset(self._values.items()))

    def __repr__(self) -> str:
        return f"State({self.text()})"

    def text(self) -> dict[str, object]:
        """``{"atLandmark": 2, "trayUp": True, ...}`` in the domain's order of constants."""
        return {gc.text: json_value(gc, v) for gc, v in sorted(self._values.items(), key=lambda kv: kv[0].id)}

    def value(self, text: str) -> object:
        """The value of the constant written ``text`` (``"letter(3)"``); KeyError if none."""
        for gc, v in self._values.items():
            if gc.text == text:
                return v
        raise KeyError(text)

    def diff(self, other: State) -> dict[GroundConst, tuple[object, object]]:
        """The constants whose values differ: ``{gc: (value here, value there)}``."""
        return {gc: (v, other._values.get(gc)) for gc, v in self._values.items() if other._values.get(gc) != v}


@dataclass(frozen=True)
class Act:
    """One action occurrence of a step, as the executor receives it.

    ``text`` is how CCALC prints it (``move(r1,right,steps=2)``); ``value`` is the value of a
    non-Boolean action constant (``"true"`` for a Boolean one); ``attributes`` maps each
    attribute constant of the action that is not ``none`` to its value.
    """

    gc: GroundConst
    value: object
    attributes: Mapping[GroundConst, object]
    text: str

    @property
    def name(self) -> str:
        return self.gc.decl.name

    def attribute(self, name: str) -> object:
        """The value of the attribute called ``name`` (KeyError when it has none)."""
        for ag, v in self.attributes.items():
            if ag.decl.name == name:
                return v
        raise KeyError(name)


@dataclass(frozen=True)
class Roles:
    """Which ground action constants the robot does, and which events are observed or inferred."""

    agent: frozenset[GroundConst]
    observed: frozenset[GroundConst] = frozenset()
    inferred: frozenset[GroundConst] = frozenset()

    @property
    def events(self) -> frozenset[GroundConst]:
        return self.observed | self.inferred

    @classmethod
    def of(cls, domain, observed: Iterable[str] = (), inferred: Iterable[str] = ()) -> Roles:
        """Roles from names: constants named (``"press"``, every ``request(...)`` for
        ``"request"``) or ground instances written out (``"request(3)"``) are events; every other
        action constant is the agent's. Raises :class:`~cplus.errors.QueryError` for a name that
        is no action of the domain."""
        actions = user_actions(domain)

        def pick(names: Iterable[str]) -> frozenset[GroundConst]:
            out: set[GroundConst] = set()
            for name in names:
                hit = [gc for gc in actions if gc.text == name or gc.decl.name == name]
                if not hit:
                    raise QueryError(f"'{name}' is not an action constant of {domain.path}")
                out.update(hit)
            return frozenset(out)
        obs, inf = pick(observed), pick(inferred)
        return cls(frozenset(actions) - obs - inf, obs, inf - obs)


def user_actions(domain) -> list[GroundConst]:
    """The ground action constants a binding must place: exogenous and plain actions declared
    by the user (not attributes, abnormalities or the grounder's hidden constants)."""
    return [gc for gc in domain.program.signature.ground
            if gc.decl.kind in _AGENT_KINDS and not gc.decl.hidden and not gc.decl.auto_ab]


def state_constants(domain) -> list[GroundConst]:
    """The constants a state gives a value to: every fluent and rigid constant that is not
    hidden."""
    return [gc for gc in domain.program.signature.ground
            if (gc.decl.is_fluent or gc.decl.kind == "rigid") and not gc.decl.hidden]


class EstimateStatus(StrEnum):
    UNIQUE = "unique"       # one state agrees with everything observed
    NONE = "none"           # the model cannot explain the observations
    SEVERAL = "several"     # several states agree: some fluents are left open


@dataclass
class Estimate:
    """The answer of :meth:`OnlineModel.estimate` (or :meth:`~OnlineModel.initial_state`).

    ``state`` is the state when it is unique; ``open`` maps each fluent left open to the values
    it can take (several states); ``unexplained`` names the observations that cannot all hold
    (none: ``"sensed atLandmark=4"``, ``"event press"``); ``inferred`` lists the inferred
    events that every explanation needs (a unique state reached through a missed landmark).
    """

    status: EstimateStatus
    state: State | None = None
    states: list[State] = field(default_factory=list)
    open: dict[GroundConst, list[object]] = field(default_factory=dict)
    unexplained: list[str] = field(default_factory=list)
    inferred: list[GroundConst] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def unique(self) -> bool:
        return self.status is EstimateStatus.UNIQUE


@dataclass
class Plan:
    """A plan from a state: the agent's actions per step and the states it predicts
    (``states[0]`` is the state planned from, ``states[i+1]`` the prediction after step i).

    A ``partial`` plan reaches only part of the goal (a planner that serves goals one at a
    time, :mod:`cplus.robot.serving.standing`): when it has been carried out, the loop plans again."""

    steps: list[list[Act]]
    states: list[State]
    history: History
    seconds: float = 0.0
    partial: bool = False

    @property
    def length(self) -> int:
        return len(self.steps)

    def texts(self) -> list[list[str]]:
        """The plan as CCALC prints actions, one list per step (the log's ``plan``)."""
        return [[a.text for a in step] for step in self.steps]

    def rest(self) -> Plan:
        """The plan without its first step (what remains once that step was executed)."""
        h = self.history
        rest = History(h.maxstep - 1, h.rigid, h.states[1:], h.actions[1:])
        return Plan(self.steps[1:], self.states[1:], rest, 0.0, self.partial)


class OnlineModel:
    """A domain and a goal, grounded once, answering the online loop's questions.

    ``goal`` is a query label: its step-0 conditions describe where the run starts, its other
    conditions (stamped ``maxstep``, or quantified over steps) are the goal, and its maxstep
    range bounds the length of every plan made from a state (``max_horizon`` when it is open).
    """

    def __init__(self, domain, goal: str, roles: Roles, *, solver: str = DEFAULT_SOLVER,
                 max_horizon: int | None = None) -> None:
        self.domain = domain
        self.roles = roles
        self.solver = solver
        self.query: QuerySpec = domain.query(goal)
        self.start_items, goal_items = split_query(self.query)
        hi = self.query.hi if self.query.hi is not None else (max_horizon or DEFAULT_MAX_HORIZON)
        self.goal_query = QuerySpec(self.query.label, 0, hi, tuple(goal_items), self.query.loc)
        self.start_query = QuerySpec(self.query.label, 0, 0, tuple(self.start_items), self.query.loc)
        self.theory = domain.theory
        self.templates = domain.templates
        self.atoms = self.theory.atoms
        self.state_gcs = state_constants(domain)
        self.by_text = {gc.text: gc for gc in domain.program.signature.ground}
        self._est: Horizon | None = None
        self._zero: Horizon | None = None

    # ------------------------------------------------------------------ literals
    def _lit(self, h: Horizon, gc: GroundConst, value: object, t: int) -> int:
        a = self.atoms.lit(gc, value)
        if a == 0:
            raise ValueError(f"{render_value(value)!r} is not a value of {gc.text}")  # type: ignore[arg-type]
        v = h.var(abs(a), t)
        return v if a > 0 else -v

    def _happened(self, h: Horizon, gc: GroundConst) -> int:
        """The literal that an event happened at step 0: ``e`` (a non-Boolean one: ``e`` is not ``none``)."""
        return self._lit(h, gc, "true", 0) if gc.boolean else -self._lit(h, gc, "none", 0)

    def _state_lits(self, h: Horizon, state: Mapping[GroundConst, object], t: int) -> list[int]:
        return [self._lit(h, gc, v, t) for gc, v in state.items()]

    def _read_state(self, h: Horizon, t: int) -> State:
        s = h.solver
        out: dict[GroundConst, object] = {}
        for gc in self.state_gcs:
            pairs = self.atoms.head_lits(gc)
            if gc.boolean:
                out[gc] = "true" if s.value(h.var(pairs[0][0], t)) else "false"
            else:
                out[gc] = next(v for aid, v in pairs if s.value(h.var(aid, t)))
        return State(out)

    def _state_vars(self, h: Horizon, t: int) -> list[int]:
        return [h.var(aid, t) for gc in self.state_gcs for aid in self.atoms.atoms(gc)]

    # ------------------------------------------------------------------ questions
    def initial_state(self, sensed: Mapping[GroundConst, object] | None = None) -> Estimate:
        """The state at step 0: the goal query's step-0 conditions and ``sensed`` values."""
        return self._states_with(self.start_query, sensed or {})

    def complete(self, values: Mapping[GroundConst, object]) -> Estimate:
        """The states that agree with ``values`` (the domain's static laws decide the rest):
        is this assignment a state, and which one? (One live horizon-0 solver per run.)"""
        t0 = time.perf_counter()
        if self._zero is None:
            self._zero = Horizon(self.theory, self.solver, templates=self.templates)
        h = self._zero
        bad = [f"{_atom(gc, v)}, not a value of {gc.text}" for gc, v in values.items() if self.atoms.lit(gc, v) == 0]
        if bad:
            return Estimate(EstimateStatus.NONE, unexplained=bad, seconds=time.perf_counter() - t0)
        fixed = self._state_lits(h, values, 0)
        obs = {lit: _atom(gc, v) for lit, (gc, v) in zip(fixed, values.items())}
        est = self._enumerate(h, fixed, obs, 0, [])
        est.seconds = time.perf_counter() - t0
        return est

    def _states_with(self, spec: QuerySpec, sensed: Mapping[GroundConst, object]) -> Estimate:
        t0 = time.perf_counter()
        session = QuerySession(self.theory, spec, self.solver, templates=self.templates)
        h = session.horizon
        for gc, v in (sensed or {}).items():
            if self.atoms.lit(gc, v) == 0:
                return Estimate(EstimateStatus.NONE, unexplained=[f"sensed {_atom(gc, v)}, not a value of {gc.text}"],
                                seconds=time.perf_counter() - t0)
        obs = {self._lit(h, gc, v, 0): f"sensed {_atom(gc, v)}" for gc, v in (sensed or {}).items()}
        session.assert_items(0)
        est = self._enumerate(h, list(obs), obs, 0, [])
        est.seconds = time.perf_counter() - t0
        return est

    def estimate(self, state: State, acts: Iterable[Act], events: Iterable[GroundConst | str] = (),
                 sensed: Mapping[GroundConst, object] | None = None) -> Estimate:
        """The successors of ``state`` under ``acts`` (the agent's actions executed, with their
        attributes) and ``events`` (observed), that agree with ``sensed`` (values at the new
        step)."""
        t0 = time.perf_counter()
        h = self._estimator()
        fixed = self._state_lits(h, state, 0)
        done = {a.gc: a for a in acts}
        for gc in self.roles.agent:
            a = done.get(gc)
            fixed.append(self._lit(h, gc, a.value if a else _absent(gc), 0))
            if a is not None:
                fixed.extend(self._lit(h, ag, v, 0) for ag, v in a.attributes.items())
        obs: dict[int, str] = {}
        seen = {self.by_text[e] if isinstance(e, str) else e for e in events}
        for gc in self.roles.observed:
            if gc in seen:
                obs[self._happened(h, gc)] = f"event {gc.text}"
            else:
                fixed.append(self._lit(h, gc, _absent(gc), 0))
        for gc in seen - self.roles.observed:
            obs[self._happened(h, gc)] = f"event {gc.text}"
        for gc, v in (sensed or {}).items():
            if self.atoms.lit(gc, v) == 0:
                return Estimate(EstimateStatus.NONE, unexplained=[f"sensed {_atom(gc, v)}, not a value of {gc.text}"],
                                seconds=time.perf_counter() - t0)
            obs[self._lit(h, gc, v, 1)] = f"sensed {_atom(gc, v)}"
        est = self._enumerate(h, fixed + list(obs), obs, 1, fixed)
        if est.unique:
            est.inferred = self._inferred(h, fixed + list(obs) + self._state_lits(h, est.state, 1))  # type: ignore[arg-type]
        est.seconds = time.perf_counter() - t0
        return est

    def session(self, state: State) -> QuerySession:
        """A live solver for the goal from ``state`` (events false at every step), not yet
        solved: :meth:`plan` searches it, the refinement loop refines in it."""
        session = QuerySession(self.theory, self.goal_query, self.solver, self.goal_query.hi,
                               templates=self.templates)
        h = session.horizon
        for lit in self._state_lits(h, state, 0):
            h.solver.add_clause([lit])
        for gc in self.roles.events:
            for aid, v in self.atoms.head_lits(gc):
                if v not in ("false", "none"):
                    h.forbid_everywhere(template_lit(aid, 0))
        return session

    def plan(self, state: State) -> Plan | None:
        """The shortest plan from ``state`` to the goal (events absent), or None when there is
        none within the goal query's maxstep range."""
        t0 = time.perf_counter()
        session = self.session(state)
        find_horizon(session)
        if session.found is None:
            return None
        return self.plan_of(decode_history(session), time.perf_counter() - t0)

    # ------------------------------------------------------------------ helpers
    def plan_of(self, hist: History, seconds: float = 0.0) -> Plan:
        """A history (from a session of :meth:`session`) as a :class:`Plan` (whose states and
        acts hold the grounder's objects: ``"true"`` where the history has ``True``)."""
        states = [State({gc: to_object(gc, hist.rigid[gc] if gc.decl.kind == "rigid" else s[gc])
                         for gc in self.state_gcs}) for s in hist.states]
        steps = [self.acts({gc: to_object(gc, v) for gc, v in table.items()}) for table in hist.actions]
        return Plan(steps, states, hist, seconds)

    def acts(self, table: Mapping[GroundConst, object]) -> list[Act]:
        """The agent's actions done in one step of a history, with their attributes."""
        out = []
        for gc in sorted(self.roles.agent, key=lambda g: g.id):
            v = table.get(gc)
            if v is None or v in ("false", "none"):
                continue
            attrs = {ag: av for ag, av in table.items()
                     if ag.decl.kind == "attribute" and ag.decl.parent is gc.decl
                     and ag.args[:gc.decl.arity] == gc.args and av != "none"}
            out.append(Act(gc, v, attrs, action_text(gc, v, attrs)))
        return out

    def _estimator(self) -> Horizon:
        if self._est is None:
            h = Horizon(self.theory, self.solver, templates=self.templates)
            h.extend_to(1)
            self._est = h
        return self._est

    def _enumerate(self, h: Horizon, assumptions: list[int], obs: dict[int, str], t: int,
                   fixed: list[int]) -> Estimate:
        s = h.solver
        if not s.solve(assumptions):
            return Estimate(EstimateStatus.NONE, unexplained=self._unexplained(h, assumptions, obs, fixed))
        states = [self._read_state(h, t)]
        guard = h.new_var()
        projection = self._state_vars(h, t)
        while len(states) < MAX_STATES:
            s.add_clause([-guard] + [-v if s.value(v) else v for v in projection])
            if not s.solve(assumptions + [guard]):
                break
            states.append(self._read_state(h, t))
        s.add_clause([-guard])
        if len(states) == 1:
            return Estimate(EstimateStatus.UNIQUE, states[0], states)
        opened: dict[GroundConst, list[object]] = {}
        for gc in self.state_gcs:
            values = {st[gc] for st in states}
            if len(values) > 1:
                opened[gc] = [v for v in gc.domain if v in values]
        return Estimate(EstimateStatus.SEVERAL, None, states, opened)

    def _unexplained(self, h: Horizon, assumptions: list[int], obs: dict[int, str], fixed: list[int]) -> list[str]:
        """A minimal set of observations that the model cannot explain together with the
        state and the executed actions (deletion over the solver's core)."""
        s = h.solver
        core = [x for x in s.core() if x in obs]
        if not core:
            return []
        keep = list(core)
        for x in core:
            trial = [y for y in keep if y != x]
            if not s.solve(fixed + trial):
                keep = trial
        return [obs[x] for x in keep]

    def _inferred(self, h: Horizon, assumptions: list[int]) -> list[GroundConst]:
        """The inferred events true in every model with the estimated state."""
        s = h.solver
        out = []
        for gc in sorted(self.roles.inferred, key=lambda g: g.id):
            if not s.solve(assumptions + [-self._happened(h, gc)]):
                out.append(gc)
        return out


def action_text(gc: GroundConst, value: object, attrs: Mapping[GroundConst, object]) -> str:
    """How CCALC prints an action with its attributes: ``move(r1,right,steps=2)``."""
    if not gc.boolean:
        return f"{gc.text}={render_value(value)}"  # type: ignore[arg-type]
    if not attrs:
        return gc.text
    parts = [render_value(a) for a in gc.args]
    for ag, v in sorted(attrs.items(), key=lambda kv: (kv[0].decl.order, kv[0].id)):
        rest = ag.args[gc.decl.arity:]
        name = ag.decl.name + (f"({','.join(render_value(a) for a in rest)})" if rest else "")
        parts.append(f"{name}={render_value(v)}")  # type: ignore[arg-type]
    return f"{gc.decl.name}({','.join(parts)})"


def _absent(gc: GroundConst) -> str:
    """The value of an action constant at a step it is not done."""
    return "false" if gc.boolean else "none"


def _atom(gc: GroundConst, value: object) -> str:
    if gc.boolean:
        return gc.text if value == "true" else f"-{gc.text}"
    return f"{gc.text}={render_value(value)}"  # type: ignore[arg-type]


def split_query(query: QuerySpec) -> tuple[list, list]:
    """Split a query's items into the start (conditions stamped ``0:``) and the goal (the
    rest). A condition stamped with another step number means nothing when planning from the
    current state, and is refused."""
    start: list = []
    goal: list = []
    for formula, loc in query.items:
        for part in ir.conjuncts(formula):
            if isinstance(part, ir.StampF) and isinstance(part.time, ir.Lit):
                if part.time.value == 0:
                    start.append((part, loc))
                    continue
                raise QueryError(f"a condition at step {part.time.value} has no meaning when the plan starts from "
                                 "the current state: stamp start conditions '0:' and goals 'maxstep:'",
                                 getattr(part, "loc", None) or loc)
            goal.append((part, loc))
    return start, goal
