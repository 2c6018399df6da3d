"""What every subcommand shares: exit codes, one-line usage errors, option types, printers.

Exit codes (the README's table):

==== ==================================================================================
0    done: every query has a solution, the job ran
1    no plan in a query's maxstep range (CCALC's "No solution" lines are printed); for
     ``execute``/``run``: the link or a brick failed; for ``online``: no plan from the observed
     state
2    bad input or usage: a located ``file:line:col: error:`` or a one-line message
3    an open maxstep range reached ``--max-horizon`` without a plan; ``online``: ``--max-cycles``
     came before the goal
4    a robot task has plans, and none is collision-free in the horizon range (proved)
5    a robot task's refinement gave up (``--max-iterations``) before a plan or a proof
6    ``online``: the world contradicted the model (an observation it cannot explain, a
     failed action)
7    ``online``: the observed state is ambiguous (the fluents left open are named)
8    ``online``: a robot was lost (a brick stopped answering)
9    ``--no-refine``: the plan shown is not collision-free
10   ``plan``: a ``maxstep :: any`` query's invariant proves that no plan of any length exists
11   ``plan``: a ``maxstep :: any`` query's invariant is wrong (a check failed: its
     counterexample is printed; nothing is proved)
12   ``plan --minimize``: a plan, but its optimality is not proved (``--time-limit`` or
     Ctrl-C came first; the bound is printed)
124  a second SIGINT/SIGTERM ended a command that moves robots at once (:mod:`cplus.cli.signals`)
130  interrupted (SIGINT)
143  SIGTERM (``online``, ``execute``, ``run``: the bricks stopped and the logs written first)
==== ==================================================================================
"""
from __future__ import annotations

import argparse
import math
import os
import sys

__all__ = ["EXIT_OK", "EXIT_NO_PLAN", "EXIT_LINK", "EXIT_INPUT", "EXIT_LIMIT", "EXIT_NO_SAFE_PLAN",
           "EXIT_GAVE_UP", "EXIT_NO_PLAN_PROVED", "EXIT_INVARIANT_WRONG", "EXIT_NOT_PROVED", "EXIT_CONTRADICTED",
           "EXIT_AMBIGUOUS", "EXIT_ROBOT_LOST", "EXIT_UNSAFE", "EXIT_INTERRUPTED", "CliError", "OneLineArgumentParser",
           "nonneg", "number", "positive", "positive_int", "externals", "checked", "query_label", "in_range", "nonempty", "time_scale", "action_seconds", "TIME_SCALE",
           "ACTION_TIME_MAX_S",
           "Warnings", "horizon_progress", "clear_progress", "query", "file_loc", "robot_exit_code"]

EXIT_OK = 0
EXIT_NO_PLAN = 1
EXIT_LINK = 1
EXIT_INPUT = 2
EXIT_LIMIT = 3
EXIT_NO_SAFE_PLAN = 4
EXIT_GAVE_UP = 5
EXIT_CONTRADICTED = 6
EXIT_AMBIGUOUS = 7
EXIT_ROBOT_LOST = 8
EXIT_UNSAFE = 9
EXIT_NO_PLAN_PROVED = 10
EXIT_INVARIANT_WRONG = 11
EXIT_NOT_PROVED = 12
EXIT_INTERRUPTED = 130


class CliError(Exception):
    """A usage error already phrased for the user (one line)."""


class OneLineArgumentParser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line and raises instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise CliError(f"{self.prog}: error: {message}{self._did_you_mean(message)}")

    def _did_you_mean(self, message: str) -> str:
        """`` (did you mean --minimize?)`` after an unknown flag close to one of this parser's."""
        if not message.startswith("unrecognized arguments: "):
            return ""
        import difflib
        flags = [f for f in self._option_string_actions if f.startswith("--")]
        for word in message.split(": ", 1)[1].split():
            if word.startswith("--"):
                match = difflib.get_close_matches(word.split("=", 1)[0], flags, n=1, cutoff=0.7)
                return f" (did you mean {match[0]}?)" if match else ""
        return ""

    def _get_formatter(self) -> argparse.HelpFormatter:
        """The help formatter, told the terminal's width: left to itself it imports shutil to
        ask (with bz2, lzma and more: 2 ms of every command's start-up, measured on tanks-200),
        and argparse makes one for every option it adds, though the width only matters when
        help is printed.  The width is found as ``shutil.get_terminal_size`` finds it."""
        return self.formatter_class(prog=self.prog, width=terminal_columns() - 2)  # type: ignore[call-arg]


