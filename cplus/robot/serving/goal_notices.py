"""The state of a :class:`~cplus.robot.serving.goals.GoalBoard` and how it tells its watchers:
status changes and feedback are queued under the board's lock and delivered by one
dispatcher thread, in order, outside it; and what the log remembers of the goals.

The base class of the board, split from it because delivering notices is a concern of its
own (a thread, an outbox, the failures of watchers) beside taking requests and following
the loop.
"""
from __future__ import annotations

import copy
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Hashable

from cplus.robot.online import State
from cplus.robot.serving.goal_types import FINAL, Goal, GoalRecorder, GoalStatus, GoalWatcher, Limits
from cplus.robot.serving.vocabulary import RequestVocabulary

_log = logging.getLogger("cplus.robot.serving.goals")
"""A watcher's failure is logged here: the library prints nothing (the command shows warnings)."""


class _GoalNotices:
    """The board's state (see :class:`~cplus.robot.serving.goals.GoalBoard` for the arguments),
    its notices to watchers, and what it remembers for the log."""

    def __init__(self, vocabulary: RequestVocabulary, clock: Callable[[], float] = time.perf_counter,
                 limits: Limits | None = None, first_id: int = 1) -> None:
        self.vocabulary = vocabulary
        self.clock = clock
        self.limits = limits or Limits()
        self._lock = threading.Lock()
        self._arrived = threading.Condition(self._lock)    # the loop waits here while idle
        self._news = threading.Condition(self._lock)       # the dispatcher waits here
        self.goals: dict[int, Goal] = {}           # every goal open, and the last final ones
        self.first_id = first_id                   # ids before it are an earlier run's (a log continued)
        self._next_id = first_id
        self.recorder: GoalRecorder | None = None  # the log: told of each change under the lock
        self.on_preempt: Callable[[], object] | None = None   # an active goal was cancelled (--preempt stop)
        self._queue: deque[Goal] = deque()         # pending, oldest first
        self._cancels: list[Goal] = []             # active goals whose cancellation is not delivered
        self._holder: dict[object, Goal] = {}      # slot -> goal in flight
        self._next_slot = 0
        self._open = 0                             # goals not final
        self._by_client: dict[Hashable, int] = {}  # client -> its goals not final
        self._finals: deque[int] = deque()         # final goals still remembered, oldest first
        self._watchers: tuple[GoalWatcher, ...] = ()
        self._scripts: list[Callable[[int], None]] = []
        self._script_left: list[Callable[[], bool]] = []
        self._live = 0
        self._seen = -1                            # the last cycle whose state was looked at
        self._predicted: State | None = None       # the state the current plan predicts next
        self._closing = ""
        self._woken = False
        self._outbox: deque[tuple] = deque()       # (kind, goal copy, status or feedback, audience)
        self._delivering = False
        self._dispatcher: threading.Thread | None = None
        self._stopped = False                      # the dispatcher was told to end
        self.dropped_feedback = 0                  # feedback left out because the outbox was full

    # ------------------------------------------------------------------ the log
    def remembered(self, timeout: float = -1) -> list[dict]:
        """Every goal still remembered (those open, and the last final ones), for the end record."""
        if not self._lock.acquire(timeout=timeout):
            return []
        try:
            return [g.to_json() for g in self.goals.values()]
        finally:
            self._lock.release()

    def summary(self, timeout: float = -1) -> dict[str, int]:
        """How many goals ended in each status (and are still open), of those remembered, and
        how many were forgotten (``"forgotten"``)."""
        if not self._lock.acquire(timeout=timeout):
            return {}
        try:
            counts: dict[str, int] = {}
            for g in self.goals.values():
                counts[g.status.value] = counts.get(g.status.value, 0) + 1
            forgotten = self._next_id - 1 - len(self.goals)
            if forgotten:
                counts["forgotten"] = forgotten
            return counts
        finally:
            self._lock.release()

    # ------------------------------------------------------------------ notifications
    def _set(self, goal: Goal, status: GoalStatus, reason: str = "", tell_own: bool = True) -> None:
        """Change a goal's status (under the lock) and queue the news for its watchers (not for
        its own one when ``tell_own`` is False: the channel that made it acknowledges it)."""
        goal.status = status
        if reason:
            goal.reason = reason
        if self.recorder is not None:              # before anyone can hear of it
            self.recorder.goal_changed(goal)
        if status in FINAL:
            if status is not GoalStatus.REJECTED:  # a rejected goal never counted
                self._open -= 1
                if goal.client is not None:
                    left = self._by_client.get(goal.client, 1) - 1
                    if left:
                        self._by_client[goal.client] = left
                    else:
                        self._by_client.pop(goal.client, None)
            self._finals.append(goal.id)
            while len(self._finals) > self.limits.kept_final:
                self.goals.pop(self._finals.popleft(), None)
        self._post("status", goal, status, tell_own)

    def _post(self, kind: str, goal: Goal, what: object, tell_own: bool = True) -> None:
        """Queue a notification (under the lock), with a copy of the goal as it is now and its
        audience; nothing is queued for a goal nobody watches."""
        audience = (goal.watcher, *self._watchers) if goal.watcher is not None and tell_own else self._watchers
        if not audience or self._stopped:
            return
        if kind == "feedback" and len(self._outbox) >= self.limits.outbox:
            self.dropped_feedback += 1
            return
        self._outbox.append((kind, copy.copy(goal), what, audience))
        self._news.notify()

    def _started(self) -> None:
        """Start the dispatcher when there is news and it is not running (called with no lock
        held: starting a thread is not done under the board's lock)."""
        if self._dispatcher is not None or not self._outbox or self._stopped:
            return
        with self._lock:
            if self._dispatcher is not None or self._stopped:
                return
            thread = self._dispatcher = threading.Thread(target=self._dispatch, name="cplus-serve-goals",
                                                         daemon=True)
        try:
            thread.start()
        except RuntimeError:                      # no thread to be had now: the next change tries again
            with self._lock:
                self._dispatcher = None

    def _dispatch(self) -> None:
        """The dispatcher: deliver the outbox in order, outside the lock, until told to end."""
        while True:
            with self._lock:
                self._delivering = False
                self._news.notify_all()          # drain() waits for an empty outbox
                while not self._outbox and not self._stopped:
                    self._news.wait()
                if not self._outbox:
                    return
                batch = list(self._outbox)
                self._outbox.clear()
                self._delivering = True
                recorder = self.recorder
            if recorder is not None and any(kind == "status" and what in FINAL for kind, _, what, _ in batch):
                recorder.sync()                    # a result is told once it is durable
            for kind, goal, what, audience in batch:
                for w in audience:
                    try:
                        if kind == "status":
                            w.status(goal, what)
                        else:
                            w.feedback(goal, what)
                    except Exception:  # noqa: BLE001 - one watcher's bug must not silence the others
                        _log.exception("a goal watcher (%s) failed; the others go on", type(w).__name__)

    def drain(self, timeout: float) -> bool:
        """Wait until every notification queued so far has been delivered (at most ``timeout``
        seconds); False when some are still waiting."""
        self._started()
        deadline = time.monotonic() + timeout
        with self._lock:
            while self._outbox or self._delivering:
                left = deadline - time.monotonic()
                if left <= 0 or self._dispatcher is None:
                    return False
                self._news.wait(left)
        return True

    def close(self, timeout: float = 1.0) -> None:
        """Deliver what is queued (at most ``timeout`` seconds), then end the dispatcher; later
        changes are not told to anyone."""
        self.drain(timeout)
        with self._lock:
            self._stopped = True
            self._outbox.clear()
            self._news.notify_all()
            thread = self._dispatcher
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)
