"""``cplus brick``: run an emulated NXT brick on a pseudo-terminal.

Prints the path to open (a symlink that survives simulated disconnects) on
the first line of standard output, then serves until SIGINT or SIGTERM and
exits 0. Bad options give one line on standard error and exit code 2.

The brick runs the compiled ``cplus_follow.rxe`` on its bytecode interpreter
(compiled once by nbc and cached), or the program given with ``--program``;
without nbc it runs the Python model of the follower program and says so. A
program the brick aborts is reported on standard error, one line each.

Example::

    $ cplus brick --name r1 --drop 0.1 &
    /tmp/cplus-brick-r1-x8k2/tty
    $ cplus execute traj.json --brick r1=/tmp/cplus-brick-r1-x8k2/tty ...
"""
from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from dataclasses import replace

from cplus.cli.common import EXIT_INPUT, EXIT_LINK, EXIT_OK, CliError, OneLineArgumentParser
from nxt_link.emulator import (
    BrickEmulator,
    EmulatorConfig,
    FaultParams,
    LinkParams,
    compiled_follower,
)
from nxt_link.firmware import FirmwareParams
from nxt_link.motor_model import MotorParams
from nxt_link.pty_server import PtyBrickServer
from nxt_link.vm import NbcError, NbcMissingError, RxeError, load_rxe
from nxt_link.vm.flash import FILENAME_LENGTH

__all__ = ["build_parser", "config_from_args", "main"]


def _probability(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 <= value < 1.0:
        raise argparse.ArgumentTypeError(f"probability must be in [0, 1), got {text}")
    return value


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _positive_float(text: str) -> float:
    value = _non_negative(text)
    if value == 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text}")
    return value


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus brick",
        description="Emulate an NXT brick (firmware, bytecode interpreter running the compiled "
                    "cplus_follow program, motors) on a pseudo-terminal. Prints the device path "
                    "on the first line, serves until interrupted.")
    p.add_argument("--name", required=True, help="brick name, e.g. r1")
    p.add_argument("--link", metavar="PATH",
                   help="publish the pty as this symlink (default: a fresh temporary path)")
    p.add_argument("--drop", type=_probability, default=0.0, metavar="P",
                   help="drop each frame, either direction, with probability P")
    p.add_argument("--corrupt", type=_probability, default=0.0, metavar="P",
                   help="flip a byte in a reply frame or a MESSAGEWRITE payload with probability P")
    p.add_argument("--delay", type=_non_negative, default=0.0, metavar="MS",
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
    p.add_argument("--program", metavar="FILE.rxe", default=None,
                   help="run this compiled NXT program (put in the brick's flash under its file "
                        "name) instead of cplus_follow.rxe")
    p.add_argument("--time-scale", type=_positive_float, default=1.0, metavar="X",
                   help="run simulated time X times faster than real time (default 1)")
    p.add_argument("--battery-mv", type=_positive_int, default=9000, metavar="MV",
                   help="battery level reported, and motor supply voltage (default 9000)")
    p.add_argument("--backlash-deg", type=_non_negative, default=MotorParams().backlash_deg,
                   metavar="DEG", help="gear play of each motor, +-DEG (default 2)")
    p.add_argument("--verbose", "-v", action="count", default=0, help="log to stderr")
    return p


def config_from_args(args: argparse.Namespace) -> EmulatorConfig:
    """The emulator configuration the options describe (shared with ``cplus execute``)."""
    motors = MotorParams(supply_v=args.battery_mv / 1000.0, backlash_deg=args.backlash_deg)
    return EmulatorConfig(
        name=args.name,
        firmware=FirmwareParams(name=args.name[:14], battery_mv=args.battery_mv),
        motors=motors,
        link=LinkParams() if args.latency else LinkParams.instant(),
        faults=FaultParams(drop=args.drop, corrupt=args.corrupt, delay_ms=args.delay,
                           disconnect_after=args.disconnect_after, seed=args.seed),
        program_running=args.program_running,
        stale_frame_ms=250.0 * args.time_scale,
    )


def program_files(args: argparse.Namespace) -> tuple[dict[str, bytes], dict[str, str], str | None]:
    """The programs to put in flash, their symbol tables, and the one to start.

    ``--program FILE`` is checked here (a file the brick would refuse is a
    one-line error); otherwise ``cplus_follow.rxe`` is compiled (once, cached).
    Without nbc the files are empty and the follower's Python model runs: a
    note says so on standard error."""
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
    try:
        files, symbols = compiled_follower()
    except NbcMissingError:
        print("cplus brick: nbc not found: running the Python model of cplus_follow.nxc "
              "(nxt_link/follower_program.py) instead of the compiled program", file=sys.stderr)
        return {}, {}, None
    except NbcError as exc:
        print(f"cplus brick: {exc}; running the Python model of cplus_follow.nxc instead",
              file=sys.stderr)
        return {}, {}, None
    return files, symbols, None


def main(args: argparse.Namespace) -> int:
    """``cplus brick``; returns the exit code."""
    try:
        if not args.name or not args.name.isprintable() or "/" in args.name:
            raise CliError(f"cplus brick: error: invalid brick name {args.name!r}")
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
    return EXIT_OK
