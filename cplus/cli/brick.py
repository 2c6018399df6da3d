"""``cplus brick``: run an emulated NXT brick on a pseudo-terminal.

Prints the path to open (a symlink that survives simulated disconnects) on
the first line of standard output, then serves until SIGINT or SIGTERM and
exits 0. Bad options give one line on standard error and exit code 2; a bad
world file a located ``file:line:col: error:``.

With ``--world world.toml`` the brick is Legolog's delivery robot: the compiled
``cplus_legolog.rxe`` behaviour program runs and the robot drives on the world's
track, which its light and touch sensors read. Each line on standard input presses
the touch sensor (``press`` or an empty line: 0.3 s; ``press 1.5``: 1.5 s), and so
does SIGUSR1 (0.3 s).
``--stall PORT@SECONDS[+DURATION]`` holds a motor still mid-trajectory.

The brick runs the compiled ``cplus_follow.rxe`` on its bytecode interpreter
(compiled once by nbc and cached), or the program given with ``--program``;
without nbc it runs the Python model of the follower program and says so. A
program the brick aborts is reported on standard error, one line each.

Example::

    $ cplus brick --name r1 --drop 0.1 &
    /tmp/cplus-brick-r1-x8k2/tty
    $ cplus execute traj.json --brick r1=/tmp/cplus-brick-r1-x8k2/tty ...
    $ cplus brick --name robot --world domains/delivery/world.toml
"""
from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import sys
import threading
from dataclasses import replace

from cplus.cli.common import (
    EXIT_INPUT,
    EXIT_LINK,
    EXIT_OK,
    TIME_SCALE,
    CliError,
    OneLineArgumentParser,
    in_range,
    nonempty,
    number,
    time_scale,
)
from nxt_link.emulator.emulator import (
    BrickEmulator,
    EmulatorConfig,
    FaultParams,
    LinkParams,
    compiled_follower,
    compiled_legolog,
)
from nxt_link.emulator.firmware import FirmwareParams
from nxt_link.emulator.motor_model import MotorParams
from nxt_link.emulator.pty_server import PtyBrickServer
from nxt_link.emulator.stall import Stall
from nxt_link.emulator.vm import NbcError, NbcMissingError, RxeError, load_rxe
from nxt_link.emulator.vm.flash import FILENAME_LENGTH
from nxt_link.emulator.world import World

__all__ = ["build_parser", "config_from_args", "main"]


def _probability(text: str) -> float:
    value = number(text)
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"probability must be in [0, 1), got {text}")
    return value


BATTERY_MV = (1000, 12000)
"""``--battery-mv``: what an NXT's six cells or its rechargeable pack can give, with margin
(GETBATTERYLEVEL answers in an unsigned 16-bit field, and the motors run on this voltage)."""

BACKLASH_DEG = (0.0, 45.0)
"""``--backlash-deg``: gear play of a motor, up to an eighth of a turn."""

DELAY_MS = (0.0, 10000.0)
"""``--delay``: added one-way delay of a frame, up to 10 s (the client gives a brick up after
10 s without a valid answer)."""


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text}")
    return value


