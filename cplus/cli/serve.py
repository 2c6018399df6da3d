"""``cplus serve DOMAIN``: keep a robot working on a domain's standing goal while requests come.

Goal requests and cancellations arrive from a script (``--script``), a JSON-lines socket on
the loopback interface (``--listen``), and ROS actionlib (``--ros``); each is an event of the
domain (``requests.toml`` beside it), and the online loop plans, acts and re-plans
(:mod:`cplus.robot.serving.reactive`). Without a channel option it listens on 127.0.0.1:7070.

Runs until interrupted (SIGINT or SIGTERM: the goals in flight are aborted, exit 0), or until
a script has delivered everything and every goal is final (exit 0). A run that does not stop
within 1.2 s of the signal (or the seconds in ``CPLUS_STOP_GRACE``) is ended by the watchdog
(exit 130 or 143, ``128 + signal``), a second signal ends it at once (124). Exit codes
otherwise as ``cplus online``: 1 no plan, 2 bad input, 6 the world contradicted the model, 7
ambiguous, 8 robot lost.
"""
from __future__ import annotations

import argparse
import gc
import os
import re
import select
import signal
import socket
import sys
import threading
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, TextIO

from cplus.cli.common import (
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    CliError,
    OneLineArgumentParser,
    Warnings,
    action_seconds,
    nonneg,
    parse_bricks,
    positive_int,
    time_scale,
)
from cplus.cli.online import Progress, goal_error
from cplus.cli.paths import Input, Output, check_paths
from cplus.cli.signals import EXIT_FORCED, stop_grace
from cplus.robot.serving.goals import GoalWatcher

if TYPE_CHECKING:
    from cplus.api import Domain
    from cplus.robot.online.binding import RobotBinding
    from cplus.robot.serving.reactive import ServerSettings
    from cplus.robot.serving.script import RequestScript
    from cplus.robot.serving.vocabulary import RequestVocabulary

__all__ = ["build_parser", "main", "DEFAULT_LISTEN"]

DEFAULT_LISTEN = "127.0.0.1:7070"
GRACE_S = 1.2
"""After SIGINT or SIGTERM, how long the loop has to stop by itself before the watchdog ends
the run (:meth:`Server.force_end`, then exit ``128 + signal``), unless ``CPLUS_STOP_GRACE``
says otherwise (:func:`cplus.cli.signals.stop_grace`: a slow controller PC, or a loaded test
machine where the orderly stop is what a test checks)."""
FORCE_S = 0.6
"""How long the watchdog's forced end may take (stopping the robot, the log's end record)."""
_ROS_NAME = re.compile(r"/?[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*\Z")


