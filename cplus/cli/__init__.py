"""The ``cplus`` command: one module per subcommand, each with ``build_parser()`` and
``main(args) -> int``.

This package maps results to exit codes (:mod:`cplus.cli.common` has the table) and is the only
place that prints for the user; nothing imports it.  Subcommand modules are imported only when
their command runs, so ``cplus plan`` does not pay for the robot stack.
"""
from __future__ import annotations

import gc
import importlib
import os
import sys
from collections.abc import MutableMapping

from cplus.cli.common import EXIT_INPUT, EXIT_OK, CliError

__all__ = ["COMMANDS", "main", "run"]

COMMANDS = {
    "plan": "answer the queries of a C+ file (CCALC's output, or JSON), or plan for a PDDL domain and problem",
    "translate": "write the C+ theory of a PDDL domain and problem",
    "ground": "write the CNF of one horizon in DIMACS form",
    "run": "the whole robot job: plan, refine, trajectory, execute, report, pictures",
    "execute": "run a trajectory file on NXT bricks (emulated when none is given)",
    "brick": "emulate an NXT brick on a pseudo-terminal",
    "online": "run a domain online on a robot: act, sense, observe events, re-plan (Legolog's loop)",
    "replay": "animate the log of an online run, cycle by cycle (GIF, or MP4 with ffmpeg)",
    "shell": "CCALC's interactive session: loadf, query, nmquery, sat, show, set, help (scriptable)",
    "serve": "serve goal requests on a domain (script, JSON-lines socket, ROS actionlib): plan, act, re-plan",
    "batch": "run many planning jobs (a job file or a folder of domains) on a process pool or on Ray",
}


def _usage() -> str:
    width = max(map(len, COMMANDS))
    lines = ["usage: cplus COMMAND [options]   (cplus COMMAND --help for its options)",
             "       cplus --version", "",
             "C+ planning in the style of CCALC, with trajectories for LEGO NXT arms.", "", "commands:"]
    lines += [f"  {name:<{width}}  {text}" for name, text in COMMANDS.items()]
    return "\n".join(lines) + "\n"


