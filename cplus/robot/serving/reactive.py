"""A C+ domain served: the online loop kept running on a standing goal, fed by request channels.

ROSoClingo keeps a planner running while goal requests and cancellations arrive; here that is
the online loop of :mod:`cplus.robot.online.loop` with three parts added, and nothing else:

* a :class:`~cplus.robot.serving.goals.GoalBoard`: clients' requests and cancellations become events
  of the domain (:mod:`cplus.robot.serving.vocabulary`, ``requests.toml``), and each goal follows the
  actionlib states as the estimated state closes it;
* a :class:`~cplus.robot.serving.standing.StandingModel`: one solver for the run, the shortest plan
  within a budget, the oldest goal first beyond it;
* the channels: a script (:class:`~cplus.robot.serving.script.RequestScript`), a JSON-lines socket
  (:class:`~cplus.robot.serving.socket_channel.SocketChannel`), ROS actionlib (:mod:`cplus.robot.serving.ros_bridge`).

**Threads and the lock order.** The loop runs in the thread that calls :meth:`Server.run`;
the board's dispatcher tells watchers (:mod:`.goals`); the socket has one I/O thread
(:mod:`.socket_channel`); rospy has its own (:mod:`.ros_bridge`). Every lock of the server, and the
one order in which they may be held::

    actionlib's action_server.lock  ──>  GoalBoard._lock  ──>  the log's lock (ServeLog: a leaf)
    the loop's _act_lock                                        (a leaf: nothing under it)
    a socket client's _Client._lock                             (a leaf: nothing under it)

(the log writes each goal change under the board's lock, and never calls the board with its
own lock held: :mod:`.serve_log`)

No lock is held while calling into another component: the board queues notifications and the
dispatcher delivers them with no lock held; a watcher (a socket client, an actionlib goal
handle, progress lines) only queues or sends without blocking; the socket's I/O thread calls
the board with no lock of its own held. :meth:`Server.stop` and :meth:`Server.force_end` are
for any thread; ``cplus serve`` calls them from its watchdog (:mod:`cplus.cli.serve`), so
that SIGINT and SIGTERM end it within 2 s whatever the threads are doing.

The goal is a query of the domain whose step-0 conditions are where the robot starts and whose
``maxstep`` conditions say that nothing is pending. The run waits when nothing is to be done,
and ends when it is stopped (:meth:`Server.stop`), or when every channel has finished (a
script that has delivered everything, with every goal final), or badly, as an online run
does (no plan, the world contradicted the model, a robot lost). Goals still open then are
aborted.

Python API::

    from cplus.api import Domain
    from cplus.robot.serving.reactive import Server, ServerSettings
    from cplus.robot.serving.vocabulary import load_requests

    domain = Domain.load("domains/mailbot/mailbot.cp")
    server = Server(domain, load_requests("domains/mailbot/requests.toml", domain),
                    ServerSettings(action_time=0.5))
    goal = server.board.submit("deliver(office3,office2)")     # from any thread
    host, port = server.listen("127.0.0.1", 0)                 # JSON lines
    result = server.run()                                      # until server.stop()
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TextIO

from cplus.robot.online import (
    Executor,
    Observer,
    OnlineLoop,
    OnlineStatus,
    Roles,
    RunResult,
    SimulatedExecutor,
    user_actions,
)
from cplus.robot.serving.goals import Goal, GoalBoard, Limits
from cplus.robot.serving.script import RequestScript
from cplus.robot.serving.serve_log import LogHistory, ServeLog
from cplus.robot.serving.socket_channel import SocketChannel, SocketLimits
from cplus.robot.serving.standing import DEFAULT_BUDGET, StandingModel
from cplus.robot.serving.vocabulary import RequestsError, RequestVocabulary
from cplus.sat.solver import DEFAULT_SOLVER
from nxt_link.wire.clock import MONOTONIC, Clock, MonotonicClock

__all__ = ["Server", "ServerSettings", "serve_roles"]


def serve_roles(domain, vocabulary: RequestVocabulary, binding=None) -> Roles:
    """Which actions the robot does: with a binding file, what it says (the request events
    must be events from source ``input`` there); without one, every action but the events
    of requests and cancellations."""
    events = vocabulary.event_constants()
    if binding is None:
        return Roles(frozenset(gc for gc in user_actions(domain) if gc not in events), frozenset(events))
    roles = binding.roles()
    for gc in sorted(events, key=lambda g: g.id):
        e = binding.events.get(gc)
        if e is None or e.source != "input":
            where = e.location if e is not None else None
            raise RequestsError(f"{gc.text} is an event of the requests in {vocabulary.path}, so {binding.path} must "
                                f"bind it with source = \"input\" ([events.{gc.decl.name}])", where)
    return roles


class _StopClock:
    """The server's clock: the settings' clock, except that in real time a sleep ends when the
    server is stopped (so that a simulated robot's long action does not delay a stop)."""

    def __init__(self, inner: Clock, stopping: threading.Event) -> None:
        self.inner = inner
        self.stopping = stopping
        self.real = isinstance(inner, MonotonicClock)

    def now(self) -> float:
        return self.inner.now()

    def sleep(self, seconds: float) -> None:
        if self.real:
            self.stopping.wait(max(seconds, 0.0))
        else:
            self.inner.sleep(seconds)


@dataclass(frozen=True)
class ServerSettings:
    """How a server plans and runs, apart from what it serves and on which robot.

    Attributes:
        goal: the query label of the standing goal (None: the domain's first query).
        budget: unit propagations for the shortest plan per re-plan (None: always the shortest).
        horizon: steps the planner encodes when the server starts (more are added when a plan
            needs them; None: 20).
        max_horizon: the longest plan when the goal's maxstep range is open (None: the loop's default).
        solver: the SAT solver (None: the default one).
        action_time: seconds each action of the simulated robot takes (when no executor is given).
        clock: the clock of the loop and the simulated robot (a ``VirtualClock`` in tests).
        idle_poll_s: how long an idle step waits between two polls of the channels.
        limits: how many goals may be open, per client and in all (:class:`Limits`).
        socket: what the socket takes from its clients (:class:`SocketLimits`).
        keep_records: cycle records kept in memory (the log has them all).
        first_goal_id: the first goal's id (one above the last of the log a run continues).
        preempt: what a cancellation of an active goal does to the robot's step under way:
            ``"finish"`` lets it end (the step's actions are done, then the cancellation's
            events take effect); ``"stop"`` cuts it short (the executor stops its actions
            part-way where it can: motors to 0, the state estimated from what was measured,
            and the loop plans on from there).
    """

    goal: str | None = None
    budget: int | None = DEFAULT_BUDGET
    horizon: int | None = None
    max_horizon: int | None = None
    solver: str | None = None
    action_time: float = 0.0
    clock: Clock = MONOTONIC
    idle_poll_s: float = 0.05
    limits: Limits = Limits()
    socket: SocketLimits = SocketLimits()
    keep_records: int = 1000
    first_goal_id: int = 1
    preempt: str = "finish"


class Server:
    """A domain served to clients.

    Args:
        domain: the C+ domain (:class:`cplus.api.Domain`).
        vocabulary: its requests (:func:`~cplus.robot.serving.vocabulary.load_requests`).
        settings: the goal, the planner's budget and horizons, the simulated robot's timing,
            the limits (:class:`ServerSettings`; one object, so that a new setting is one
            field, not one more argument in every caller).
        binding: a ``robot.toml`` (:class:`~cplus.robot.online.binding.RobotBinding`), for the roles.
        executor: the robot, or a function that makes it from the server's model (default: a
            simulated robot whose actions take ``settings.action_time`` seconds).
        observers: more observers of the loop (progress lines, the log).

    Threads: the loop runs in the thread that calls :meth:`run`; the board's dispatcher tells
    watchers (:mod:`.goals`); each channel has its own (the socket's I/O thread, rospy's).
    Every one of them is stopped or ends with the run; :meth:`stop` and :meth:`force_end` may
    be called from any thread.
    """

    def __init__(self, domain, vocabulary: RequestVocabulary, settings: ServerSettings | None = None, *,
                 binding=None, executor: Executor | Callable[[StandingModel], Executor] | None = None,
                 observers: Iterable[Observer] = ()) -> None:
        settings = settings or ServerSettings()
        self.settings = settings
        self.domain = domain
        self.vocabulary = vocabulary
        self._stopping = threading.Event()
        clock = _StopClock(settings.clock, self._stopping)
        self.board = GoalBoard(vocabulary, limits=settings.limits, first_id=settings.first_goal_id)
        label = settings.goal or domain.labels[0]
        self.model = StandingModel(domain, label, serve_roles(domain, vocabulary, binding),
                                   max_horizon=settings.max_horizon, budget=settings.budget, agenda=self.board.agenda,
                                   solver=settings.solver or DEFAULT_SOLVER, horizon=settings.horizon)
        if executor is None:
            executor = SimulatedExecutor(self.model, default_s=settings.action_time, clock=clock)
        elif not isinstance(executor, Executor):
            executor = executor(self.model)
        self.executor: Executor = executor
        self.channels: list = []
        self.loop = OnlineLoop(self.model, executor, [self.board], [self.board, *observers], when_done="wait",
                               clock=clock, idle_poll_s=settings.idle_poll_s, keep_records=settings.keep_records)
        if settings.preempt not in ("finish", "stop"):
            raise ValueError(f"preempt must be 'finish' or 'stop', not {settings.preempt!r}")
        if settings.preempt == "stop":
            self.board.on_preempt = self.loop.interrupt
        self._t0 = time.monotonic()

    def log_to(self, stream: TextIO, extra: dict | None = None, history: LogHistory | None = None) -> ServeLog:
        """Write the run's log to ``stream`` (:mod:`.serve_log`): its start record now, then
        every goal change as it happens and every cycle. ``history``: the log it continues
        (:func:`~cplus.robot.serving.serve_log.open_log`)."""
        log = ServeLog(stream, self.board, extra, loop=self.loop, history=history)
        self.loop.observers.append(log)
        return log

    def add_script(self, script: RequestScript) -> None:
        script.attach(self.board)

    def listen(self, host: str = "127.0.0.1", port: int = 0) -> tuple[str, int]:
        """Take requests on a JSON-lines socket (loopback); returns the address it listens on."""
        channel = SocketChannel(self.board, host, port, self.settings.socket)
        address = channel.start()
        self.channels.append(channel)
        return address

    def add_channel(self, channel) -> None:
        """A channel started elsewhere (ROS): closed when the run ends."""
        self.channels.append(channel)

    def submit(self, request: str) -> Goal:
        return self.board.submit(request, origin="api")

    def run(self) -> RunResult:
        """Serve until stopped or until every channel has finished; then tell the clients how
        their goals ended (a second at most) and close the channels."""
        self._t0 = time.monotonic()
        try:
            return self.loop.run()
        finally:
            self.board.drain(1.0)
            for channel in self.channels:
                channel.close()
            self.board.close(0.5)

    def stop(self) -> None:
        """End the run between two cycles (from any thread, but not from a signal handler: it
        takes locks, which the interrupted main thread may hold; ``cplus serve`` calls it from
        its watchdog thread): the simulated robot's action and an idle wait end at once."""
        self._stopping.set()
        self.loop.stop()
        self.board.wake()

    def force_end(self, message: str, timeout: float = 0.6) -> None:
        """End now, as well as can be in ``timeout`` seconds, whatever the loop is doing (the
        watchdog's end, when :meth:`stop` was not enough): tell the robot to abort, abort the
        goals open (their clients are told what the channels still send in time), write the
        log's end record. Each part has a share of the time and is skipped when it cannot
        have it; the process is expected to exit right after."""
        deadline = time.monotonic() + timeout
        self.stop()
        robot = threading.Thread(target=self._abort_robot, name="cplus-serve-abort", daemon=True)
        robot.start()
        robot.join(timeout / 3)
        reason = f"the server stopped ({message})"
        self.board.abort_all(reason, timeout=max(deadline - time.monotonic(), 0.0) / 3)
        self.board.drain(max(deadline - time.monotonic(), 0.0) / 3)
        records = list(self.loop.records)
        end = RunResult(OnlineStatus.STOPPED, message, records, self.loop.state, dropped=self.loop._dropped,
                        dropped_replans=self.loop._dropped_replans, seconds=time.monotonic() - self._t0).to_json()
        for obs in list(self.loop.observers):
            if isinstance(obs, ServeLog):
                obs.end_now(end, max(deadline - time.monotonic(), 0.05))

    def _abort_robot(self) -> None:
        try:
            self.executor.abort()
        except Exception:  # noqa: BLE001 - ending anyway; the robot's own failure is no news here
            pass
