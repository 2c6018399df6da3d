"""The online loop: plan, act, observe, estimate, monitor, commit (Legolog's Indigolog loop over
a C+ domain).

One run keeps one growing history. Cycle ``k`` starts in the state ``s_k``:

1. **decide**: when there is no plan, or the last estimate differed from the plan's prediction,
   plan afresh from ``s_k`` (:meth:`OnlineModel.plan`: the shortest history that satisfies
   the goal, with events assumed absent in the future). A plan of length 0 means the goal
   holds: the run stops (``when_done="stop"``), or waits for an event (``"wait"``, for a
   standing goal that requests re-open);
2. **act**: the executor performs the agent's actions of the plan's first step (nothing, on an
   idle step) and reports the sensed values and the events it saw meanwhile;
3. **observe**: every :class:`EventSource` is polled; what arrived belongs to the transition
   that just ended;
4. **estimate**: ``s_{k+1}`` is the successor of ``s_k`` under the executed actions and the
   observed events that agrees with every sensed value (:meth:`OnlineModel.estimate`). With
   none, the world contradicted the model and the run stops, naming the observation. With
   several, the run stops, naming the fluents left open;
5. **monitor**: ``s_{k+1}`` equal to the plan's prediction → carry on with the rest of the plan;
   different → re-plan at the next cycle (the record says which fluents differed, and the
   events);
6. **commit**: the transition is history and is never revised.

The record of cycle ``k`` (:class:`CycleRecord`, one line of the ``cplus.online/1`` log) holds
what was known at step ``k``: the state, the events and sensed values that led to it, the
re-plan and its reason, the remaining plan, and the actions executed from it.

Python API::

    from cplus.api import Domain
    from cplus.robot.online.estimation import OnlineModel, Roles
    from cplus.robot.online.loop import OnlineLoop
    from cplus.robot.online.executors import SimulatedExecutor

    domain = Domain.load("domains/delivery/delivery.cp")
    model = OnlineModel(domain, "deliver", Roles.of(domain, observed=["press"], inferred=["missed"]))
    loop = OnlineLoop(model, SimulatedExecutor(model), observers=[my_observer])
    result = loop.run()          # RunResult: status, records, message
    result.status                # OnlineStatus.GOAL_REACHED

The pieces are interfaces, so that other front ends reuse the loop: an :class:`Executor` does
the robot's actions (:mod:`cplus.robot.online.executors`: a simulated one whose actions take a
configurable time; NXT bricks through the behaviour protocol), an :class:`EventSource` brings
events from outside (a script, standard input, a request channel), and an :class:`Observer` is
told about each step (progress lines, the JSON-lines log, a server's feedback). :meth:`OnlineLoop.stop`
ends a run from another thread between two cycles. Nothing here prints or exits.
"""
from __future__ import annotations

import json
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from enum import StrEnum

from cplus.robot.online.estimation import Act, Estimate, EstimateStatus, OnlineModel, Plan, State, json_value
from cplus.signature import GroundConst, render_value
from nxt_link.wire.clock import MONOTONIC, Clock

__all__ = ["ONLINE_FORMAT", "CycleRecord", "EventSource", "Executor", "JsonLinesLog", "Observer", "OnlineLoop",
           "OnlineStatus", "Outcome", "Replan", "RobotLost", "RunResult", "Step"]

ONLINE_FORMAT = "cplus.online/1"


class OnlineStatus(StrEnum):
    """How a run ended (the ``status`` of the log's end record; the CLI's exit code)."""

    GOAL_REACHED = "goal_reached"      # the goal holds in the estimated state
    NO_PLAN = "no_plan"                # no plan from the observed state within the goal's maxstep range
    CONTRADICTED = "contradicted"      # the world contradicted the model (an observation, a failed action)
    AMBIGUOUS = "ambiguous"            # several states agree with the observations
    ROBOT_LOST = "robot_lost"          # an executor lost its robot (a brick stopped answering)
    MAX_CYCLES = "max_cycles"          # the cycle limit came first
    STOPPED = "stopped"                # stop() was called, or the run was interrupted


class RobotLost(Exception):
    """An executor lost contact with a robot; the message names it and says why."""