def version() -> str:
    """The installed package's version (the source tree's when it is not installed)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed
    try:
        return installed("cplus")
    except PackageNotFoundError:   # pragma: no cover - running from a bare source tree
        return "unknown"


_STOPPED_IN_ORDER = ("execute", "online", "run", "serve")
"""The commands whose SIGINT/SIGTERM is an orderly stop under a watchdog (:mod:`cplus.cli.signals`;
``serve``'s is :class:`cplus.cli.serve.Watchdog`): each honours ``CPLUS_STOP_GRACE``."""


def main(argv: list[str] | None = None, *, exiting: bool = False) -> int:
    """Run ``cplus`` with ``argv`` (default: the process's arguments); return the exit code.

    ``exiting``: the process ends right after (the console script), so the cyclic collector,
    off while the command runs, stays off. Switched back on, it would go through every
    object the command made at the next allocation: a tenth of a second of processor time
    after a robot job, over a second of wall time on a loaded machine, added to the 2 s in
    which a command stopped by a signal must end (:mod:`cplus.cli.signals`)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        (sys.stdout if argv else sys.stderr).write(_usage())
        return EXIT_OK if argv else EXIT_INPUT
    if argv[0] in ("-V", "--version"):
        print(f"cplus {version()}")
        return EXIT_OK
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"cplus: error: unknown command {name!r} (choose from {', '.join(COMMANDS)})", file=sys.stderr)
        return EXIT_INPUT
    from cplus.errors import CPlusError
    _closed_streams()
    # A planning command is a short process that allocates millions of small objects and
    # creates almost no reference cycles: the cyclic collector only costs time here.
    gc.disable()
    try:
        if name in _STOPPED_IN_ORDER:     # its environment variable, checked before any work
            from cplus.cli.signals import stop_grace
            stop_grace(f"cplus {name}")
        module = importlib.import_module(f"cplus.cli.{name}")
        try:
            args = module.build_parser().parse_args(rest)
        except CliError as exc:
            print(exc, file=sys.stderr)
            return EXIT_INPUT
        except SystemExit as exc:  # --help, --version
            return exc.code if isinstance(exc.code, int) else EXIT_OK
        code = module.main(args)
        sys.stdout.flush()        # a full disk or a closed stdout is found here, not at exit
        return code
    except CPlusError as exc:
        print(prefixed(exc.render(), name), file=sys.stderr)
        return EXIT_INPUT
    except CliError as exc:     # the command line's, found once the file is read (an unknown --query)
        print(exc, file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt as exc:
        from cplus.cli.signals import exit_code_of, reason_of
        print(f"cplus: {reason_of(exc)}", file=sys.stderr)
        return exit_code_of(exc)
    except RecursionError:   # the front end bounds nesting; this is the last line of defence
        print(f"cplus {name}: error: the input is nested too deeply to be processed", file=sys.stderr)
        return EXIT_INPUT
    except MemoryError:
        print(f"cplus {name}: error: out of memory: the problem is too large for this machine", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:
        _discard_stdout()
        return EXIT_OK
    except OSError as exc:
        if exc.filename is not None:      # a file the command did not expect to fail on
            print(f"cplus {name}: error: {exc.filename}: {exc.strerror or exc}", file=sys.stderr)
            return EXIT_INPUT
        # a write to standard output failed: a full disk (/dev/full), a closed stdout (>&-)
        _discard_stdout()
        print(f"cplus {name}: error: cannot write standard output: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_INPUT
    finally:
        if not exiting:
            gc.enable()


def prefixed(text: str, name: str) -> str:
    """A message of the library for the user: ``cplus NAME: error: ...`` when it is not
    located (a located one, ``file:line:col: error: ...``, names its place itself)."""
    for kind in ("error: ", "warning: "):
        if text.startswith(kind):
            return f"cplus {name}: {text}"
    return text


class _ClosedStream:
    """Standard output when the process started without one (``>&-``): a write fails as it
    would on the closed descriptor, so the command says so instead of losing its output."""

    def write(self, text: str) -> int:
        import errno
        raise OSError(errno.EBADF, "Bad file descriptor (standard output is closed)")

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False

    def fileno(self) -> int:
        import io
        raise io.UnsupportedOperation("standard output is closed")


def _closed_streams() -> None:
    """Standard output or error closed at start (``>&-``, ``2>&-``): Python leaves them None,
    and ``print(file=None)`` would then write to standard output.  The descriptors are held
    by ``/dev/null`` (so that no file opened later lands on 1 or 2 and receives output), a
    closed stderr discards the diagnostics, and a closed stdout fails the first write."""
    for fd, name in ((1, "stdout"), (2, "stderr")):
        if getattr(sys, name) is not None:
            continue
        try:
            null = os.open(os.devnull, os.O_WRONLY)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
        except OSError:  # pragma: no cover
            pass
        setattr(sys, name, _ClosedStream() if name == "stdout" else open(os.devnull, "w"))


def _discard_stdout() -> None:
    """Standard output that failed: later writes (and the flush at exit) go nowhere."""
    try:
        sys.stdout = open(os.devnull, "w")
    except OSError:  # pragma: no cover
        pass


def _one_blas_thread(environ: MutableMapping[str, str]) -> None:
    """Ask numpy's OpenBLAS for one thread unless the user chose a number.

    OpenBLAS starts a worker thread per core when numpy loads, and they spin waiting for work
    that never comes (the project's arrays are small): on a 2-core machine that is 45 ms of
    processor time, half of numpy's import, in every command of a robot task."""
    environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def run() -> None:  # pragma: no cover - the console script; tests call main()
    """Entry point of the ``cplus`` script: run, flush, and leave without tearing down the
    grounded theory object by object (a tenth of a second on large domains)."""
    _one_blas_thread(os.environ)     # before anything imports numpy
    code = main(exiting=True)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(code)
