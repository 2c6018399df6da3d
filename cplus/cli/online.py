"""``cplus online DOMAIN``: run a C+ domain online on a robot (the Legolog loop).

Plans from the current state, sends the first step's actions to the robot, reads its sensing
values and the events that happened, estimates the new state, re-plans when it differs from the
prediction, until the goal holds (:mod:`cplus.robot.online.loop`). The robot is described by the
binding file ``robot.toml`` beside the domain (or ``--robot``). Its bricks are opened at
``--brick NAME=PORT``; without ``--brick`` they are emulated on pseudo-terminals, in the world
file the binding names. ``--simulate`` uses no brick at all: the world does what the model
predicts, and ``--events`` brings the surprises.

Exit codes (:mod:`cplus.cli.common`): 0 goal reached, 1 no plan from the observed state,
2 bad input, 3 ``--max-cycles`` reached, 6 the world contradicted the model, 7 the observed
state is ambiguous, 8 a robot was lost, 130 SIGINT, 143 SIGTERM (the bricks told to stop, the log
ended), 124 a second signal (:mod:`cplus.cli.signals`).
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TextIO

from cplus.cli.common import (
    EXIT_AMBIGUOUS,
    EXIT_CONTRADICTED,
    EXIT_INPUT,
    EXIT_INTERRUPTED,
    EXIT_LIMIT,
    EXIT_NO_PLAN,
    EXIT_OK,
    EXIT_ROBOT_LOST,
    CliError,
    OneLineArgumentParser,
    Warnings,
    action_seconds,
    checked,
    nonempty,
    nonneg,
    parse_bricks,
    positive,
    query_label,
    time_scale,
)
from cplus.cli.paths import Input, Output, check_paths
from cplus.cli.signals import Shutdown, exit_code_of, motors_off, reason_of
from cplus.options import check_max_horizon, check_solver

__all__ = ["build_parser", "main", "exit_code", "end_line", "goal_error"]

MAX_EVENTS_FILE = 16 * 1024 * 1024
"""The largest ``--events FILE`` read (characters): a script of a few hundred thousand lines,
read and checked in seconds; anything larger is a mistake (a device, a log)."""


ACTION_TIME = 0.0
"""``--simulate``: seconds per action by default (a run as fast as the planner goes)."""
TYPING_ACTION_TIME = 1.0
"""``--simulate --events -``: seconds per action by default, so that a person at the keyboard
can type ``press`` before the goal is reached."""


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus online",
        description="Run a C+ domain online on a robot: plan, act, sense, observe events, estimate the state, "
                    "re-plan when the world differs from the plan, until the goal holds.")
    p.add_argument("domain", help="the C+ domain file")
    p.add_argument("--goal", type=query_label, metavar="LABEL", help="the query whose step-0 conditions are the start and whose "
                   "other conditions are the goal (default: the file's first query)")
    p.add_argument("--robot", type=nonempty, metavar="FILE", help="the binding file (cplus.robot/1; default: robot.toml beside "
                   "the domain)")
    p.add_argument("--brick", action="append", default=[], metavar="NAME=PORT",
                   help="brick NAME is at PORT (/dev/rfcomm0, or a `cplus brick` pty); repeat per brick; none: "
                        "emulate every brick in its world")
    p.add_argument("--simulate", action="store_true",
                   help="no brick: a simulated robot that does what the model predicts (events come from --events)")
    p.add_argument("--action-time", type=action_seconds, default=None, metavar="SECONDS",
                   help=f"with --simulate: how long each action takes (default {ACTION_TIME:g}; with --events -, "
                        f"{TYPING_ACTION_TIME:g}, so that there is time to type an event)")
    p.add_argument("--events", type=nonempty, metavar="FILE|-", help="events from a file or standard input: lines "
                   "'[@CYCLE] EVENT ...' naming events whose binding source is 'input'")
    p.add_argument("--log", type=nonempty, metavar="FILE", help="write the run as JSON lines (cplus.online/1)")
    p.add_argument("--max-cycles", type=nonneg, metavar="N", help="stop after N cycles without reaching the goal")
    p.add_argument("--max-horizon", type=checked(check_max_horizon, int), metavar="N",
                   help="longest plan when the goal's maxstep range is open (default 40)")
    p.add_argument("--no-latency", action="store_true",
                   help="emulated bricks answer at once instead of with Bluetooth timing")
    p.add_argument("--time-scale", type=time_scale, default=None, metavar="X",
                   help="emulated bricks and their worlds run on the wall clock, X times faster than real time "
                        "(1 = real time); default: on simulated time, as fast as the emulation goes and whatever "
                        "the machine's load")
    p.add_argument("--solver", type=checked(check_solver), default=None, help="SAT solver (default glucose4)")
    arms = p.add_argument_group("the payload arms of a robot task (a scene.toml beside the domain)")
    arms.add_argument("--scene", type=nonempty, metavar="FILE", help="the scene (default: scene.toml beside the domain, when there "
                      "is no robot.toml)")
    arms.add_argument("--tracking-threshold", type=positive, default=30.0, metavar="DEG",
                      help="a motor this far from its setpoints is not following: stop, map to the grid, re-plan "
                           "(default 30)")
    arms.add_argument("--max-faults", type=nonneg, default=3, metavar="N",
                      help="give up after N tracking faults (default 3)")
    arms.add_argument("--stall", action="append", default=[], metavar="ROBOT:PORT@SECONDS[+DURATION]",
                      help="emulated bricks: hold a motor still SECONDS after it first turned (for DURATION, or "
                           "for good)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


def exit_code(status) -> int:
    """The exit code of an :class:`~cplus.robot.online.loop.OnlineStatus`."""
    from cplus.robot.online.loop import OnlineStatus as S
    return {S.GOAL_REACHED: EXIT_OK, S.NO_PLAN: EXIT_NO_PLAN, S.MAX_CYCLES: EXIT_LIMIT,
            S.CONTRADICTED: EXIT_CONTRADICTED, S.AMBIGUOUS: EXIT_AMBIGUOUS, S.ROBOT_LOST: EXIT_ROBOT_LOST,
            S.STOPPED: EXIT_INTERRUPTED}[status]


class Progress:
    """One line per cycle on stderr: wall time, what was sensed and observed, re-plans with the
    fluents that differed, what is sent; then how the run ended."""

    def __init__(self, out: TextIO, prog: str = "cplus online") -> None:
        self.out = out
        self.prog = prog

    def _line(self, text: str) -> None:
        print(f"{self.prog}: {text}", file=self.out, flush=True)

    def on_start(self, loop) -> None:
        self._line(f"{loop.model.domain.path}: goal '{loop.model.query.label}' on {loop.executor.description}")

    def _observed(self, record) -> list[str]:
        parts = []
        if record.sensed:
            parts.append("sensed " + ", ".join(f"{gc.text}={_v(v)}" for gc, v in record.sensed.items()))
        if record.events:
            parts.append("events " + ", ".join(record.events))
        if record.inferred:
            parts.append("inferred " + ", ".join(record.inferred))
        if record.replanned is not None and record.plan is not None:
            steps = [_step(s) for s in record.plan.texts()]
            shown = _clip(", ".join(steps), 160)
            what = "plan" if record.replanned.reason == "start" else f"replan ({record.replanned.text()})"
            parts.append(f"{what}: {len(steps)} step{'s' if len(steps) != 1 else ''}" + (f": {shown}" if steps else ""))
        parts.extend(record.notes)
        return parts

    def on_act(self, record) -> None:
        acts = [a.text for a in record.executed]
        sent = (" ".join(acts) if len(acts) <= 4 else f"{len(acts)} actions of {record.plan.length} steps") or \
            ("wait for an event" if record.plan.length == 0 else "nothing (an idle step)")
        parts = self._observed(record) + [f"send {sent}"]
        self._line(f"cycle {record.cycle} [{record.time:.2f} s] " + " | ".join(parts))

    def on_cycle(self, record) -> None:
        if record.failure:
            self._line(f"cycle {record.cycle}: {record.failure}")
        if not record.executed and (record.plan is None or record.plan.length == 0):
            parts = self._observed(record)
            if parts:
                self._line(f"cycle {record.cycle} [{record.time:.2f} s] " + " | ".join(parts))

    def on_end(self, result) -> None:
        self._line(end_line(result))


def end_line(result) -> str:
    """How a run ended, with how many cycles ran (those that executed a step or waited: cycle k
    is reached after k of them), its re-plans and its time (every cycle counted, also those
    whose records the loop no longer keeps)."""
    ran = max(result.cycles - 1, 0)
    return (f"{result.status.value}: {result.message}; {ran} cycle{'s' if ran != 1 else ''} ran, {result.replans} "
            f"replan{'s' if result.replans != 1 else ''}, {result.seconds:.2f} s")


def _step(actions: Sequence[str]) -> str:
    if len(actions) == 1:
        return actions[0]
    return "{" + ", ".join(actions) + "}" if actions else "(wait)"


def _clip(text: str, width: int) -> str:
    return text if len(text) <= width else text[:width - 4].rsplit(", ", 1)[0] + ", ..."


def _v(value: object) -> str:
    from cplus.signature import render_value
    return render_value(value)  # type: ignore[arg-type]


def main(args: argparse.Namespace) -> int:
    """``cplus online``; returns the exit code."""
    from cplus.robot.offline.task import scene_beside
    from cplus.robot.online.binding import binding_beside
    err = sys.stderr
    try:
        ports = parse_bricks(args.brick, "cplus online")
        robot = args.robot or binding_beside(args.domain)
        scene = None if robot else (args.scene or scene_beside(args.domain))
        if robot is None and scene is None:
            raise CliError(f"cplus online: error: no robot.toml (or scene.toml) beside {args.domain}: give the "
                           "binding file with --robot FILE")
        if args.simulate and ports:
            raise CliError("cplus online: error: --simulate uses no brick; drop --brick or --simulate")
        wrong = ([("--stall", args.stall), ("--scene", args.scene)] if robot else
                 [("--events", args.events), ("--simulate", args.simulate), ("--max-cycles", args.max_cycles is not None)])
        for flag, given in wrong:
            if given:
                what = "a robot with a binding file" if robot else "the arms of a robot task (scene.toml)"
                raise CliError(f"cplus online: error: {flag} has no meaning for {what}")
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
    if robot is not None:
        return _behaviours(args, robot, ports)
    return _arms(args, scene, ports)  # type: ignore[arg-type]


def _domain_and_goal(args: argparse.Namespace, domain) -> str | None:
    Warnings()(domain.diagnostics)
    if not domain.labels:
        print(f"cplus online: error: {args.domain} has no query: add one whose step-0 conditions are the start "
              "and whose maxstep conditions are the goal", file=sys.stderr)
        return None
    label = args.goal or domain.labels[0]
    wrong = goal_error(domain, label)
    if wrong:
        print(f"cplus online: error: {wrong}", file=sys.stderr)
        return None
    return label


def goal_error(domain, label: str) -> str | None:
    """What is wrong with ``--goal LABEL`` (no such query: the labels there are), or None. Not
    located in the file: the label came from the command line, and no line of the file is
    wrong."""
    from cplus.errors import QueryError
    try:
        domain.query(label)
    except QueryError as exc:
        return f"--goal {label}: {exc.message}"
    return None


class _Log:
    """``--log FILE``: checked with the other paths and opened before the run (a bad path is
    an input error), closed after.  Written as the run goes, in place (a run ended by the
    watchdog or killed leaves what it did): a regular file is truncated, a device or a FIFO
    written through, nothing replaced."""

    def __init__(self, path: str | None, inputs: list[Input]) -> None:
        self.path = path
        self.inputs = inputs
        self.file: TextIO | None = None

    def open(self) -> bool:
        if self.path:
            try:
                check_paths("cplus online", self.inputs, [Output("--log", self.path)])
                self.file = open(self.path, "w", encoding="utf-8")
            except CliError as exc:
                print(exc, file=sys.stderr)
                return False
            except OSError as exc:
                print(f"cplus online: error: --log {self.path}: cannot write: {exc.strerror}", file=sys.stderr)
                return False
        return True

    def check(self) -> bool:
        """The path checked alone (before the bricks are started; opened after)."""
        try:
            check_paths("cplus online", self.inputs, [Output("--log", self.path)])
        except CliError as exc:
            print(exc, file=sys.stderr)
            return False
        return True

    def observer(self, extra: dict) -> list:
        from cplus.robot.online.loop import JsonLinesLog
        return [] if self.file is None else [JsonLinesLog(self.file, extra)]

    def close(self, quiet: bool) -> None:
        if self.file is not None:
            self.file.close()
            if not quiet:
                print(f"cplus online: wrote {self.path}", file=sys.stderr)


def _behaviours(args: argparse.Namespace, robot: str, ports: dict[str, str]) -> int:
    """A robot whose actions are behaviours of bricks (a binding file)."""
    from cplus.api import Domain
    from cplus.robot.online.binding import load_binding
    from cplus.robot.online.estimation import OnlineModel
    from cplus.robot.online.events import LineEvents, ScriptedEvents, check_events, parse_events
    from cplus.robot.online.loop import EventSource, OnlineLoop
    from nxt_link.wire.clock import MONOTONIC
    err = sys.stderr
    domain = Domain.load(args.domain)
    label = _domain_and_goal(args, domain)
    if label is None:
        return EXIT_INPUT
    binding = load_binding(robot, domain)
    unknown = sorted(set(ports) - set(binding.bricks))
    if unknown:
        print(f"cplus online: error: --brick {unknown[0]}: {robot} has no brick {unknown[0]!r} "
              f"(bricks: {', '.join(binding.bricks) or 'none'})", file=err)
        return EXIT_INPUT
    missing = [b for b in binding.bricks if ports and b not in ports]
    if missing:
        print(f"cplus online: error: no --brick for brick {missing[0]!r}: give one per brick, or none to emulate "
              "them", file=err)
        return EXIT_INPUT
    model = OnlineModel(domain, label, binding.roles(), max_horizon=args.max_horizon,
                        **({"solver": args.solver} if args.solver else {}))
    sources: list[EventSource] = []
    if args.events == "-":
        sources.append(LineEvents(sys.stdin, binding.input_events(args.simulate)))
    elif args.events:
        try:
            with open(args.events, encoding="utf-8") as f:
                text = f.read(MAX_EVENTS_FILE + 1)     # bounded: --events /dev/zero is an error, not a hang
        except (OSError, UnicodeDecodeError) as exc:
            print(f"cplus online: error: cannot read {args.events}: {getattr(exc, 'strerror', None) or exc}",
                  file=err)
            return EXIT_INPUT
        if len(text) > MAX_EVENTS_FILE:
            print(f"cplus online: error: {args.events}: an event file has at most {MAX_EVENTS_FILE} characters",
                  file=err)
            return EXIT_INPUT
        lines = parse_events(text, args.events)
        check_events(lines, binding.input_events(args.simulate))
        sources.append(ScriptedEvents(lines))
    inputs = [Input(args.domain, "the domain"), Input(robot, "the binding"), Input(args.events, "the events file"),
              *(Input(str(b.world), "a world file") for b in binding.bricks.values() if b.world is not None)]
    log = _Log(args.log, inputs)
    if args.log and not log.check():
        return EXIT_INPUT
    executor = _executor(args, model, binding, ports)
    if not log.open():
        return EXIT_INPUT
    observers: list = ([] if args.quiet else [Progress(err)]) + log.observer({"binding": robot})
    loop = OnlineLoop(model, executor, sources, observers, max_cycles=args.max_cycles,
                      clock=getattr(executor, "clock", MONOTONIC))   # emulated bricks: their simulated clock
    return _supervised(loop.run, "the robot was", lambda: [b.brick for b in getattr(executor, "bricks", {}).values()],
                       observers, log, args.quiet, err, on_stop=loop.stop)


def action_time(args: argparse.Namespace) -> float:
    """``--action-time``, or its default: :data:`TYPING_ACTION_TIME` when events are typed
    (``--events -``), else :data:`ACTION_TIME`."""
    if args.action_time is not None:
        return args.action_time
    return TYPING_ACTION_TIME if args.events == "-" else ACTION_TIME


def _executor(args: argparse.Namespace, model, binding, ports: dict[str, str]):
    from cplus.robot.online.executors import SimulatedExecutor
    if args.simulate:
        return SimulatedExecutor.from_binding(model, binding, default_s=action_time(args))
    from cplus.robot.online.nxt_executor import NxtExecutor
    return NxtExecutor(model, binding, ports or None, latency=not args.no_latency, time_scale=args.time_scale)


def _arms(args: argparse.Namespace, scene: str, ports: dict[str, str]) -> int:
    """The payload arms of a robot task: trajectories, monitored; re-planned after a fault."""
    from cplus.robot.offline.task import RobotTask
    from cplus.robot.online.payload_monitor import ArmsExecutor, run_arms
    err = sys.stderr
    task = RobotTask.load(args.domain, scene)
    label = _domain_and_goal(args, task.domain)
    if label is None:
        return EXIT_INPUT
    robots = list(task.robots)
    try:
        unknown = sorted(set(ports) - set(robots))
        if unknown:
            raise CliError(f"cplus online: error: --brick {unknown[0]}: the scene has no robot {unknown[0]!r} "
                           f"(robots: {', '.join(robots)})")
        missing = [r for r in robots if ports and r not in ports]
        if missing:
            raise CliError(f"cplus online: error: no --brick for robot {missing[0]!r}: give one per robot, or none "
                           "to emulate them")
        stalls = _stalls(args.stall, robots)
        if stalls and ports:
            raise CliError("cplus online: error: --stall needs emulated bricks (no --brick); for a brick on a port, "
                           "start it with `cplus brick --stall`")
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
    log = _Log(args.log, [Input(args.domain, "the domain"), Input(scene, "the scene")])
    if not log.open():
        return EXIT_INPUT
    executor = ArmsExecutor(robots, ports or None, stalls, time_scale=args.time_scale, latency=not args.no_latency)
    observers: list = ([] if args.quiet else [Progress(err)]) + log.observer({"scene": scene})
    return _supervised(lambda: run_arms(task, label, executor, observers=observers,
                                        threshold_deg=args.tracking_threshold, max_faults=args.max_faults,
                                        max_horizon=args.max_horizon),
                       "the bricks were", lambda: list(executor.bricks.values()), observers, log, args.quiet, err)


def _supervised(run, who: str, bricks, observers, log, quiet: bool, err, on_stop=None) -> int:
    """Run the loop under the shutdown watchdog (SIGINT/SIGTERM: an orderly stop, then motors
    off if it is late) and turn how it ended into the exit code; the log is closed however."""
    from nxt_link.wire.clock import SimulationStalled
    with Shutdown("cplus online") as shutdown:
        if on_stop is not None:
            shutdown.on_stop(on_stop)
        _forced_stop(shutdown, bricks, observers)
        try:
            result = run()
        except SimulationStalled as exc:
            print(f"cplus online: error: {exc}", file=err)
            return EXIT_ROBOT_LOST
        except KeyboardInterrupt as exc:
            print(f"cplus online: {reason_of(exc)} ({who} told to stop)", file=err)
            return exit_code_of(exc)
        finally:
            log.close(quiet)
    return shutdown.exit_code if result.status.value == "stopped" else exit_code(result.status)


def _forced_stop(shutdown, bricks, observers) -> None:
    """What the shutdown watchdog does when the orderly stop is late: motors off on every
    brick, and the log's end record (``"forced": true``)."""
    from cplus.robot.online.loop import JsonLinesLog
    shutdown.on_force(lambda: motors_off(bricks()))
    for obs in observers:
        if isinstance(obs, JsonLinesLog):
            shutdown.on_force(lambda obs=obs: obs.end_forced(f"{_stop_reason(shutdown)}, forced after "
                                                             f"{shutdown.grace_s:g} s (motors commanded off)"))


def _stop_reason(shutdown) -> str:
    from cplus.cli.signals import Stopped
    return str(Stopped(shutdown.signum)) if shutdown.signum is not None else "interrupted"


def _stalls(items: Sequence[str], robots: Sequence[str]) -> dict:
    from nxt_link.emulator.stall import Stall
    out: dict[str, list] = {}
    for item in items:
        name, sep, spec = item.partition(":")
        if not sep or name not in robots:
            raise CliError(f"cplus online: error: --stall expects ROBOT:PORT@SECONDS[+DURATION] with ROBOT one of "
                           f"{', '.join(robots)}, got {item!r}")
        try:
            stall = Stall.parse(spec)
        except ValueError as exc:
            raise CliError(f"cplus online: error: --stall: {exc}") from None
        earlier = [s for s in out.get(name, []) if s.port == stall.port]
        if earlier:        # the emulator holds one stall per motor: say so now, not in a traceback later
            raise CliError(f"cplus online: error: --stall {item} and --stall {name}:{earlier[0]} are both on "
                           f"{name}'s motor {'ABC'[stall.port]}: give one stall per motor")
        out.setdefault(name, []).append(stall)
    return out