@dataclass(frozen=True)
class Step:
    """What the executor is asked to do at one cycle.

    ``acts`` are the agent's actions (empty: an idle step); ``state`` is the state the loop
    believes the robot is in, ``predicted`` what the plan expects afterwards (None on an idle
    step): a real robot ignores both, a simulated one uses them. ``stop`` is set when the
    step is to be cut short (:meth:`OnlineLoop.interrupt`: a goal preempted with ``--preempt
    stop``): an executor that can stop an action part-way does so and reports which actions
    ran (:attr:`Outcome.ran`); one that cannot lets them finish.
    """

    cycle: int
    acts: Sequence[Act]
    state: State
    predicted: State | None
    stop: threading.Event | None = None


@dataclass
class Outcome:
    """What an executor reports after a step.

    ``sensed`` maps sensed fluents to their values after the step; ``events`` are events the
    executor's robot saw during it (a button); ``raw`` keeps the readings behind ``sensed``
    (``{"robot.landmark": 3}``); ``failure`` says why an action could not be done (a behaviour
    reported it was stuck); ``notes`` are things worth a line in the log (an event with no
    binding, ignored). ``ran``: the actions that were executed, when not all of them were (an
    action refused or stopped before it started is not; one stopped part-way is, with the
    event that says so among ``events``); None: all of them.
    """

    sensed: dict[GroundConst, object] = field(default_factory=dict)
    events: list[GroundConst] = field(default_factory=list)
    raw: dict[str, object] = field(default_factory=dict)
    failure: str | None = None
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    ran: list[Act] | None = None


class Executor(ABC):
    """Does the agent's actions on a robot (real, emulated or simulated)."""

    description = "a robot"
    """What it is, for the log's start record (``"emulated NXT bricks: robot=/dev/pts/4"``)."""

    def open(self) -> None:
        """Connect (called once, before the first cycle)."""
        return None

    def sense(self) -> Outcome:
        """Read the sensors before anything moved (the sensed values of step 0)."""
        return Outcome()

    @abstractmethod
    def execute(self, step: Step) -> Outcome:
        """Perform ``step.acts`` (all of them, then return) and report what was observed.

        Raises:
            RobotLost: the robot does not answer any more.
        """

    def poll(self) -> Outcome:
        """Events seen while idle (called repeatedly while the loop waits for one)."""
        return Outcome()

    def abort(self) -> None:
        """Stop whatever the robot is doing (best effort: the run is ending badly)."""
        return None

    def close(self) -> None:
        """Release the robot (called once, however the run ended)."""
        return None


class EventSource(ABC):
    """Events from outside the robot: lines of a script or of standard input, requests.

    Events are ground action constants written as CCALC prints them (``press``,
    ``request(office3,office2)``); the loop checks them against the domain.
    """

    @abstractmethod
    def poll(self, cycle: int) -> list[str]:
        """The events that arrived for the transition ending at ``cycle`` (never blocks)."""

    def waiting(self, cycle: int) -> bool:
        """True when events are scheduled for ``cycle`` or later: an idle step then ends at
        once, so that a script runs deterministically. Live sources say False."""
        return False

    def ready(self, cycle: int) -> bool | None:
        """Whether :meth:`poll` would bring events for ``cycle`` now, looked at without taking
        them; None (the default): the source cannot tell without taking them, and the idle
        step polls it and keeps what came for the transition. A source that can look
        overrides it, so that each transition polls it exactly once: what it hands over is
        then committed with the transition that ends there, and what arrives later (a
        cancellation of what was just handed over) belongs to the next one."""
        return None

    def wait(self, timeout: float) -> None:
        """Block until something may have arrived, at most ``timeout`` seconds."""
        time.sleep(timeout)

    def finished(self) -> bool:
        """No event will ever come any more (a script delivered, standard input closed)."""
        return False

    def notes(self) -> list[str]:
        """Messages about input that was ignored since the last call (a typo at the keyboard)."""
        return []


@dataclass
class Replan:
    """Why the plan of a cycle was made: ``"start"``, ``"event"`` (an observed event changed
    the state), ``"diverged"`` (a sensed value or an inferred event did) or ``"partial"`` (the
    last plan reached part of the goal, :attr:`Plan.partial`), with each fluent whose
    estimated value differs from the prediction."""

    reason: str
    differ: dict[GroundConst, tuple[object, object]] = field(default_factory=dict)
    events: list[str] = field(default_factory=list)

    def to_json(self) -> dict:
        return {"reason": self.reason,
                "fluents": {gc.text: {"predicted": json_value(gc, p), "observed": json_value(gc, o)}
                            for gc, (p, o) in sorted(self.differ.items(), key=lambda kv: kv[0].id)},
                "events": list(self.events)}

    def text(self) -> str:
        """``after press: letter(1) false -> true`` / ``diverged: atLandmark 2 -> 3``."""
        changes = ", ".join(f"{gc.text} {_value_text(p)} -> {_value_text(o)}" for gc, (p, o) in self.differ.items())
        if self.reason == "event":
            return f"after {', '.join(self.events)}" + (f": {changes}" if changes else "")
        return f"{self.reason}: {changes}" if changes else self.reason