def _stall(text: str) -> Stall:
    try:
        return Stall.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus brick",
        description="Emulate an NXT brick (firmware, bytecode interpreter running the compiled "
                    "cplus_follow program, motors) on a pseudo-terminal; with --world, a delivery "
                    "robot running the cplus_legolog behaviour program on a line track. Prints "
                    "the device path on the first line, serves until interrupted.")
    p.add_argument("--name", required=True, help="brick name, e.g. r1")
    p.add_argument("--link", type=nonempty, metavar="PATH",
                   help="publish the pty as this symlink (default: a fresh temporary path)")
    p.add_argument("--drop", type=_probability, default=0.0, metavar="P",
                   help="drop each frame, either direction, with probability P")
    p.add_argument("--corrupt", type=_probability, default=0.0, metavar="P",
                   help="flip a byte in a reply frame or a MESSAGEWRITE payload with probability P")
    p.add_argument("--delay", type=in_range(*DELAY_MS, "milliseconds"), default=0.0, metavar="MS",
                   help="add MS milliseconds to every frame's one-way delay")
    p.add_argument("--disconnect-after", type=_positive_int, default=None, metavar="N",
                   help="drop the link once after N received frames (reopen the path to "
                        "reconnect)")
    p.add_argument("--seed", type=int, default=None, help="random seed of the fault injection")
    latency = p.add_mutually_exclusive_group()
    latency.add_argument("--latency", dest="latency", action="store_true", default=True,
                         help="model Bluetooth timing: 15+-5 ms one way, 30 ms turnaround, "
                              "rare stalls (default)")
    latency.add_argument("--no-latency", dest="latency", action="store_false",
                         help="answer at once (tests)")
    program = p.add_mutually_exclusive_group()
    program.add_argument("--program-running", dest="program_running", action="store_true",
                         default=True,
                         help="the program runs from power-on (default)")
    program.add_argument("--no-program", dest="program_running", action="store_false",
                         help="no program runs; the client must STARTPROGRAM it")
    p.add_argument("--program", type=nonempty, metavar="FILE.rxe", default=None,
                   help="run this compiled NXT program (put in the brick's flash under its file "
                        "name) instead of cplus_follow.rxe")
    p.add_argument("--time-scale", type=time_scale, default=1.0, metavar="X",
                   help="run simulated time X times faster than real time (default 1)")
    p.add_argument("--battery-mv", type=in_range(*BATTERY_MV, "millivolts", int), default=9000, metavar="MV",
                   help=f"battery level reported, and motor supply voltage ({BATTERY_MV[0]}..{BATTERY_MV[1]}, "
                        "default 9000)")
    p.add_argument("--backlash-deg", type=in_range(*BACKLASH_DEG, "degrees"), default=MotorParams().backlash_deg,
                   metavar="DEG", help=f"gear play of each motor, +-DEG (at most {BACKLASH_DEG[1]:g}, default 2)")
    p.add_argument("--world", type=nonempty, metavar="WORLD.toml",
                   help="a delivery robot on this track (cplus.world/1): the cplus_legolog "
                        "behaviour program runs; lines on stdin press the touch sensor")
    p.add_argument("--stall", type=_stall, action="append", default=[],
                   metavar="PORT@SECONDS[+DURATION]",
                   help="hold the motor on PORT (A, B, C) still from SECONDS after it first "
                        "turned, for DURATION seconds or for good (repeatable)")
    p.add_argument("--verbose", "-v", action="count", default=0, help="log to stderr")
    return p


def config_from_args(args: argparse.Namespace) -> EmulatorConfig:
    """The emulator configuration the options describe (shared with ``cplus execute``).

    Raises:
        WorldFileError: the ``--world`` file is bad (located).
    """
    for option, value, (lo, hi) in (("--battery-mv", args.battery_mv, BATTERY_MV),
                                    ("--backlash-deg", args.backlash_deg, BACKLASH_DEG),
                                    ("--delay", args.delay, DELAY_MS), ("--time-scale", args.time_scale, TIME_SCALE)):
        if not lo <= value <= hi:        # a Namespace built by a caller, not by the parser
            raise ValueError(f"{option} {value}: must be at least {lo:g} and at most {hi:g}")
    motors = MotorParams(supply_v=args.battery_mv / 1000.0, backlash_deg=args.backlash_deg)
    world = None
    if getattr(args, "world", None):
        from cplus.robot.online.world_file import load_world

        world = load_world(args.world)
    return EmulatorConfig(
        name=args.name,
        firmware=FirmwareParams(name=args.name[:14], battery_mv=args.battery_mv),
        motors=motors,
        link=LinkParams() if args.latency else LinkParams.instant(),
        faults=FaultParams(drop=args.drop, corrupt=args.corrupt, delay_ms=args.delay,
                           disconnect_after=args.disconnect_after, seed=args.seed),
        program_running=args.program_running,
        stale_frame_ms=250.0 * args.time_scale,
        world=world,
        stalls=tuple(getattr(args, "stall", ())),
    )