def _at_most(kind, hi: float, unit: str):
    """An argparse type: ``kind`` and at most ``hi`` (a number beyond any sensible one would
    overflow a C type deep inside, or make the server encode or wait without end)."""
    def check(text: str):
        value = kind(text)
        if value > hi:
            raise argparse.ArgumentTypeError(f"at most {hi:g} {unit}, got '{text}'")
        return value
    check.__name__ = kind.__name__
    return check


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus serve",
        description="Serve goal requests on a C+ domain: requests and cancellations from a script, a JSON-lines "
                    "socket or ROS actionlib become events; the robot plans, acts and re-plans until interrupted.")
    p.add_argument("domain", help="the C+ domain file")
    p.add_argument("--goal", metavar="LABEL", help="the query of the standing goal: step-0 conditions are the start, "
                   "maxstep conditions say that nothing is pending (default: the file's first query)")
    p.add_argument("--listen", metavar="HOST:PORT", help="take JSON-lines requests on this loopback address "
                   f"(port 0: any free port; the default when no channel is given: {DEFAULT_LISTEN})")
    p.add_argument("--script", metavar="FILE", help="requests at given cycles, JSON lines {\"cycle\": 1, "
                   "\"request\": \"deliver(office3,office2)\"} or {\"cycle\": 3, \"cancel\": 1}")
    p.add_argument("--ros", action="store_true", help="an actionlib action server (ROS 1; ROS_MASTER_URI must name "
                   "a running roscore)")
    p.add_argument("--ros-name", metavar="NAME", default="cplus_serve",
                   help="the action server's namespace (default cplus_serve: /cplus_serve/goal, ...)")
    p.add_argument("--robot", metavar="FILE", help="the binding file (cplus.robot/1): the robot's actions run as "
                   "behaviours of NXT bricks (emulated unless --brick); default: a simulated robot")
    p.add_argument("--brick", action="append", default=[], metavar="NAME=PORT",
                   help="with --robot: brick NAME is at PORT; none: emulate every brick in its world")
    p.add_argument("--requests", metavar="FILE", help="the requests the domain accepts (cplus.requests/1; default: "
                   "requests.toml beside the domain)")
    p.add_argument("--log", metavar="FILE", help="write the run as JSON lines (cplus.online/1, with goals); an "
                   "existing log of that kind is continued, goal ids going on from its last one")
    p.add_argument("--log-overwrite", action="store_true",
                   help="replace the --log file whatever it holds (without it, a file that is not a cplus.online/1 "
                        "log is refused)")
    p.add_argument("--preempt", choices=("finish", "stop"), default="finish",
                   help="what cancelling a goal in flight does to the robot's step under way: finish lets it end "
                        "(default); stop sets the motors to 0 at once (the actions the binding allows to stop), "
                        "estimates the state from what was measured and plans on from there")
    p.add_argument("--action-time", type=action_seconds, default=0.5, metavar="SECONDS",
                   help="simulated robot: how long each action takes (default 0.5)")
    p.add_argument("--budget", type=_at_most(nonneg, 1e12, "propagations"), metavar="PROPAGATIONS",
                   help="the solver's unit propagations for the shortest plan of every goal at once, per re-plan; "
                        "beyond it the oldest goal is served first (default 250000, some 20 ms; 0: always the oldest "
                        "goal first)")
    p.add_argument("--horizon", type=_at_most(nonneg, 1000, "steps"), metavar="STEPS",
                   help="steps the planner encodes when the server starts, so that the first long plans need no "
                        "encoding (default 20; more are added when a plan needs them)")
    p.add_argument("--max-horizon", type=_at_most(nonneg, 1000, "steps"), metavar="N",
                   help="longest plan when the goal's maxstep range is open (default 40)")
    p.add_argument("--no-latency", action="store_true",
                   help="with --robot: emulated bricks answer at once instead of with Bluetooth timing")
    p.add_argument("--time-scale", type=time_scale, default=None, metavar="X",
                   help="with --robot: emulated bricks and their worlds run on the wall clock, X times faster "
                        "(1 = real time); default: on simulated time")
    p.add_argument("--max-clients", type=_at_most(positive_int, 10000, "connections"), default=None, metavar="N",
                   help="socket connections at once; one more is told so and closed (default 64)")
    p.add_argument("--max-goals", type=_at_most(positive_int, 100000, "goals"), default=None, metavar="N",
                   help="goals open at once (pending or in flight), every client together; a request beyond is "
                        "rejected with the reason (default 256)")
    p.add_argument("--max-client-goals", type=_at_most(positive_int, 100000, "goals"), default=None, metavar="N",
                   help="goals open at once for one client (a socket connection, a ROS node); a request beyond is "
                        "rejected with the reason, so that one client cannot make the others wait (default 32)")
    p.add_argument("--solver", default=None, help="SAT solver (default glucose4)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


def address_text(host: str, port: int) -> str:
    """``HOST:PORT`` as ``--listen`` takes it back: an IPv6 host in brackets (``[::1]:7070``)."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


class ServeProgress(Progress):
    """``cplus online``'s progress lines, without repeating an idle cycle's line when it ends."""

    shown = -1

    def on_act(self, record) -> None:
        self.shown = record.cycle
        super().on_act(record)

    def on_cycle(self, record) -> None:
        if record.cycle != self.shown or record.failure:
            super().on_cycle(record)



def one_line(text: str) -> str:
    """``text`` as it may go on a progress line: printable ASCII as it is, every other character
    escaped as Python writes it (``\\n``, ``\\x00``, ``\\xe9``, ``\\u2028``), so that what a client
    sends can neither split a line of stderr (nor forge one) nor reach the terminal raw."""
    if text.isascii() and text.isprintable():
        return text
    return _UNPRINTABLE.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), text)


_UNPRINTABLE = re.compile(r"[^\x20-\x7e]")


class GoalLines(GoalWatcher):
    """A progress line per goal change on stderr; the request and the reason (which may quote
    it) escaped by :func:`one_line`."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def status(self, goal, status) -> None:
        extra = f" (slot {goal.slot})" if status.value == "active" and goal.slot is not None else ""
        why = f": {one_line(goal.reason)}" if goal.reason and status.value in ("rejected", "aborted", "recalled") \
            else ""
        print(f"cplus serve: goal {goal.id} {one_line(goal.request)}: {status.value}{extra}{why}", file=self.out,
              flush=True)


@dataclass(frozen=True)
class ServeOptions:
    """The checked options of one ``cplus serve``: everything :func:`_run` needs, read and
    validated before anything moves (so a bad input is an exit 2 with nothing started), and
    named, so that the run takes one value instead of a dozen positional ones.

    Attributes:
        domain: the loaded domain; ``label`` its standing goal's query.
        vocabulary: the requests it accepts, read from ``requests_path``.
        script: the ``--script`` requests, if any.
        binding: the ``--robot`` binding, and ``ports`` its ``--brick`` ports (empty: emulated).
        listen: the socket's address, if it listens.
        ros: ROS, checked (master answering), when ``--ros``.
        log_file: the open ``--log`` file, if any; ``log_history`` what it held, when continued.
        settings: how the server plans and runs (``--budget``, ``--horizon``, ...).
        args: the parsed command line, for the plain values (``--quiet``, ``--ros-name``, ...).
    """

    domain: Domain
    label: str
    vocabulary: RequestVocabulary
    requests_path: str
    script: RequestScript | None
    binding: RobotBinding | None
    ports: dict[str, str]
    listen: tuple[str, int] | None
    ros: Any                      # ros_bridge.RosSetup: that module is imported only with --ros
    log_file: TextIO | None
    log_history: Any              # serve_log.LogHistory of a continued log, or None
    settings: ServerSettings
    args: argparse.Namespace


def main(args: argparse.Namespace) -> int:
    """``cplus serve``; returns the exit code."""
    gc.enable()                         # a server runs for days: reference cycles must be collected
    checked = _check(args)
    if isinstance(checked, int):
        return checked
    try:
        return _run(checked)
    finally:
        if checked.log_file is not None:
            checked.log_file.close()
            if not args.quiet:
                print(f"cplus serve: wrote {args.log}", file=sys.stderr)


def _fail(message: str) -> int:
    print(f"cplus serve: error: {message}", file=sys.stderr)
    return EXIT_INPUT


def _check(args: argparse.Namespace) -> ServeOptions | int:
    """Read and check every input; the options, or the exit code of the first bad one (its
    message printed)."""
    from cplus.api import Domain
    from cplus.robot.serving.goals import Limits
    from cplus.robot.serving.reactive import ServerSettings
    from cplus.robot.serving.script import load_script
    from cplus.robot.serving.socket_channel import SocketLimits, parse_listen
    from cplus.robot.serving.standing import DEFAULT_BUDGET
    from cplus.robot.serving.vocabulary import load_requests, requests_beside
    listen = None
    if args.listen or not (args.script or args.ros):
        try:
            listen = parse_listen(args.listen or DEFAULT_LISTEN)
        except ValueError as exc:
            return _fail(f"--listen: {exc}")
    try:
        ports = parse_bricks(args.brick, "cplus serve")
    except CliError as exc:
        print(exc, file=sys.stderr)
        return EXIT_INPUT
    if ports and not args.robot:
        return _fail("--brick needs --robot (the binding file that names the bricks)")
    requests_path = args.requests or requests_beside(args.domain)
    if requests_path is None:
        return _fail(f"no requests.toml beside {args.domain}: give the requests the domain accepts with --requests FILE")
    domain = Domain.load(args.domain)
    Warnings()(domain.diagnostics)
    if not domain.labels:
        return _fail(f"{args.domain} has no query: add one whose step-0 conditions are the start and whose maxstep "
                    "conditions say that nothing is pending")
    label = args.goal or domain.labels[0]
    wrong = goal_error(domain, label)
    if wrong:
        return _fail(wrong)
    vocabulary = load_requests(requests_path, domain)
    script = load_script(args.script) if args.script else None
    binding = None
    if args.robot:
        from cplus.robot.online.binding import load_binding
        binding = load_binding(args.robot, domain)
        unknown = sorted(set(ports) - set(binding.bricks))
        if unknown:
            return _fail(f"--brick {unknown[0]}: {args.robot} has no brick {unknown[0]!r} "
                        f"(bricks: {', '.join(binding.bricks) or 'none'})")
        missing = [b for b in binding.bricks if ports and b not in ports]
        if missing:
            return _fail(f"no --brick for brick {missing[0]!r}: give one per brick, or none to emulate them")
    ros = None
    if args.ros and not _ROS_NAME.match(args.ros_name):
        return _fail(f"--ros-name: {args.ros_name!r} is not a ROS name (letters, digits and _, parts separated "
                     "by /, each starting with a letter)")
    if args.ros:
        from cplus.robot.serving import ros_bridge
        try:
            ros = ros_bridge.RosSetup.check()
        except ros_bridge.RosUnavailable as exc:
            return _fail(str(exc))
    log_file = history = None
    if args.log_overwrite and not args.log:
        return _fail("--log-overwrite needs --log FILE")
    if args.log:                        # written as the run goes, continued (cplus.serve/3)
        from cplus.robot.serving.serve_log import LogRefused, open_log
        inputs = [Input(args.domain, "the domain"), Input(requests_path, "the requests file"),
                  Input(args.script, "the script"), Input(args.robot, "the binding"),
                  *(Input(str(b.world), "a world file") for b in (binding.bricks.values() if binding else ())
                    if b.world is not None)]
        try:
            check_paths("cplus serve", inputs, [Output("--log", args.log)])
            log_file, history = open_log(args.log, overwrite=args.log_overwrite)
        except CliError as exc:
            print(exc, file=sys.stderr)
            return EXIT_INPUT
        except LogRefused as exc:
            return _fail(f"--log: {exc}")
        except OSError as exc:
            return _fail(f"--log {args.log}: cannot write: {exc.strerror}")
    limits, sockets = Limits(), SocketLimits()
    limits = replace(limits, open_goals=args.max_goals or limits.open_goals,
                     client_goals=args.max_client_goals or limits.client_goals)
    sockets = replace(sockets, clients=args.max_clients or sockets.clients)
    settings = ServerSettings(goal=label, budget=DEFAULT_BUDGET if args.budget is None else args.budget,
                              horizon=args.horizon, max_horizon=args.max_horizon, solver=args.solver,
                              action_time=args.action_time, limits=limits, socket=sockets,
                              first_goal_id=history.last_goal_id + 1 if history is not None else 1,
                              preempt=args.preempt)
    return ServeOptions(domain, label, vocabulary, requests_path, script, binding, ports, listen, ros, log_file,
                        history, settings, args)


def _run(opts: ServeOptions) -> int:
    """Build the server from checked inputs, open its channels, serve until the end."""
    from cplus.cli.online import exit_code
    from cplus.robot.online.loop import OnlineStatus
    from cplus.robot.serving.reactive import Server
    args = opts.args
    err = sys.stderr
    executor = None
    if opts.binding is not None:
        from cplus.robot.online.nxt_executor import NxtExecutor
        binding, ports = opts.binding, opts.ports

        def executor(model):
            return NxtExecutor(model, binding, ports or None, latency=not args.no_latency,
                               time_scale=args.time_scale)
    observers: list = [] if args.quiet else [ServeProgress(err, "cplus serve")]
    server = Server(opts.domain, opts.vocabulary, opts.settings, binding=opts.binding, executor=executor,
                    observers=observers)
    if opts.log_file is not None:
        extra = {"requests": opts.requests_path, "accepts": opts.vocabulary.usage(), "binding": args.robot}
        serve_log = server.log_to(opts.log_file, extra, opts.log_history)
    if not args.quiet:
        server.board.watch(GoalLines(err))
    if opts.script is not None:
        server.add_script(opts.script)
    listen, ros = opts.listen, opts.ros
    watchdog = Watchdog(server, err, quiet=args.quiet, grace_s=stop_grace("cplus serve", default=GRACE_S))
    watchdog.install()                  # before the address is printed: a signal from then on is honoured
    try:
        try:
            if listen is not None:
                host, port = server.listen(*listen)
                print(f"cplus serve: listening on {address_text(host, port)} (JSON lines; requests: {opts.vocabulary.usage()})",
                      file=err, flush=True)
            if ros is not None:
                from cplus.robot.serving import ros_bridge
                def say(text: str) -> None:
                    print(f"cplus serve: {text}", file=err, flush=True)
                channel = ros_bridge.ActionChannel(server.board, args.ros_name, ros, say=say)
                server.add_channel(channel)
                channel.start()
                print(f"cplus serve: ROS action server {channel.namespace} ({channel.action_type}) at "
                      f"{ros.master_uri}", file=err, flush=True)
        except (OSError, RuntimeError) as exc:
            for c in server.channels:
                c.close()
            what = f"cannot listen on {address_text(*listen)}: {exc.strerror}" \
                if isinstance(exc, OSError) and listen else str(exc)
            print(f"cplus serve: error: {what}", file=err)
            return EXIT_INPUT
        try:
            result = server.run()
        except KeyboardInterrupt:       # SIGINT inside a SAT call (the solver's own handler): a stop
            return EXIT_OK
        code = EXIT_OK if result.status in (OnlineStatus.STOPPED, OnlineStatus.GOAL_REACHED) \
            else exit_code(result.status)
        if opts.log_file is not None and serve_log.failure:
            print(f"cplus serve: warning: goal records of {args.log} could not all be written: {serve_log.failure}",
                  file=err, flush=True)
        watchdog.finished(code)
        return code
    finally:
        watchdog.uninstall()


def _exit_now(signum, frame) -> None:
    os._exit(EXIT_FORCED)


class Watchdog:
    """SIGINT and SIGTERM end ``cplus serve`` within ``grace_s`` (:data:`GRACE_S`) +
    :data:`FORCE_S` seconds, whatever its threads are doing.

    A Python signal handler runs only when the main thread comes back to the interpreter, and
    the main thread may be waiting for a robot or inside a SAT call. So the signal is also
    written, by the C-level handler, to a socket (:func:`signal.set_wakeup_fd`) that this
    thread watches: at the first signal it asks the server to stop between two cycles
    (:meth:`Server.stop`), and when the run has not ended ``grace_s`` seconds later it
    ends it (:meth:`Server.force_end`: the robot told to abort, the goals aborted, the log's
    end record) and exits ``128 + signal`` (130, 143), as ``cplus online`` does
    (:mod:`cplus.cli.signals`). A second signal does that at once and exits 124
    (``EXIT_FORCED``). An orderly stop exits 0: serving until a signal is how ``cplus serve``
    is used. Unlike :class:`cplus.cli.signals.Shutdown`, nothing is raised in the main thread:
    an exception there could cut the channels' last answers or a log line short, while the
    loop's own stop ends the run between two cycles. Once a signalled run has
    ended, the process has ``grace_s`` seconds to exit (a thread of a library that does
    not end cannot hold it), then exits with the run's code. Without a signal this thread only
    ends with the run (so ``cplus serve`` run in-process, as in tests, is never exited).

    Messages go through a thread of their own: a full stderr pipe must not hold the watchdog."""

    def __init__(self, server, err: TextIO, quiet: bool = False, grace_s: float = GRACE_S) -> None:
        self.server = server
        self.err = err
        self.quiet = quiet
        self.grace_s = grace_s
        self._done = threading.Event()
        self._code = EXIT_OK
        self._installed = False
        self._signalled = False
        self._old: dict = {}
        self._old_fd = -1
        self._r: socket.socket | None = None
        self._w: socket.socket | None = None
        self._thread: threading.Thread | None = None

    def install(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return                      # signals are the main thread's: whoever runs us handles them
        self._r, self._w = socket.socketpair()
        self._r.setblocking(False)
        self._w.setblocking(False)
        self._old = {s: signal.signal(s, self._on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        self._old_fd = signal.set_wakeup_fd(self._w.fileno(), warn_on_full_buffer=False)
        self._installed = True
        self._thread = threading.Thread(target=self._watch, name="cplus-serve-watchdog", daemon=True)
        self._thread.start()

    def _on_signal(self, signum, frame) -> None:
        """The Python-level handler: only a mark. It runs in the main thread between two
        bytecodes, maybe inside ``with lock:`` of the very lock that stopping takes (a stop
        from here deadlocked the main thread on the board's lock, and the watchdog behind it);
        the watchdog hears the same signal through the wakeup fd and stops the server from its
        own thread."""
        self._signalled = True

    def finished(self, code: int) -> None:
        self._code = code

    def uninstall(self) -> None:
        if not self._installed:
            return
        self._installed = False
        for s, h in self._old.items():
            # after a signal, the process is on its way out: another one ends it at once (130),
            # not with the default action's death by signal; otherwise the handlers are given back
            signal.signal(s, _exit_now if self._signalled else h)
        signal.set_wakeup_fd(self._old_fd)
        self._done.set()
        assert self._w is not None
        try:
            self._w.send(b"\0")           # wake the watchdog to see the run ended
        except OSError:
            pass

    def _say(self, text: str) -> None:
        def write() -> None:
            try:
                print(f"cplus serve: {text}", file=self.err, flush=True)
            except (OSError, ValueError):
                pass
        threading.Thread(target=write, name="cplus-serve-say", daemon=True).start()

    def _watch(self) -> None:
        assert self._r is not None
        first: float | None = None
        code = EXIT_INTERRUPTED
        while True:
            timeout = None if first is None else max(first + self.grace_s - time.monotonic(), 0.0)
            ready, _, _ = select.select([self._r], [], [], timeout)
            if ready:
                try:
                    data = self._r.recv(64)
                except BlockingIOError:
                    data = b""
                signals = [b for b in data if b in (signal.SIGINT, signal.SIGTERM)]
                if signals and first is None:
                    first = time.monotonic()
                    code = 128 + signals[0]
                    self.server.stop()
                    if not self.quiet:
                        self._say(f"{signal.Signals(signals[0]).name}: stopping (the goals in flight are aborted; "
                                  "a second signal ends at once)")
                    signals = signals[1:]
                if signals:
                    self._say(f"{signal.Signals(signals[0]).name} again: ending now")
                    self.server.force_end("forced by a second signal", FORCE_S)
                    os._exit(EXIT_FORCED)
                if self._done.is_set() and first is None:
                    return                      # ended without a signal: nothing to watch
                continue
            assert first is not None           # the grace period is over
            if self._done.is_set():
                os._exit(self._code)            # the run ended, but the process did not exit
            self._say(f"the run did not stop within {self.grace_s:g} s of the signal: ending it")
            self.server.force_end(f"forced {self.grace_s:g} s after the signal", FORCE_S)
            os._exit(code)