@dataclass
class CycleRecord:
    """One cycle of a run (one line of the ``cplus.online/1`` log).

    ``state`` is None when the estimate of this step failed (then ``plan`` is None and
    nothing was executed); ``plan`` is the remaining plan from ``state`` (empty when the goal
    holds); ``executed`` the actions sent at this cycle.
    """

    cycle: int
    time: float
    state: State | None
    events: list[str] = field(default_factory=list)
    inferred: list[str] = field(default_factory=list)
    sensed: dict[GroundConst, object] = field(default_factory=dict)
    raw: dict[str, object] = field(default_factory=dict)
    plan: Plan | None = None
    replanned: Replan | None = None
    executed: list[Act] = field(default_factory=list)
    failure: str | None = None
    notes: list[str] = field(default_factory=list)
    decision_s: float = 0.0
    act_s: float = 0.0

    def to_json(self) -> dict:
        """The log line (schema ``cplus.online/1``, README and docs/online.md)."""
        return {
            "record": "cycle",
            "cycle": self.cycle,
            "time": round(self.time, 6),
            "state": None if self.state is None else self.state.text(),
            "events": list(self.events),
            "inferred": list(self.inferred),
            "sensed": {gc.text: json_value(gc, v) for gc, v in self.sensed.items()},
            "raw": dict(self.raw),
            "plan": None if self.plan is None else self.plan.texts(),
            "replanned": None if self.replanned is None else self.replanned.to_json(),
            "executed": [a.text for a in self.executed],
            "failure": self.failure,
            "notes": list(self.notes),
            "decision_ms": round(self.decision_s * 1000, 3),
            "act_s": round(self.act_s, 6),
        }


@dataclass
class RunResult:
    """How a run ended, and every cycle of it."""

    status: OnlineStatus
    message: str
    records: list[CycleRecord]
    state: State | None
    unexplained: list[str] = field(default_factory=list)
    open: dict[GroundConst, list[object]] = field(default_factory=dict)
    seconds: float = 0.0
    dropped: int = 0              # the first cycles' records, not kept (``keep_records``)
    dropped_replans: int = 0      # the re-plans among them

    @property
    def cycles(self) -> int:
        return len(self.records) + self.dropped

    @property
    def replans(self) -> int:
        return self.dropped_replans + sum(1 for r in self.records
                                          if r.replanned is not None and r.replanned.reason != "start")

    def to_json(self) -> dict:
        """The log's end record."""
        return {"record": "end", "status": self.status.value, "message": self.message,
                "cycles": self.cycles, "replans": self.replans,
                "state": None if self.state is None else self.state.text(),
                "unexplained": list(self.unexplained),
                "open": {gc.text: [json_value(gc, v) for v in vs] for gc, vs in self.open.items()},
                "seconds": round(self.seconds, 6)}


class Observer:
    """Told about a run as it goes; every method is a no-op unless overridden."""

    def on_start(self, loop: OnlineLoop) -> None:
        """Before the executor is opened and the first cycle runs."""

    def on_act(self, record: CycleRecord) -> None:
        """A cycle's decision is made and its actions go to the executor (``record.executed``
        is what is about to be sent; ``act_s`` is not known yet)."""

    def on_cycle(self, record: CycleRecord) -> None:
        """A cycle is complete (its actions were executed, or the run ends here)."""

    def on_end(self, result: RunResult) -> None:
        """The run ended (the executor is closed)."""