def program_files(args: argparse.Namespace) -> tuple[dict[str, bytes], dict[str, str], str | None]:
    """The programs to put in flash, their symbol tables, and the one to start.

    ``--program FILE`` is checked here (a file the brick would refuse is a
    one-line error); otherwise ``cplus_follow.rxe`` (with ``--world``:
    ``cplus_legolog.rxe``) is compiled (once, cached). Without nbc the files are
    empty and the program's Python model runs: a note says so on standard error."""
    path = getattr(args, "program", None)
    if path:
        name = os.path.basename(path)
        if len(name) > FILENAME_LENGTH:
            raise CliError(f"cplus brick: error: {name}: the brick's file names have at most "
                           f"{FILENAME_LENGTH} characters")
        try:
            with open(path, "rb") as fh:
                data = fh.read()
        except OSError as exc:
            raise CliError(f"cplus brick: error: cannot read {path}: {exc.strerror}") from None
        try:
            load_rxe(data, name)
        except RxeError as exc:
            raise CliError(f"cplus brick: error: {exc}") from None
        return {name: data}, {}, name
    world = bool(getattr(args, "world", None))
    source, model = (("cplus_legolog.nxc", "legolog_program.py") if world
                     else ("cplus_follow.nxc", "follower_program.py"))
    try:
        files, symbols = compiled_legolog() if world else compiled_follower()
    except NbcMissingError:
        print(f"cplus brick: nbc not found: running the Python model of {source} "
              f"(nxt_link/{model}) instead of the compiled program", file=sys.stderr)
        return {}, {}, None
    except NbcError as exc:
        print(f"cplus brick: {exc}; running the Python model of {source} instead",
              file=sys.stderr)
        return {}, {}, None
    return files, symbols, None


def main(args: argparse.Namespace) -> int:
    """``cplus brick``; returns the exit code."""
    try:
        if not args.name or not args.name.isprintable() or "/" in args.name:
            raise CliError(f"cplus brick: error: invalid brick name {args.name!r}")
        problem = link_problem(args.link)        # before the world is read and the program compiled
        if problem is not None:
            raise CliError(f"cplus brick: error: --link {args.link}: {problem}")
        config = config_from_args(args)
        files, symbols, start = program_files(args)
        config = replace(config, flash_files=files, symbols=symbols,
                         start_program=start or config.start_program)
    except CliError as exc:
        print(exc, file=sys.stderr)
        return EXIT_INPUT
    except ValueError as exc:
        print(f"cplus brick: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    if args.verbose:
        logging.basicConfig(level=logging.DEBUG if args.verbose > 1 else logging.INFO,
                            format="%(relativeCreated)8.0f %(name)s %(message)s")
    server = PtyBrickServer(BrickEmulator(config), link_path=args.link,
                            time_scale=args.time_scale)
    try:
        path = server.start()
    except OSError as exc:
        print(f"cplus brick: error: cannot publish the pty at {args.link}: {exc.strerror}",
              file=sys.stderr)
        return EXIT_LINK
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set())
                for sig in (signal.SIGINT, signal.SIGTERM)}
    world = server.emulator.world
    if world is not None:
        press = world.press
        previous[signal.SIGUSR1] = signal.signal(signal.SIGUSR1, lambda *_: press(0.3))
        if _stdin_readable():
            threading.Thread(target=_presses_from_stdin, args=(world,), name="presses",
                             daemon=True).start()
    try:
        print(path, flush=True)
        reported = 0
        errors = server.emulator.firmware.program_errors
        while not stop.wait(0.2):
            if server.error is not None:
                print(f"cplus brick: error: emulator stopped: {server.error}", file=sys.stderr)
                return EXIT_LINK
            while reported < len(errors):
                print(f"cplus brick: {args.name}: {errors[reported]}", file=sys.stderr,
                      flush=True)
                reported += 1
    finally:
        server.stop()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    stats = server.emulator.stats
    print(f"cplus brick: {args.name}: {stats.frames_in} frames in, {stats.frames_out} out, "
          f"dropped {stats.dropped_in}/{stats.dropped_out}, corrupted "
          f"{stats.corrupted_in}/{stats.corrupted_out}, {stats.disconnects} disconnect(s)",
          file=sys.stderr)
    if world is not None:
        near = world.nearest_landmark()
        print(f"cplus brick: {args.name}: robot at {world.position_mm:.0f} mm"
              f"{f' (landmark {near})' if near else ''}, {world.distance_mm:.0f} mm driven, "
              f"{world.presses} press(es), stuck {world.stuck_contacts()} time(s)",
              file=sys.stderr)
    for schedule in server.emulator.stalls:
        state = "never (the motor did not turn)" if schedule.moved_at_ms is None else \
            "not reached" if schedule.started_at_ms is None else \
            f"at {schedule.started_at_ms / 1000:.2f} s"
        print(f"cplus brick: {args.name}: stall {schedule.stall}: {state}", file=sys.stderr)
    return EXIT_OK


