"""``cplus shell [FILE ...]``: CCALC's interactive session (``loadf``, ``query``, ``sat``, ...).

The commands themselves are :mod:`cplus.shell` (no I/O); this module is the edge: it reads
lines (through readline, with history and completion, when standard input is a terminal;
plainly when it is a script or a pipe), prints the replies, and handles Ctrl-C: at the prompt
it cancels the line, during a query it interrupts that query only.

Exit code: 0; when standard input is not a terminal, 2 if any command failed (so that a script
of commands can be checked like a compiler's input).  At a terminal a failed command is just
an answer: the session's exit is 0.
"""
from __future__ import annotations

import argparse
import os
import sys

from cplus.cli.common import EXIT_INPUT, EXIT_OK, OneLineArgumentParser, nonempty

__all__ = ["build_parser", "main", "history_path", "Completer"]

PROMPT = "?- "
"""The prompt of CCALC's Prolog top level."""


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(
        prog="cplus shell", description="CCALC's interactive session: loadf, query, nmquery, sat, show, set, help.",
        epilog="Commands end with '.' (as in Prolog); 'help.' lists them. Scriptable from standard input.")
    p.add_argument("files", nargs="*", metavar="FILE", help="C+ files to loadf first (the last is the current theory)")
    p.add_argument("--extern", type=nonempty, action="append", default=[], metavar="FILE.py",
                   help="a Python file whose functions are external predicates/functions")
    return p


def history_path(environ=os.environ) -> str:
    """``$XDG_CACHE_HOME/cplus/shell_history``, else ``~/.cache/cplus/shell_history``."""
    base = environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "cplus", "shell_history")


class Completer:
    """readline's completer: command names at the start of a goal, the current theory's query
    labels after ``query``, its nmquery labels after ``nmquery``, topics after ``help(``."""

    def __init__(self, session) -> None:
        self.session = session
        self.matches: list[str] = []

    def candidates(self, before: str, word: str) -> list[str]:
        """What may complete ``word``, given the text of the line before it."""
        from cplus.shell import COMMANDS
        head = before.rstrip().rsplit(".", 1)[-1].strip().rstrip("(").strip()
        if head == "query":
            pool = self.session.labels()
        elif head == "nmquery":
            pool = self.session.nm_labels()
        elif head == "help":
            pool = list(COMMANDS)
        elif head in ("", ):
            pool = list(COMMANDS)
        else:
            pool = []
        return [c for c in pool if c.startswith(word)]

    def __call__(self, text: str, state: int) -> str | None:
        if state == 0:
            import readline
            line = readline.get_line_buffer()
            before = line[:readline.get_begidx()]
            self.matches = self.candidates(before, text)
        return self.matches[state] if state < len(self.matches) else None


def _setup_readline(session):
    """readline with history and completion; None when it is not available."""
    try:
        import readline
    except ImportError:   # pragma: no cover - a Python built without it
        return None
    path = history_path()
    try:
        readline.read_history_file(path)
    except OSError:
        pass
    readline.set_completer(Completer(session))
    readline.set_completer_delims(" \t\n().,'")
    if "libedit" in (readline.__doc__ or ""):   # pragma: no cover - macOS
        readline.parse_and_bind("bind ^I rl_complete")
    else:
        readline.parse_and_bind("tab: complete")
    return readline, path


def _save_history(rl) -> None:
    if rl is None:
        return
    readline, path = rl
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        readline.set_history_length(1000)
        readline.write_history_file(path)
    except OSError as exc:
        print(f"% history not saved: {exc}", file=sys.stderr)


def _emit(reply) -> None:
    if reply.out:
        sys.stdout.write(reply.out)
        sys.stdout.flush()
    if reply.err:
        sys.stderr.write(reply.err)
        sys.stderr.flush()


def main(args: argparse.Namespace) -> int:
    from cplus.shell import Reply, Session

    extern_files = list(args.extern)

    def externals():
        from cplus.cli.common import externals as load_externals
        return load_externals(extern_files)

    session = Session(externals=externals if extern_files else None)
    failed = False
    for path in args.files:   # CCALC's loadf of each: the last one is the current theory
        reply = session.run(f"loadf {_quoted(path)}.", 0)
        _emit(reply)
        failed |= reply.failed
    interactive = sys.stdin.isatty()
    rl = _setup_readline(session) if interactive else None
    lineno = 0
    try:
        while True:
            try:
                line = input(PROMPT) if interactive else sys.stdin.readline()
            except KeyboardInterrupt:   # Ctrl-C at the prompt: cancel the line
                print()
                continue
            except EOFError:
                if interactive:
                    print()
                break
            if not interactive and not line:
                break
            lineno += 1
            try:
                reply = session.run(line.rstrip("\n"), lineno)
            except KeyboardInterrupt:   # Ctrl-C during a query: that query only
                reply = Reply(err="% interrupted\n")
            _emit(reply)
            failed |= reply.failed
            if reply.halt:
                break
    finally:
        _save_history(rl)
    return EXIT_INPUT if failed and not interactive else EXIT_OK


def _quoted(path: str) -> str:
    """``path`` as a Prolog quoted atom (a quote inside is doubled)."""
    return "'" + path.replace("'", "''") + "'"