class JsonLinesLog(Observer):
    """The ``cplus.online/1`` log: a start record, one record per cycle, an end record; one
    JSON object per line, each line flushed as soon as it is known (nothing is lost when a
    run is interrupted)."""

    def __init__(self, stream, extra: Mapping[str, object] | None = None,
                 annotate: Callable[[CycleRecord, dict], None] | None = None) -> None:
        """``extra``: more fields of the start record; ``annotate(record, line)``: adds fields to
        each cycle's line before it is written (a server's goals and their statuses)."""
        self.stream = stream
        self.extra = dict(extra or {})
        self.annotate = annotate
        self._lock = threading.Lock()
        self._ended = False
        self._cycles = 0
        self._t0 = time.monotonic()

    def _write(self, obj: dict, end: bool = False) -> None:
        """One whole line, under a lock: the run's thread and a shutdown watchdog
        (:meth:`end_forced`) may both want to write, and the log must stay JSON lines with
        one end record."""
        line = json.dumps(obj, separators=(",", ":")) + "\n"
        with self._lock:
            if self._ended:
                return
            self._ended = end
            self.stream.write(line)
            self.stream.flush()

    def end_forced(self, message: str, timeout_s: float = 0.2) -> None:
        """The end record of a run whose thread did not get to write it (a watchdog ending the
        process): status ``stopped``, ``"forced": true``. Nothing if the end was written."""
        if not self._lock.acquire(timeout=timeout_s):
            return                                   # a write is stuck: leave the lines as they are
        try:
            if self._ended:
                return
            self._ended = True
            record = {"record": "end", "status": OnlineStatus.STOPPED.value, "message": message, "cycles": self._cycles,
                      "forced": True, "seconds": round(time.monotonic() - self._t0, 6)}
            self.stream.write(json.dumps(record, separators=(",", ":")) + "\n")
            self.stream.flush()
        finally:
            self._lock.release()

    def start_record(self, loop: OnlineLoop) -> dict:
        """The run's start record (the first line of a run; a log continued after a restart
        holds several runs, each from its own start record)."""
        roles = loop.model.roles
        started = datetime.now(UTC).isoformat(timespec="seconds")
        return {"record": "start", "format": ONLINE_FORMAT, "started": started, "domain": loop.model.domain.path,
                "goal": loop.model.query.label, "max_plan_length": loop.model.goal_query.hi,
                "agent": sorted(gc.text for gc in roles.agent),
                "observed": sorted(gc.text for gc in roles.observed),
                "inferred": sorted(gc.text for gc in roles.inferred),
                "executor": loop.executor.description, **self.extra}

    def on_start(self, loop: OnlineLoop) -> None:
        self._t0 = time.monotonic()
        self._write(self.start_record(loop))

    def on_cycle(self, record: CycleRecord) -> None:
        line = record.to_json()
        if self.annotate is not None:
            self.annotate(record, line)
        self._cycles += 1
        self._write(line)

    def on_end(self, result: RunResult) -> None:
        self._write(result.to_json(), end=True)