def terminal_columns() -> int:
    """``$COLUMNS``, else the width of the terminal on standard output, else 80."""
    try:
        columns = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns or 80


def _integer(text: str, least: int, what: str) -> int:
    """``text`` as an integer >= ``least``; no integer and too small an integer are one error."""
    try:
        v = int(text)
    except ValueError:
        v = least - 1
    if v < least:
        raise argparse.ArgumentTypeError(f"expected a {what} integer, got '{text}'")
    return v


def nonneg(text: str) -> int:
    return _integer(text, 0, "non-negative")


def number(text: str) -> float:
    """``text`` as a float, or the one usage error every number option gives for anything else."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def positive(text: str) -> float:
    v = number(text)
    if not v > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError("must be finite")
    return v


def seconds(text: str) -> float:
    """A duration: a finite number of seconds, 0 allowed."""
    v = number(text)
    if not v >= 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected seconds >= 0, got {text!r}")
    return v


def positive_int(text: str) -> int:
    return _integer(text, 1, "positive")


def checked(check, kind: type = str):
    """An argparse type from a check of :mod:`cplus.options` (the job files' and the API's):
    the flag's text converted to ``kind``, then checked; its refusal is argparse's one line."""
    from cplus.options import OptionError, from_text
    parse = from_text(check, kind)

    def convert(text: str):
        try:
            return parse(text)
        except OptionError as exc:
            raise argparse.ArgumentTypeError(exc.message) from None
    convert.__name__ = parse.__name__
    return convert


def nonempty(text: str) -> str:
    """A file name: not empty (an empty one is not "absent")."""
    if not text:
        raise argparse.ArgumentTypeError("an empty file name")
    return text


def query_label(text: str) -> str:
    """A query label (``--query``, ``--goal``, ``--nmquery``): not empty."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a query label, got an empty one")
    return text