def link_problem(path: str | None) -> str | None:
    """Why the pty cannot be published at ``path``, or None. The link replaces only what a
    brick left there: nothing, or a symlink to a pseudo-terminal that is gone (a brick killed
    before it could clean up). A file, a directory, any other link, or the link of a pty that
    still exists (a brick serving there) is refused: publishing would replace it, and the exit
    would delete it."""
    if path is None:
        return None
    if not os.path.lexists(path):
        from cplus.cli.paths import output_problem
        return output_problem(path)     # its folder exists, and a link can be made there
    if os.path.islink(path):
        target = os.readlink(path)
        if target.startswith("/dev/pts/"):
            if not os.path.exists(target):
                return None
            return (f"it is the link of {target}, a pty in use (a brick serving there?): stop that brick, or "
                    "remove the link if none is, or choose another path")
        return f"it is a symlink to {target}, not a brick's link: choose another path, or remove it"
    what = "a directory" if os.path.isdir(path) else "a file"
    return f"it exists ({what}) and would be replaced: choose another path, or remove it"


def _stdin_readable() -> bool:
    """Standard input can be read without stopping the process: not a terminal (a pipe,
    a file), or a terminal this process has in the foreground (a background job reading
    its terminal would be stopped by SIGTTIN)."""
    try:
        fd = sys.stdin.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    if not os.isatty(fd):
        return True
    try:
        return os.tcgetpgrp(fd) == os.getpgrp()
    except OSError:
        return False


def _presses_from_stdin(world: World) -> None:
    """Each line on standard input presses the touch sensor: ``press [SECONDS]`` or an empty
    line (0.3 s). Anything else, a hold that is not a number in (0, 60] s (``press nan``), a
    line that is not UTF-8 or longer than 4 KiB, is refused with one line naming it, and the
    reader goes on."""
    raw = getattr(sys.stdin, "buffer", None)
    read = raw.readline if raw is not None else sys.stdin.readline
    number = 0
    while True:
        try:
            chunk = read(4097)
        except (OSError, ValueError):
            return
        if not chunk:
            return
        number += 1
        text = chunk.decode("utf-8", errors="replace") if isinstance(chunk, bytes) else chunk
        if len(chunk) > 4096 and not text.endswith("\n"):
            _skip_line(read)
            _ignored(number, "longer than 4096 characters")
            continue
        hold, problem = press_hold(text)
        if hold is None:
            _ignored(number, problem)
            continue
        world.press(hold)
        print(f"cplus brick: touch sensor pressed for {hold:g} s", file=sys.stderr, flush=True)


def press_hold(line: str) -> tuple[float | None, str]:
    """How long a line of standard input holds the touch sensor, or None and why not."""
    from nxt_link.emulator.world import MAX_PRESS_S
    words = line.split()
    if not words or words == ["press"]:
        return 0.3, ""
    if words[0] != "press" or len(words) != 2:
        return None, f"{line.strip()[:40]!r}: write 'press' or 'press SECONDS' (or an empty line)"
    try:
        hold = float(words[1])
    except ValueError:
        hold = math.nan
    if not 0 < hold <= MAX_PRESS_S:
        return None, f"{line.strip()[:40]!r}: a press lasts more than 0 and at most {MAX_PRESS_S:g} s"
    return hold, ""


def _skip_line(read) -> None:
    while True:
        more = read(4097)
        if not more or (more.endswith(b"\n") if isinstance(more, bytes) else more.endswith("\n")):
            return


def _ignored(number: int, why: str) -> None:
    print(f"cplus brick: ignored standard input line {number}: {why}", file=sys.stderr, flush=True)