class OnlineLoop:
    """One online run of a model on an executor.

    ``when_done``: ``"stop"`` ends the run when the goal holds; ``"wait"`` keeps waiting for
    events (idle steps) until :meth:`stop`, or until every event source has finished.
    ``max_cycles`` bounds the number of cycles that execute a step. ``idle_poll_s`` is how long
    an idle step waits between two polls of the live event sources. ``keep_records`` bounds
    the records kept in memory (the last ones; None: all), for a run without end (a server):
    the observers see every record as it comes, the result counts the ones dropped.
    """

    def __init__(self, model: OnlineModel, executor: Executor, sources: Iterable[EventSource] = (),
                 observers: Iterable[Observer] = (), *, when_done: str = "stop", max_cycles: int | None = None,
                 clock: Clock = MONOTONIC, idle_poll_s: float = 0.05, keep_records: int | None = None) -> None:
        if when_done not in ("stop", "wait"):
            raise ValueError(f"when_done must be 'stop' or 'wait', not {when_done!r}")
        self.model = model
        self.executor = executor
        self.sources = list(sources)
        self.observers = list(observers)
        self.when_done = when_done
        self.max_cycles = max_cycles
        self.clock = clock
        self.idle_poll_s = idle_poll_s
        self._stop = threading.Event()
        self._cut = threading.Event()           # the step under way is to be cut short
        self._acting = False
        self._act_lock = threading.Lock()       # a leaf: guards _acting
        self._early: dict[EventSource, list[str]] = {}
        self._t0 = 0.0
        self.records: list[CycleRecord] = []
        self.keep_records = keep_records
        self._dropped = self._dropped_replans = 0
        self.state: State | None = None

    def stop(self) -> None:
        """Ask the run to end between two cycles (thread-safe); it ends as ``stopped``."""
        self._stop.set()

    def interrupt(self) -> bool:
        """Cut the step under way short (thread-safe, never blocks): its :attr:`Step.stop` is
        set, and an executor that can stop its actions part-way does so (the motors to 0),
        reports what it measured, and the loop estimates the state from that and plans on.
        False when no step is under way (nothing to cut short)."""
        with self._act_lock:
            if self._acting:
                self._cut.set()
            return self._acting

    # ------------------------------------------------------------------ the run
    def run(self) -> RunResult:
        """Run until the goal holds (or a failure, the cycle limit, :meth:`stop`)."""
        self._t0 = self.clock.now()
        result: RunResult | None = None
        for obs in self.observers:
            obs.on_start(self)
        try:
            self.executor.open()
            result = self._run()
        except RobotLost as exc:           # while connecting or sensing before the first cycle
            result = self._end(OnlineStatus.ROBOT_LOST, str(exc))
        except KeyboardInterrupt as exc:       # Ctrl-C, or a SIGTERM raised as one (its text says which)
            result = self._end(OnlineStatus.STOPPED, str(exc) or "interrupted")
            raise
        finally:
            if result is None or result.status not in (OnlineStatus.GOAL_REACHED, OnlineStatus.MAX_CYCLES):
                try:
                    self.executor.abort()
                except Exception:  # noqa: BLE001 - already ending badly; the first error is reported
                    pass
            self.executor.close()
            if result is not None:
                result.seconds = self.clock.now() - self._t0
                for obs in self.observers:
                    obs.on_end(result)
        return result

    def _now(self) -> float:
        return self.clock.now() - self._t0

    def _run(self) -> RunResult:
        model = self.model
        t = time.perf_counter()
        first = self.executor.sense()
        est = model.initial_state(first.sensed)
        record = CycleRecord(0, self._now(), est.state, sensed=dict(first.sensed), raw=dict(first.raw),
                             notes=list(first.notes))
        if not est.unique:
            record.decision_s = time.perf_counter() - t
            return self._unknown(record, est, "the start")
        state: State = est.state  # type: ignore[assignment]
        plan: Plan | None = None
        reason: Replan | None = Replan("start")
        cycle = 0
        while True:
            self.state = state
            if plan is None:
                plan = model.plan(state)
            record.plan, record.replanned = plan, reason
            record.decision_s += time.perf_counter() - t
            if plan is None:
                self._record(record)
                hi = model.goal_query.hi
                return self._end(OnlineStatus.NO_PLAN, f"no plan reaches the goal '{model.query.label}' from the "
                                 f"state of cycle {cycle} within {hi} steps")
            if self._stop.is_set():
                self._record(record)
                return self._end(OnlineStatus.STOPPED, f"ended on request at cycle {cycle}")
            if plan.length == 0 and self.when_done == "stop":
                self._record(record)
                return self._end(OnlineStatus.GOAL_REACHED, f"goal '{model.query.label}' reached at cycle {cycle}")
            if self.max_cycles is not None and cycle >= self.max_cycles:
                self._record(record)
                return self._end(OnlineStatus.MAX_CYCLES, f"no goal after {cycle} cycles, the --max-cycles limit")
            # act
            acts = plan.steps[0] if plan.length else []
            predicted = plan.states[1] if plan.length else None
            record.executed = list(acts)
            for obs in self.observers:
                obs.on_act(record)
            t_act = self.clock.now()
            outcome: Outcome | None
            try:
                if plan.length:
                    self._cut.clear()
                    with self._act_lock:
                        self._acting = True
                    try:
                        outcome = self.executor.execute(Step(cycle, acts, state, predicted, self._cut))
                    finally:
                        with self._act_lock:
                            self._acting = False
                else:
                    outcome = self._idle(cycle)
            except RobotLost as exc:
                record.failure = str(exc)
                record.act_s = self.clock.now() - t_act
                self._record(record)
                return self._end(OnlineStatus.ROBOT_LOST, str(exc))
            if outcome is None:
                self._record(record)
                if self._stop.is_set():
                    return self._end(OnlineStatus.STOPPED, f"ended on request at cycle {cycle}")
                return self._end(OnlineStatus.GOAL_REACHED, f"goal '{model.query.label}' holds at cycle {cycle} "
                                 "and no more events will come")
            record.act_s = self.clock.now() - t_act
            record.failure = outcome.failure
            record.notes.extend(outcome.notes)
            sent = list(acts)
            if outcome.ran is not None:      # the log says what ran, not what was sent
                acts = list(outcome.ran)
                record.executed = list(acts)
            self._record(record)
            # observe
            cycle += 1
            t = time.perf_counter()
            events, notes = self._events(outcome, cycle)
            record = CycleRecord(cycle, self._now(), None, events=[e.text for e in events],
                                 sensed=dict(outcome.sensed), raw=dict(outcome.raw), notes=notes)
            if outcome.failure is not None:
                record.decision_s = time.perf_counter() - t
                self._record(record)
                what = ", ".join(a.text for a in sent) or "the idle step"
                return self._end(OnlineStatus.CONTRADICTED, f"{what} failed at cycle {cycle - 1}: {outcome.failure}",
                                 unexplained=[f"{what} failed: {outcome.failure}"])
            # estimate
            est = model.estimate(state, acts, events, outcome.sensed)
            if not est.unique:
                record.decision_s = time.perf_counter() - t
                return self._unknown(record, est, f"cycle {cycle}")
            new: State = est.state  # type: ignore[assignment]
            record.state = new
            record.inferred = [gc.text for gc in est.inferred]
            # monitor
            if predicted is not None and new == predicted:
                plan, reason = plan.rest(), None
                if plan.length == 0 and plan.partial:   # part of the goal reached: plan the rest
                    plan, reason = None, Replan("partial")
            elif predicted is None and new == state:
                reason = None               # an idle step that changed nothing
            else:
                differ = (predicted or state).diff(new)
                reason = Replan("event" if events else "diverged", differ, [e.text for e in events])
                plan = None
            state = new

    # ------------------------------------------------------------------ pieces
    def _events(self, outcome: Outcome, cycle: int) -> tuple[list[GroundConst], list[str]]:
        """The executor's events and every source's, checked against the domain's events."""
        events = list(outcome.events)
        notes: list[str] = []
        observed = self.model.roles.observed
        for source in self.sources:
            notes.extend(source.notes())
            for text in self._early.pop(source, []) + source.poll(cycle):
                gc = self.model.by_text.get("".join(text.split()))
                if gc is None or gc not in observed:
                    notes.append(f"ignored {text!r}: not an observed event of the domain")
                    continue
                if gc not in events:
                    events.append(gc)
        return events, notes

    def _idle(self, cycle: int) -> Outcome | None:
        """An idle step: wait until an event arrives. None when none ever will (every event
        source has finished), or on :meth:`stop`. Without event sources only the executor's
        robot can bring one, and the loop waits for it until :meth:`stop`."""
        while not self._stop.is_set():
            outcome = self.executor.poll()
            if outcome.events or outcome.failure or any(s.waiting(cycle + 1) for s in self.sources):
                return outcome
            live = [s for s in self.sources if not s.finished()]
            if self.sources and not live:
                return None
            if live:
                live[0].wait(self.idle_poll_s)
            else:
                self.clock.sleep(self.idle_poll_s)
            for source in live:
                ready = source.ready(cycle + 1)
                if ready:
                    return outcome
                if ready is None:
                    events = source.poll(cycle + 1)
                    if events:
                        self._early[source] = events
                        return outcome
        return None

    def _unknown(self, record: CycleRecord, est: Estimate, where: str) -> RunResult:
        self._record(record)
        if est.status is EstimateStatus.NONE:
            what = "; ".join(est.unexplained) or "the executed actions"
            return self._end(OnlineStatus.CONTRADICTED, f"the model cannot explain what was observed at {where}: "
                             f"{what}", unexplained=est.unexplained)
        opened = "; ".join(f"{gc.text} in {{{', '.join(_value_text(v) for v in vs)}}}" for gc, vs in est.open.items())
        return self._end(OnlineStatus.AMBIGUOUS, f"the state at {where} is not known: {opened}", open=est.open)

    def _record(self, record: CycleRecord) -> None:
        self.records.append(record)
        if self.keep_records is not None and len(self.records) > 2 * self.keep_records:
            gone, self.records = self.records[:-self.keep_records], self.records[-self.keep_records:]
            self._dropped += len(gone)
            self._dropped_replans += sum(1 for r in gone if r.replanned is not None and r.replanned.reason != "start")
        for obs in self.observers:
            obs.on_cycle(record)

    def _end(self, status: OnlineStatus, message: str, unexplained: list[str] | None = None,
             open: Mapping[GroundConst, list[object]] | None = None) -> RunResult:
        return RunResult(status, message, list(self.records), self.state, list(unexplained or []), dict(open or {}),
                         dropped=self._dropped, dropped_replans=self._dropped_replans)


def _value_text(v: object) -> str:
    return render_value(v)  # type: ignore[arg-type]
