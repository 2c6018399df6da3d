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

**Threads and locks.** Clients submit from their channels' threads (the socket's I/O thread,
actionlib's callbacks, the loop's thread for a script), the loop polls and observes from its
own, and watchers are told from the board's *dispatcher* thread. There is one lock,
``GoalBoard._lock``: it is held only while the board's own bookkeeping changes, never while
calling a watcher, a channel, actionlib or a socket. The one thing called under it is the
:class:`GoalRecorder` (the log), which writes the change before anyone can hear of it, takes
only its own lock (a leaf) and never calls the board; the dispatcher has it ``sync`` (fsync)
with no lock held before it delivers a final status. A change
queues a notification (with a copy of the goal as it is then) in the board's outbox; the
dispatcher delivers them in order with no lock held, so a watcher may call back into the board,
and a component whose own lock is held while it calls the board (actionlib holds its
``action_server.lock`` in its goal and cancel callbacks) never waits for the board's watchers.
The lock order of the server is therefore: a channel's own lock (actionlib's) → ``_lock`` →
the log's lock; nothing else is taken under ``_lock``. A watcher must not block: a slow one delays every other's
news (the socket queues its lines per client, and never waits for a client).

**Bounds.** Nothing grows with time or with what clients send: at most
:attr:`Limits.open_goals` goals are open (pending or in flight) at once, at most
:attr:`Limits.client_goals` of them for one client (a socket connection, a ROS caller); a
request beyond either is rejected at once with the reason, so a client that floods the server
is answered, and another client's request is taken (acknowledged) at once and waits behind
a bounded number of goals. Final goals are remembered for status queries up to
:attr:`Limits.kept_final` (the log has every result), and the outbox keeps at most
:attr:`Limits.outbox` notifications, beyond which feedback (not a status) is dropped.

The board is in three modules: the goal's types (:mod:`cplus.robot.serving.goal_types`), the
board's state and its notices to watchers (:mod:`cplus.robot.serving.goal_notices`, its base
class) and, here, the requests, the events for the loop and what the board sees of the loop.
Import the names from this module.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Hashable

from cplus.robot.online import CycleRecord, EventSource, Observer, RunResult
from cplus.robot.serving.goal_notices import _GoalNotices
from cplus.robot.serving.goal_types import FINAL, Feedback, Goal, GoalRecorder, GoalStatus, GoalWatcher, Limits
from cplus.robot.serving.standing import GoalLiteral
from cplus.robot.serving.vocabulary import MAX_REQUEST, Rejected

__all__ = ["FINAL", "Feedback", "Goal", "GoalBoard", "GoalRecorder", "GoalStatus", "GoalWatcher", "Limits"]


