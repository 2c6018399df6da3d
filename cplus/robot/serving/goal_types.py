"""What a server's goal is: its status (the states of ROS actionlib), the limits on open goals,
the feedback of a cycle, the interfaces of those who watch goals and record them, and
:class:`Goal` itself.

Plain types, apart from the board that moves goals through their states
(:mod:`cplus.robot.serving.goals`, which gives these names too), so that the board's parts
and the request channels can share them.
"""
from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field
from enum import StrEnum

from cplus.signature import render_value


class GoalStatus(StrEnum):
    """The states of an actionlib goal (``actionlib_msgs/GoalStatus``) that a goal here can be in."""

    PENDING = "pending"          # received, not yet taken by the loop
    ACTIVE = "active"            # its events are in the loop's history; the robot works on it
    PREEMPTING = "preempting"    # cancelled while active; the robot undoes what it must
    SUCCEEDED = "succeeded"
    PREEMPTED = "preempted"
    RECALLED = "recalled"        # cancelled while pending
    ABORTED = "aborted"          # the run ended before the goal did
    REJECTED = "rejected"        # the domain cannot express the request, or a limit was reached


FINAL = frozenset({GoalStatus.SUCCEEDED, GoalStatus.PREEMPTED, GoalStatus.RECALLED, GoalStatus.ABORTED,
                   GoalStatus.REJECTED})


@dataclass(frozen=True)
class Limits:
    """What one server takes at most, so that no client can make it grow without bound.

    Attributes:
        open_goals: goals open at once (pending, active or preempting), every client together.
        client_goals: goals open at once for one client (a socket connection, a ROS caller);
            scripts and the Python API are bounded by ``open_goals`` only.
        kept_final: final goals remembered for status queries (older ones are forgotten; the
            log has their results).
        outbox: notifications waiting for the dispatcher; beyond it feedback is dropped
            (statuses never are).
    """

    open_goals: int = 256
    client_goals: int = 32
    kept_final: int = 1000
    outbox: int = 100_000


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
    """Told about one goal (or every goal, :meth:`GoalBoard.watch`), from the board's dispatcher
    thread, in the order things happened, with a copy of the goal as it was then. Must not
    block: a slow watcher delays every other's news. No-ops unless overridden."""

    def status(self, goal: Goal, status: GoalStatus) -> None:
        """The goal was created or changed to ``status`` (in order; a final status is its
        result, and ``goal.reason`` says why when it was rejected or aborted)."""

    def feedback(self, goal: Goal, feedback: Feedback) -> None:
        """A cycle of work happened while the goal was in progress."""


class GoalRecorder:
    """Where every goal change is recorded when it happens (a server's log,
    :class:`cplus.robot.serving.serve_log.ServeLog`), before anyone can be told of it."""

    def goal_changed(self, goal: Goal) -> None:
        """``goal`` changed (called under the board's lock, in the order of the changes: write
        and flush, take no lock but the recorder's own, never call the board)."""

    def sync(self) -> None:
        """Make the changes recorded so far durable (called with no lock of the board held,
        before a final status is told to anyone)."""


@dataclass
class Goal:
    """One request and what became of it. ``slot`` is the domain object it occupies while in
    flight; ``cycle`` the cycle its events took effect; ``reason`` why it was rejected or
    aborted; ``reaction_s`` the time from its arrival to the first action sent after the loop
    took it (the server's reaction latency); ``client`` whose share of open goals it counts in."""

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
    client: Hashable | None = field(default=None, repr=False)
    parsed: tuple | None = field(default=None, repr=False)

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

