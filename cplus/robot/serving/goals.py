"""Goals of a server: requests and cancellations from clients, as events of the online loop.

A :class:`GoalBoard` sits between the request channels (a script, a socket, ROS actionlib)
and the online loop (:mod:`cplus.robot.online.loop`). Clients :meth:`~GoalBoard.submit` requests
in the domain's terms and :meth:`~GoalBoard.cancel` goals by id, from any thread. The loop
polls the board as an :class:`~cplus.robot.online.loop.EventSource`: each request becomes the
events its vocabulary says (:mod:`cplus.robot.serving.vocabulary`), with a free *slot* of the domain
(a package), and each cancellation the cancellation's events. The board also watches the
loop as an :class:`~cplus.robot.online.loop.Observer`: a goal is done when the fluent that says
it is open is false in the estimated state, and every watcher of the goal hears its status,
the feedback of each cycle (the actions executed and the plan that remains), and its result.

Goals have the states of ROS actionlib::

    pending ──> active ──> succeeded            (the goal's fluent is closed)
       │          │
       │          └──> preempting ──> preempted (cancelled; a package on board went back)
       │                          └─> succeeded (the robot finished it before the cancellation
       │                                         took effect)
       ├──> recalled        (cancelled before the loop took it)
       └──> rejected        (the domain cannot express the request)
    any state but a final one ──> aborted (the run ended: stopped, no plan, robot lost)

A request waits as *pending* until the next cycle boundary, and longer when every slot is
taken (goals are taken first come, first served). Its events belong to the transition that
ends at that cycle, so the plan chosen at that cycle already serves it. Ids are 1, 2, ... in
the order requests arrive; slots are given round-robin among the free ones, so that a slot
freed by one goal is not at once reused by the next (``pickup(2)`` for the second request,
as in ROSoClingo's Table I).
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import StrEnum

from cplus.robot.online import CycleRecord, EventSource, Observer, RunResult, State
from cplus.robot.serving.standing import GoalLiteral
from cplus.robot.serving.vocabulary import Rejected, RequestVocabulary
from cplus.signature import render_value

__all__ = ["FINAL", "Feedback", "Goal", "GoalBoard", "GoalStatus", "GoalWatcher"]


class GoalStatus(StrEnum):
    """The states of an actionlib goal (``actionlib_msgs/GoalStatus``) that a goal here can be in."""

    PENDING = "pending"          # received, not yet taken by the loop
    ACTIVE = "active"            # its events are in the loop's history; the robot works on it
    PREEMPTING = "preempting"    # cancelled while active; the robot undoes what it must
    SUCCEEDED = "succeeded"
    PREEMPTED = "preempted"
    RECALLED = "recalled"        # cancelled while pending
    ABORTED = "aborted"          # the run ended before the goal did
    REJECTED = "rejected"        # the domain cannot express the request


FINAL = frozenset({GoalStatus.SUCCEEDED, GoalStatus.PREEMPTED, GoalStatus.RECALLED, GoalStatus.ABORTED,
                   GoalStatus.REJECTED})


@dataclass(frozen=True)
class Feedback:
    """One cycle of the robot's work, told to every goal in progress: the actions executed at
    ``cycle`` and the plan that remains after them (one list of actions per step)."""

    cycle: int
    executed: list[str]
    plan: list[list[str]]

    def to_json(self) -> dict:
        return {"cycle": self.cycle, "executed": list(self.executed), "plan": [list(s) for s in self.plan]}


class GoalWatcher:
    """Told about one goal (or every goal, :meth:`GoalBoard.watch`). Called from the loop's
    thread or a client's; must not block. No-ops unless overridden."""

    def status(self, goal: Goal, status: GoalStatus) -> None:
        """The goal was created or changed to ``status`` (in order; a final status is its
        result, and ``goal.reason`` says why when it was rejected or aborted)."""

    def feedback(self, goal: Goal, feedback: Feedback) -> None:
        """A cycle of work happened while the goal was in progress."""


@dataclass
class Goal:
    """One request and what became of it. ``slot`` is the domain object it occupies while in
    flight; ``cycle`` the cycle its events took effect; ``reason`` why it was rejected or
    aborted; ``reaction_s`` the time from its arrival to the first action sent after the loop
    took it (the server's reaction latency)."""

    id: int
    request: str
    status: GoalStatus
    origin: str = ""
    reason: str = ""
    slot: object | None = None
    events: list[str] = field(default_factory=list)
    cycle: int | None = None
    cancel_cycle: int | None = None
    done_cycle: int | None = None
    received: float = 0.0
    reaction_s: float | None = None
    watcher: GoalWatcher | None = field(default=None, repr=False)
    cancel_requested: bool = False

    @property
    def final(self) -> bool:
        return self.status in FINAL

    def to_json(self) -> dict:
        """The goal in the log and on the socket: id, request, status, and what applies of
        slot, cycle, done_cycle, reason, reaction_ms."""
        out: dict[str, object] = {"id": self.id, "request": self.request, "status": self.status.value}
        if self.slot is not None:
            out["slot"] = self.slot if isinstance(self.slot, int) else render_value(self.slot)  # type: ignore[arg-type]
        if self.cycle is not None:
            out["cycle"] = self.cycle
        if self.done_cycle is not None:
            out["done_cycle"] = self.done_cycle
        if self.reason:
            out["reason"] = self.reason
        if self.reaction_s is not None:
            out["reaction_ms"] = round(self.reaction_s * 1000, 3)
        return out