def in_range(lo: float, hi: float, unit: str, kind: type = float):
    """An argparse type: a ``kind`` number from ``lo`` to ``hi`` (``unit`` names it), refused
    with the range in one line otherwise (NaN and infinities included): a number the user
    typed is honoured or refused, never wrapped or clamped."""
    def convert(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be at least {lo:g} and at most {hi:g} {unit}, got {text!r}")
        return value
    convert.__name__ = kind.__name__
    return convert


TIME_SCALE = (0.001, 1000.0)
"""``--time-scale X`` of every command that runs emulated bricks (``execute``, ``run``,
``online``, ``serve``, ``brick``): from a thousandth of real time (a tick of 10 ms lasts 10 s)
to a thousand times faster (the emulation cannot keep up beyond); ``1e-300`` would stop the
clock and ``1e300`` overflow the brick's timers."""

time_scale = in_range(*TIME_SCALE, "times real time")

ACTION_TIME_MAX_S = 3600.0
"""The longest ``--action-time`` of a simulated robot (``cplus online --simulate``, ``cplus
serve``): an hour per action; more would only make the run wait without end."""

def action_seconds(text: str) -> float:
    """``--action-time``: seconds from 0 to :data:`ACTION_TIME_MAX_S` (``cplus online`` and
    ``cplus serve`` alike)."""
    value = seconds(text)
    if value > ACTION_TIME_MAX_S:
        raise argparse.ArgumentTypeError(f"at most {ACTION_TIME_MAX_S:g} seconds, got {text!r}")
    return value


def parse_bricks(items: list[str], prog: str) -> dict[str, str]:
    """``--brick NAME=PORT`` options as a mapping (each robot once).

    Raises:
        CliError: one line for the user.
    """
    ports: dict[str, str] = {}
    for item in items:
        name, sep, port = item.partition("=")
        if not sep or not name or not port:
            raise CliError(f"{prog}: error: --brick expects NAME=PORT, got {item!r}")
        if name in ports:
            raise CliError(f"{prog}: error: two --brick options for {name!r}")
        ports[name] = port
    return ports


def distinct_bricks(ports: dict[str, str], prog: str) -> dict[str, str]:
    """``ports`` when no device serves two robots (a trajectory streams to every brick at once).

    Raises:
        CliError: one line for the user.
    """
    seen: dict[str, str] = {}
    for name, port in ports.items():
        key = os.path.realpath(port)
        if key in seen:
            raise CliError(f"{prog}: error: --brick {seen[key]} and --brick {name} are both "
                           f"{port}: each robot needs its own brick")
        seen[key] = name
    return ports


def externals(files: list[str]):
    """The built-in externals plus those of every ``--extern FILE.py`` (loading them needs
    :mod:`inspect`, 3 ms of import: only when there are any)."""
    from cplus.resolve import BUILTIN_EXTERNALS
    ext = BUILTIN_EXTERNALS.copy()
    if files:
        from cplus.externals import load_extern_file
        for f in files:
            load_extern_file(f, ext)
    return ext


class Warnings:
    """Prints each diagnostic of a domain once, however often it is asked to."""

    def __init__(self) -> None:
        self.seen: set[int] = set()

    def __call__(self, diag) -> None:
        for d in diag.items:
            if id(d) not in self.seen:
                self.seen.add(id(d))
                print(d.render(), file=sys.stderr)


def horizon_progress(enabled: bool):
    """A per-horizon callback: a ``--stats`` line, or a transient counter on a terminal."""
    tty = sys.stderr.isatty()

    def on_horizon(st) -> None:
        if enabled:
            verdict = "solution" if st.satisfiable else "no solution"
            print(f"% maxstep {st.maxstep}: {st.variables} variables, {st.clauses} clauses, "
                  f"encode {st.encode_s:.3f} s, solve {st.solve_s:.3f} s: {verdict}", file=sys.stderr)
        elif tty:
            print(f"\r% maxstep {st.maxstep} ...", end="", file=sys.stderr, flush=True)
    return on_horizon


def clear_progress(enabled: bool) -> None:
    if not enabled and sys.stderr.isatty():
        print("\r\033[K", end="", file=sys.stderr, flush=True)


def query(domain, label: str, prog: str, nmquery: bool = False, refused: bool = False):
    """The query (``nmquery``: the nmquery) ``label`` of ``domain``. An unknown label is the
    command line's error, not the file's (no line of the file is wrong): one line naming the
    option and the labels there are.  A query of the file that could not be resolved raises
    its located error, or, with ``refused``, is returned with it (``cplus plan`` reports it when
    that query's turn comes and answers the others)."""
    from cplus.errors import QueryError
    spec = (domain.program.nmquery if nmquery else domain.program.query)(label)
    if spec is not None and spec.error is not None:
        if not refused:
            raise spec.error
        return spec
    try:
        return domain.nmquery(label) if nmquery else domain.query(label)
    except QueryError as exc:
        raise CliError(f"{prog}: error: {'--nmquery' if nmquery else '--query'} {label}: {exc.message}") from None


def scene_beside(domain_path: str) -> str | None:
    """The ``scene.toml`` beside a domain file, if there is one: it makes the file a robot
    task.  The rule of :func:`cplus.robot.offline.task.scene_beside`, here so that a command can
    tell a plain domain without importing the robot stack."""
    import os
    beside = os.path.join(os.path.dirname(os.path.abspath(domain_path)), "scene.toml")
    return beside if os.path.isfile(beside) else None


def file_loc(path: str):
    """The start of a file, for errors about the file as a whole (standard input is not read
    again: it has been read once already)."""
    from cplus.errors import Location, Source
    from cplus.load import STDIN, display_name, read_text
    if path == STDIN:
        return Location(Source(display_name(path), ""), 0, 0)
    return Location(Source(path, read_text(path)), 0, 0)


def robot_exit_code(status) -> int:
    """The exit code of a :class:`cplus.robot.RefineStatus`."""
    from cplus.robot import RefineStatus
    return {RefineStatus.FOUND: EXIT_OK, RefineStatus.UNSAFE: EXIT_UNSAFE, RefineStatus.NO_PLAN: EXIT_NO_PLAN,
            RefineStatus.HORIZON_LIMIT: EXIT_LIMIT, RefineStatus.NO_SAFE_PLAN: EXIT_NO_SAFE_PLAN,
            RefineStatus.GAVE_UP: EXIT_GAVE_UP}[status]
