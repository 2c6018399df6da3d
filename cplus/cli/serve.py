"""``cplus serve DOMAIN``: keep a robot working on a domain's standing goal while requests come.

Goal requests and cancellations arrive from a script (``--script``), a JSON-lines socket on
the loopback interface (``--listen``), and ROS actionlib (``--ros``); each is an event of the
domain (``requests.toml`` beside it), and the online loop plans, acts and re-plans
(:mod:`cplus.robot.serving.reactive`). Without a channel option it listens on 127.0.0.1:7070.

Runs until interrupted (SIGINT or SIGTERM: the goals in flight are aborted, exit 0), or until
a script has delivered everything and every goal is final (exit 0). Exit codes otherwise as
``cplus online``: 1 no plan, 2 bad input, 5 the world contradicted the model, 6 ambiguous, 7
robot lost.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TextIO

from cplus.cli.common import (
    EXIT_INPUT,
    EXIT_OK,
    CliError,
    OneLineArgumentParser,
    Warnings,
    nonneg,
    parse_bricks,
    positive,
    seconds,
)
from cplus.cli.online import Progress
from cplus.robot.serving.goals import GoalWatcher

if TYPE_CHECKING:
    from cplus.api import Domain
    from cplus.robot.online.binding import RobotBinding
    from cplus.robot.serving.channels import RequestScript
    from cplus.robot.serving.reactive import ServerSettings
    from cplus.robot.serving.vocabulary import RequestVocabulary

__all__ = ["build_parser", "main", "DEFAULT_LISTEN"]

DEFAULT_LISTEN = "127.0.0.1:7070"


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
    p.add_argument("--log", metavar="FILE", help="write the run as JSON lines (cplus.online/1, with goals)")
    p.add_argument("--action-time", type=seconds, default=0.5, metavar="SECONDS",
                   help="simulated robot: how long each action takes (default 0.5)")
    p.add_argument("--budget", type=nonneg, metavar="PROPAGATIONS",
                   help="the solver's unit propagations for the shortest plan of every goal at once, per re-plan; "
                        "beyond it the oldest goal is served first (default 250000, some 20 ms; 0: always the oldest "
                        "goal first)")
    p.add_argument("--horizon", type=nonneg, metavar="STEPS",
                   help="steps the planner encodes when the server starts, so that the first long plans need no "
                        "encoding (default 20; more are added when a plan needs them)")
    p.add_argument("--max-horizon", type=nonneg, metavar="N",
                   help="longest plan when the goal's maxstep range is open (default 40)")
    p.add_argument("--no-latency", action="store_true",
                   help="with --robot: emulated bricks answer at once instead of with Bluetooth timing")
    p.add_argument("--time-scale", type=positive, default=None, metavar="X",
                   help="with --robot: emulated bricks and their worlds run on the wall clock, X times faster "
                        "(1 = real time); default: on simulated time")
    p.add_argument("--solver", default=None, help="SAT solver (default glucose4)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


class ServeProgress(Progress):
    """``cplus online``'s progress lines, without repeating an idle cycle's line when it ends."""

    shown = -1

    def on_act(self, record) -> None:
        self.shown = record.cycle
        super().on_act(record)

    def on_cycle(self, record) -> None:
        if record.cycle != self.shown or record.failure:
            super().on_cycle(record)


class GoalLines(GoalWatcher):
    """A progress line per goal change on stderr."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def status(self, goal, status) -> None:
        extra = f" (slot {goal.slot})" if status.value == "active" and goal.slot is not None else ""
        why = f": {goal.reason}" if goal.reason and status.value in ("rejected", "aborted", "recalled") else ""
        print(f"cplus serve: goal {goal.id} {goal.request}: {status.value}{extra}{why}", file=self.out, flush=True)


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
        log_file: the open ``--log`` file, if any.
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
    settings: ServerSettings
    args: argparse.Namespace


def main(args: argparse.Namespace) -> int:
    """``cplus serve``; returns the exit code."""
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
    from cplus.cli.common import query
    from cplus.robot.serving.channels import load_script, parse_listen
    from cplus.robot.serving.reactive import ServerSettings
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
    query(domain, label, args.domain)
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
    if args.ros:
        from cplus.robot.serving import ros_bridge
        try:
            ros = ros_bridge.RosSetup.check()
        except ros_bridge.RosUnavailable as exc:
            return _fail(str(exc))
    log_file = None
    if args.log:
        try:
            os.makedirs(os.path.dirname(os.path.abspath(args.log)), exist_ok=True)
            log_file = open(args.log, "w", encoding="utf-8")
        except OSError as exc:
            return _fail(f"cannot write {args.log}: {exc.strerror}")
    settings = ServerSettings(goal=label, budget=DEFAULT_BUDGET if args.budget is None else args.budget,
                              horizon=args.horizon, max_horizon=args.max_horizon, solver=args.solver,
                              action_time=args.action_time)
    return ServeOptions(domain, label, vocabulary, requests_path, script, binding, ports, listen, ros, log_file,
                        settings, args)


def _run(opts: ServeOptions) -> int:
    """Build the server from checked inputs, open its channels, serve until the end."""
    from cplus.cli.online import exit_code
    from cplus.robot.online.loop import OnlineStatus
    from cplus.robot.serving.reactive import ServeLog, Server
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
        server.loop.observers.append(ServeLog(opts.log_file, server.board, extra))
    if not args.quiet:
        server.board.watch(GoalLines(err))
    if opts.script is not None:
        server.add_script(opts.script)
    listen, ros = opts.listen, opts.ros
    try:
        if listen is not None:
            host, port = server.listen(*listen)
            print(f"cplus serve: listening on {host}:{port} (JSON lines; requests: {opts.vocabulary.usage()})",
                  file=err, flush=True)
        if ros is not None:
            from cplus.robot.serving import ros_bridge
            channel = ros_bridge.ActionChannel(server.board, args.ros_name, ros)
            server.add_channel(channel)
            channel.start()
            print(f"cplus serve: ROS action server {channel.namespace} ({channel.action_type}) at {ros.master_uri}",
                  file=err, flush=True)
    except (OSError, RuntimeError) as exc:
        for c in server.channels:
            c.close()
        what = f"cannot listen on {listen[0]}:{listen[1]}: {exc.strerror}" if isinstance(exc, OSError) and listen \
            else str(exc)
        print(f"cplus serve: error: {what}", file=err)
        return EXIT_INPUT

    def on_signal(signum, frame) -> None:
        server.stop()
    old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        result = server.run()
    finally:
        for s, h in old.items():
            signal.signal(s, h)
    if result.status in (OnlineStatus.STOPPED, OnlineStatus.GOAL_REACHED):
        return EXIT_OK
    return exit_code(result.status)