class GoalBoard(EventSource, Observer):
    """The goals of one server run: what clients asked for, as events for the loop.

    Args:
        vocabulary: the domain's requests (``requests.toml``).
        clock: a function returning seconds (arrival times, reaction latencies).
    """

    def __init__(self, vocabulary: RequestVocabulary, clock: Callable[[], float] = time.perf_counter) -> None:
        self.vocabulary = vocabulary
        self.clock = clock
        self._lock = threading.RLock()
        self._arrived = threading.Condition(self._lock)
        self.goals: dict[int, Goal] = {}
        self._queue: list[Goal] = []               # pending, oldest first
        self._cancels: list[Goal] = []             # active goals whose cancellation is not delivered
        self._holder: dict[object, Goal] = {}      # slot -> goal in flight
        self._next_slot = 0
        self._watchers: list[GoalWatcher] = []
        self._changed: dict[int, Goal] = {}        # since the last log line
        self._scripts: list[Callable[[int], None]] = []
        self._script_left: list[Callable[[], bool]] = []
        self._live = 0
        self._seen = -1                            # the last cycle whose state was looked at
        self._predicted: State | None = None       # the state the current plan predicts next
        self._closing = ""
        self._news: list[tuple[Goal, GoalStatus]] = []
        self._dispatch = threading.RLock()        # watchers hear every goal's changes in order

    # ------------------------------------------------------------------ clients
    def watch(self, watcher: GoalWatcher) -> None:
        """Tell ``watcher`` about every goal (the log, progress lines)."""
        with self._lock:
            self._watchers.append(watcher)

    def open_channel(self) -> None:
        """A live channel (a socket, ROS) is open: the board never finishes while it is."""
        with self._lock:
            self._live += 1

    def close_channel(self) -> None:
        with self._lock:
            self._live -= 1
            self._arrived.notify_all()

    def add_script(self, due: Callable[[int], None], left: Callable[[], bool]) -> None:
        """A script: ``due(cycle)`` submits what it has for that cycle (from the loop's thread,
        so a scripted run is deterministic); ``left()`` says whether anything is still to come."""
        with self._lock:
            self._scripts.append(due)
            self._script_left.append(left)

    def submit(self, request: str, watcher: GoalWatcher | None = None, origin: str = "") -> Goal:
        """A new goal: pending, or rejected with the reason when the domain cannot express
        the request (or the server is stopping). Thread-safe."""
        with self._lock:
            goal = Goal(len(self.goals) + 1, request if isinstance(request, str) else repr(request),
                        GoalStatus.PENDING, origin, received=self.clock(), watcher=watcher)
            self.goals[goal.id] = goal
            if self._closing:
                self._set(goal, GoalStatus.REJECTED, self._closing)
            else:
                try:
                    self.vocabulary.parse(request)
                except Rejected as exc:
                    self._set(goal, GoalStatus.REJECTED, exc.reason)
                else:
                    self._queue.append(goal)
                    self._set(goal, GoalStatus.PENDING)
                    self._arrived.notify_all()
        self._flush()
        return goal

    def cancel(self, goal_id: int, origin: str = "") -> Goal:
        """Cancel a goal: a pending one is recalled at once; an active one is preempting until
        the cancellation's events have done their work. A final goal stays as it is.
        Raises KeyError for an unknown id. Thread-safe."""
        with self._lock:
            goal = self.goals[goal_id]
            if goal.status is GoalStatus.PENDING:
                self._queue.remove(goal)
                self._set(goal, GoalStatus.RECALLED, f"cancelled{' by ' + origin if origin else ''} before it started")
            elif goal.status is GoalStatus.ACTIVE:
                goal.cancel_requested = True
                self._cancels.append(goal)
                self._set(goal, GoalStatus.PREEMPTING)
                self._arrived.notify_all()
        self._flush()
        return goal

    def get(self, goal_id: int) -> Goal | None:
        with self._lock:
            return self.goals.get(goal_id)

    # ------------------------------------------------------------------ the planner's agenda
    def agenda(self) -> list[GoalLiteral]:
        """The goals in flight, oldest first, each as the literal that says it is done."""
        with self._lock:
            live = sorted((g for g in self._holder.values()), key=lambda g: g.id)
            return [GoalLiteral(self.vocabulary.open_fluent(g.slot), "false", g.id) for g in live]

    # ------------------------------------------------------------------ EventSource
    def poll(self, cycle: int) -> list[str]:
        for due in list(self._scripts):
            due(cycle)
        events: list[str] = []
        with self._lock:
            for goal in self._cancels:
                if not goal.final:                # done meanwhile: its slot may be another's now
                    events.extend(self.vocabulary.cancel_events(goal.slot))
                    goal.cancel_cycle = cycle
            self._cancels = []
            while self._queue:
                slot = self._free_slot()
                if slot is None:
                    break
                goal = self._queue.pop(0)
                goal.slot = slot
                goal.events = self.vocabulary.events(goal.request, slot)
                goal.cycle = cycle
                self._holder[slot] = goal
                events.extend(goal.events)
                self._set(goal, GoalStatus.ACTIVE)
        self._flush()
        return events

    def _free_slot(self) -> object | None:
        slots = self.vocabulary.slots
        for i in range(len(slots)):
            slot = slots[(self._next_slot + i) % len(slots)]
            if slot not in self._holder:
                self._next_slot = (self._next_slot + i + 1) % len(slots)
                return slot
        return None

    def waiting(self, cycle: int) -> bool:
        with self._lock:
            return any(left() for left in self._script_left)

    def wait(self, timeout: float) -> None:
        with self._lock:
            if not self._queue and not self._cancels:
                self._arrived.wait(timeout)

    def finished(self) -> bool:
        with self._lock:
            return (not self._live and not any(left() for left in self._script_left) and not self._queue
                    and not self._cancels)

    # ------------------------------------------------------------------ Observer
    def on_act(self, record: CycleRecord) -> None:
        self._look(record)
        now = self.clock()
        with self._lock:
            for goal in self._holder.values():
                if goal.reaction_s is None and goal.cycle is not None and goal.cycle <= record.cycle:
                    goal.reaction_s = now - goal.received
            self._predicted = record.plan.states[1] if record.plan is not None and record.plan.length else None

    def on_cycle(self, record: CycleRecord) -> None:
        self._look(record)
        if not record.executed:
            return
        plan = record.plan.texts()[1:] if record.plan is not None else []
        fb = Feedback(record.cycle, [a.text for a in record.executed], plan)
        with self._lock:
            busy = [g for g in self._holder.values() if not g.final]
        for goal in sorted(busy, key=lambda g: g.id):
            for w in self._audience(goal):
                w.feedback(goal, fb)

    def on_end(self, result: RunResult) -> None:
        with self._lock:
            self._closing = f"the server stopped ({result.status.value}: {result.message})"
            for goal in list(self.goals.values()):
                if not goal.final:
                    self._set(goal, GoalStatus.ABORTED, self._closing)
            self._queue, self._cancels = [], []
            self._holder.clear()
        self._flush()

    def _look(self, record: CycleRecord) -> None:
        """Close the goals whose fluent is false in the state of ``record`` (once per cycle)."""
        state = record.state
        with self._lock:
            if record.cycle <= self._seen or state is None:
                return
            self._seen = record.cycle
            for slot, goal in list(self._holder.items()):
                if goal.cycle is None or goal.cycle > record.cycle:
                    continue
                if state.get(self.vocabulary.open_fluent(slot)) != "false":
                    continue
                del self._holder[slot]
                goal.done_cycle = record.cycle
                by_robot = self._predicted is not None and \
                    self._predicted.get(self.vocabulary.open_fluent(slot)) == "false"
                if goal.cancel_cycle is not None and (goal.cancel_cycle < record.cycle or not by_robot):
                    self._set(goal, GoalStatus.PREEMPTED, "cancelled")
                else:
                    self._set(goal, GoalStatus.SUCCEEDED)
        self._flush()

    # ------------------------------------------------------------------ the log
    def log_goals(self) -> list[dict]:
        """For the log's cycle line: every goal not final, and every goal that changed since
        the last line."""
        with self._lock:
            out = {g.id: g for g in self.goals.values() if not g.final}
            out.update(self._changed)
            self._changed = {}
            return [out[i].to_json() for i in sorted(out)]

    def summary(self) -> dict[str, int]:
        """How many goals ended in each status (and are still open)."""
        with self._lock:
            counts: dict[str, int] = {}
            for g in self.goals.values():
                counts[g.status.value] = counts.get(g.status.value, 0) + 1
            return counts

    # ------------------------------------------------------------------ notifications
    def _set(self, goal: Goal, status: GoalStatus, reason: str = "") -> None:
        """Change a goal's status (under the lock); watchers hear it at :meth:`_flush`."""
        goal.status = status
        if reason:
            goal.reason = reason
        self._changed[goal.id] = goal
        self._news.append((goal, status))

    def _audience(self, goal: Goal) -> Iterable[GoalWatcher]:
        return ([goal.watcher] if goal.watcher is not None else []) + list(self._watchers)

    def _flush(self) -> None:
        """Tell the watchers what changed, outside the board's lock (a watcher may call back),
        one flush at a time so that each hears a goal's changes in order."""
        with self._dispatch:
            with self._lock:
                news, self._news = self._news, []
            for goal, status in news:
                for w in self._audience(goal):
                    w.status(goal, status)