class GoalBoard(_GoalNotices, EventSource, Observer):
    """The goals of one server run: what clients asked for, as events for the loop.

    Args:
        vocabulary: the domain's requests (``requests.toml``).
        clock: a function returning seconds (arrival times, reaction latencies).
        limits: how many goals may be open, per client and in all, and what is remembered.
    """

    # ------------------------------------------------------------------ clients
    def watch(self, watcher: GoalWatcher) -> None:
        """Tell ``watcher`` about every goal (the log, progress lines)."""
        with self._lock:
            self._watchers = (*self._watchers, watcher)

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
        so a scripted run is deterministic); ``left()`` says whether anything is still to come
        (called under the board's lock: it must only look at the script's own entries)."""
        with self._lock:
            self._scripts.append(due)
            self._script_left.append(left)

    def submit(self, request: str, watcher: GoalWatcher | None = None, origin: str = "",
               client: Hashable | None = None) -> Goal:
        """A new goal: pending, or rejected with the reason when the domain cannot express
        the request, a limit is reached (:class:`Limits`) or the server is stopping.
        ``client`` is whose share of open goals it takes (None: only the limit for every
        client together). Thread-safe; never blocks on anything but the board's own lock (the
        request is read before it is taken)."""
        return self._make(request, watcher, origin, client, True)[0]

    def request(self, request: str, watcher: GoalWatcher | None = None, origin: str = "",
                client: Hashable | None = None) -> tuple[Goal, dict]:
        """:meth:`submit` for a channel that acknowledges the request itself: the goal, and the
        goal as JSON as it was made (pending or rejected), which the channel answers with at
        once (the loop may already be changing the goal). ``watcher`` hears the goal's later
        news, not its first status (that is the acknowledgement): so that the dispatcher has
        nothing to tell the client before the channel's answer is out."""
        return self._make(request, watcher, origin, client, False)

    def _make(self, request: str, watcher: GoalWatcher | None, origin: str, client: Hashable | None,
              tell_first: bool) -> tuple[Goal, dict]:
        text = request if isinstance(request, str) else repr(request)[:MAX_REQUEST + 1]
        try:
            parsed: tuple | None = self.vocabulary.parse(text)
            reason = ""
        except Rejected as exc:
            parsed, reason = None, exc.reason
        if len(text) > MAX_REQUEST:               # kept (and logged) cut: a ROS string has no length limit
            text = f"{text[:80]}... ({len(text)} characters)"
        now = self.clock()
        with self._lock:
            goal = Goal(self._next_id, text, GoalStatus.PENDING, origin, received=now, watcher=watcher,
                        client=client, parsed=parsed)
            self._next_id += 1
            self.goals[goal.id] = goal
            mine = self._by_client.get(client, 0) if client is not None else 0
            if self._closing:
                reason = self._closing
            elif not reason and self._open >= self.limits.open_goals:
                reason = (f"the server has {self._open} goals open, its limit: send it again when one has "
                          "ended")
            elif not reason and client is not None and mine >= self.limits.client_goals:
                reason = (f"this client has {mine} goals open (at most {self.limits.client_goals} per client): "
                          "send it again when one has ended")
            if reason:
                self._set(goal, GoalStatus.REJECTED, reason, tell_first)
            else:
                self._open += 1
                if client is not None:
                    self._by_client[client] = mine + 1
                self._queue.append(goal)
                self._set(goal, GoalStatus.PENDING, tell_own=tell_first)
                self._arrived.notify_all()
            made = goal.to_json()
        self._started()
        return goal, made

    def cancel(self, goal_id: int, origin: str = "") -> Goal:
        """Cancel a goal: a pending one is recalled at once; an active one is preempting until
        the cancellation's events have done their work (and :attr:`on_preempt` is called, with
        no lock held: ``--preempt stop`` cuts the robot's step short). A final goal stays as it
        is. Raises KeyError for an unknown (or forgotten) id. Thread-safe."""
        preempted = False
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
                preempted = True
        self._started()
        if preempted and self.on_preempt is not None:
            self.on_preempt()
        return goal

    def get(self, goal_id: int) -> Goal | None:
        with self._lock:
            return self.goals.get(goal_id)

    def describe(self, goal_id: int) -> dict | None:
        """The goal as JSON (as it is now, read under the lock), None when unknown or forgotten."""
        with self._lock:
            goal = self.goals.get(goal_id)
            return None if goal is None else goal.to_json()

    def forgotten(self, goal_id: int) -> bool:
        """True for a goal that existed and ended so long ago that it is no longer remembered
        (in this run, or in an earlier run of a log this one continues)."""
        with self._lock:
            return 0 < goal_id < self._next_id and goal_id not in self.goals

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
                goal = self._queue.popleft()
                goal.slot = slot
                assert goal.parsed is not None
                goal.events = self.vocabulary.ground(goal.parsed, slot)
                goal.cycle = cycle
                self._holder[slot] = goal
                events.extend(goal.events)
                self._set(goal, GoalStatus.ACTIVE)
            told = bool(self._outbox)
        self._started()
        if told:
            # let the dispatcher tell the clients now: the re-plan that follows holds Python's
            # GIL inside SAT calls, and the news would wait for it (a ROS goal's ACTIVE, 5 ms)
            time.sleep(0)
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

    def ready(self, cycle: int) -> bool:
        """Whether :meth:`poll` would hand the loop something now (a request with a free slot,
        a cancellation), looked at without taking it: the loop's idle step ends on it and the
        transition's one poll takes it, so that a request and a cancellation of its goal never
        share a transition (a cancellation that comes before the poll recalls the request)."""
        with self._lock:
            return self._has_work()

    def _has_work(self) -> bool:
        """Under the lock: a cancellation to deliver, or a request that a slot is free for."""
        if any(not g.final for g in self._cancels):
            return True
        return bool(self._queue) and any(slot not in self._holder for slot in self.vocabulary.slots)

    def wait(self, timeout: float) -> None:
        with self._lock:
            if not self._has_work() and not self._woken:
                self._arrived.wait(timeout)
            self._woken = False

    def wake(self) -> None:
        """End the loop's idle wait now (the server is stopping). Thread-safe, and bounded: when
        the lock cannot be had at once, the idle wait ends by its own timeout anyway."""
        if not self._lock.acquire(timeout=0.2):
            return
        try:
            self._woken = True
            self._arrived.notify_all()
        finally:
            self._lock.release()

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
            for goal in sorted(self._holder.values(), key=lambda g: g.id):
                if not goal.final:
                    self._post("feedback", goal, fb)
        self._started()

    def on_end(self, result: RunResult) -> None:
        why = result.message if result.status.value == "stopped" else f"{result.status.value}: {result.message}"
        self.abort_all(f"the server stopped ({why})")

    def abort_all(self, reason: str, timeout: float = -1) -> bool:
        """Abort every goal not final with ``reason``, and reject every later request with it
        (the run ended). ``timeout``: how long to wait for the lock (the watchdog's emergency
        end; -1: as long as it takes). False when the lock could not be had."""
        if not self._lock.acquire(timeout=timeout):
            return False
        try:
            self._closing = reason
            for goal in list(self.goals.values()):
                if not goal.final:
                    self._set(goal, GoalStatus.ABORTED, reason)
            self._queue.clear()
            self._cancels = []
            self._holder.clear()
        finally:
            self._lock.release()
        self._started()
        return True

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
        self._started()

