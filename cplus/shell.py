"""CCALC's interactive session without the terminal: parse a command line, run it, return text.

``cplus shell`` (:mod:`cplus.cli.shell`) reads lines and prints; everything a command means is
here, so that it can be tested without a terminal and reused by anything that holds a session
(an editor, a notebook).  Nothing here prints, reads standard input or touches readline.

A command is a Prolog goal ending with ``.``, as CCALC reads it at its ``?-`` prompt:
``loadf 'file'.`` (or ``loadf(file).``), ``query 0.``, ``nmquery label.``, ``sat.``, ``show.``,
``show all.`` (``show SPEC.``: CCALC's show specifications for the queries after it),
``set(num, all).``, ``set(num, 3).``, ``set(solver, minisat22).``, ``show_parameters.``,
``help.``, ``help(query).``, ``halt.``.  Several goals may share a line (``query 0. query 1.``).
A misspelt command or parameter is answered with the nearest name (``qurey`` -> ``query``).

Nothing heavy is imported at module level: the shell starts in the time Python does, and the
planner is imported by the first ``loadf``.
"""
from __future__ import annotations

import difflib
import hashlib
import os
import time
from collections.abc import Callable, Iterator

__all__ = ["Command", "Reply", "Session", "ShellError", "parse_line", "COMMANDS", "HELP"]

COMMANDS = ("loadf", "query", "nmquery", "sat", "show", "set", "show_parameters", "help", "halt")
"""Every command name, in the order ``help.`` lists them (and completion offers them)."""

HELP = {
    "loadf": ("loadf 'FILE'.", "load a C+ file; it replaces the current theory (an unchanged file is "
              "reused, a changed one reloaded)"),
    "query": ("query LABEL.", "run the query LABEL of the current theory (CCALC's output; 'states': every state)"),
    "nmquery": ("nmquery LABEL.", "run the nmquery LABEL (its rules completed on their own; labels "
                "apart from the queries')"),
    "sat": ("sat.", "list the states of the current theory (CCALC's 'State k:')"),
    "show": ("show.  show SPEC.", "list the current theory's constants, its show/hide specification and its "
             "queries; with specifications (positive, negative, all, ab, none, patterns; ';' between), use them "
             "for the queries after it, in place of the file's (until the next loadf)"),
    "set": ("set(num, N).  set(num, all).  set(solver, S).",
            "how many solutions a query prints (default 1); the pysat solver (default glucose4)"),
    "show_parameters": ("show_parameters.", "print the values of num and solver"),
    "help": ("help.  help(COMMAND).", "this text; one command's"),
    "halt": ("halt.", "end the session (so does end of input)"),
}
"""CCALC's help topics for the commands this shell has: the form and one line on each."""


class ShellError(Exception):
    """A command the shell cannot run, with the column of the line it is about."""

    def __init__(self, message: str, col: int = 1) -> None:
        super().__init__(message)
        self.message = message
        self.col = col


class Command:
    """A parsed goal: its name, its arguments (strings; a quoted atom keeps no quotes) and the
    1-based column where it starts on its line (errors about it point there)."""

    __slots__ = ("name", "args", "col", "arg_cols")

    def __init__(self, name: str, args: tuple[str, ...], col: int, arg_cols: tuple[int, ...] = ()) -> None:
        self.name = name
        self.args = args
        self.col = col
        self.arg_cols = arg_cols or (col,) * len(args)

    def __repr__(self) -> str:
        return f"Command({self.name!r}, {self.args!r}, col={self.col})"


class Reply:
    """What running a command gives: text for standard output, text for standard error
    (warnings, located errors), whether it failed, and whether the session should end."""

    __slots__ = ("out", "err", "failed", "halt")

    def __init__(self, out: str = "", err: str = "", failed: bool = False, halt: bool = False) -> None:
        self.out = out
        self.err = err
        self.failed = failed
        self.halt = halt


# --- parsing ------------------------------------------------------------------------------

_PREFIX = ("loadf", "query", "nmquery", "help")
"""Commands CCALC declares as prefix operators: ``query 0.`` is ``query(0).``"""


def did_you_mean(word: str, names) -> str:
    """`` (did you mean 'x'?)`` for the name of ``names`` nearest to ``word``, or nothing."""
    near = difflib.get_close_matches(word, list(names), n=1, cutoff=0.6)
    return f" (did you mean '{near[0]}'?)" if near else ""


def _unknown_command(name: str, col: int, shown: str | None = None) -> ShellError:
    return ShellError(f"unknown command '{shown or name}'{did_you_mean(name, COMMANDS)} (commands: "
                      f"{', '.join(COMMANDS)}; help. lists them)", col)


def _show_spec(line: str, toks: list, i: int) -> tuple[str, int, int]:
    """The text of ``show SPEC.`` after ``show`` (one pair of enclosing parentheses taken off:
    ``show(all).``), its column, and the index of the token that ends the goal."""
    depth = 0
    j = i
    while j < len(toks):
        kind, text, _ = toks[j]
        if kind == "punct" and text in "([":
            depth += 1
        elif kind == "punct" and text in ")]":
            depth -= 1
        elif kind == "punct" and text == "." and depth <= 0:
            break
        j += 1
    start = toks[i][2]
    end = toks[j][2] if j < len(toks) else len(line.rstrip()) + 1
    raw = line[start - 1:end - 1].rstrip()
    if raw.startswith("(") and raw.endswith(")") and toks[i][:2] == ("punct", "(") and _closes_last(raw):
        raw, start = raw[1:-1], start + 1
    return raw, start, j


def _closes_last(raw: str) -> bool:
    """Whether the parenthesis opening ``raw`` is the one that closes it."""
    depth = 0
    for k, c in enumerate(raw):
        depth += c == "("
        depth -= c == ")"
        if depth == 0:
            return k == len(raw) - 1
    return False


def _tokens(line: str) -> Iterator[tuple[str, str, int]]:
    """(kind, text, column) for a command line: ``atom`` (a name, a number, a quoted atom),
    ``punct`` (``( ) , .``); ``%`` starts a comment, as in Prolog."""
    i, n = 0, len(line)
    while i < n:
        c = line[i]
        if c.isspace():
            i += 1
        elif c == "%":
            return
        elif c == "'" or c == '"':
            j = i + 1
            text = []
            while True:
                if j >= n:
                    raise ShellError("unterminated quoted atom", i + 1)
                if line[j] == c:
                    if j + 1 < n and line[j + 1] == c:   # '' inside quotes is one quote
                        text.append(c)
                        j += 2
                        continue
                    break
                text.append(line[j])
                j += 1
            yield "atom", "".join(text), i + 1
            i = j + 1
        elif c in "(),.[]":
            # a '.' inside a bare name (file.cp) is part of it: only '.' before a space/end ends
            yield "punct", c, i + 1
            i += 1
        else:
            j = i
            while j < n and not line[j].isspace() and line[j] not in "(),'\"%[]":
                if line[j] == "." and (j + 1 >= n or line[j + 1].isspace() or line[j + 1] == "%"):
                    break
                j += 1
            yield "atom", line[i:j], i + 1
            i = j


def parse_line(line: str) -> list[Command]:
    """The goals of one line, each ended by ``.``.

    Raises:
        ShellError: bad syntax (a goal without its ``.``, unbalanced parentheses), at its column.
    """
    toks = list(_tokens(line))
    commands: list[Command] = []
    i = 0
    while i < len(toks):
        kind, text, col = toks[i]
        if kind != "atom" or not text[:1].isalpha():
            raise ShellError(f"expected a command, found {text!r}", col)
        name, args, cols = text, [], []
        i += 1
        if name == "show" and i < len(toks) and toks[i][:2] != ("punct", "."):
            raw, at, i = _show_spec(line, toks, i)
            args.append(raw)
            cols.append(at)
        elif i < len(toks) and toks[i][:2] == ("punct", "("):
            i += 1
            while True:
                if i < len(toks) and toks[i][:2] == ("punct", "["):
                    raise ShellError("a list of files is not taken here: loadf one file at a time "
                                     "(each replaces the theory)", toks[i][2])
                if i >= len(toks) or toks[i][0] != "atom":
                    at = toks[i][2] if i < len(toks) else len(line) + 1
                    raise ShellError("expected an argument", at)
                args.append(toks[i][1])
                cols.append(toks[i][2])
                i += 1
                if i < len(toks) and toks[i][:2] == ("punct", ","):
                    i += 1
                    continue
                if i < len(toks) and toks[i][:2] == ("punct", ")"):
                    i += 1
                    break
                at = toks[i][2] if i < len(toks) else len(line) + 1
                raise ShellError("expected ',' or ')'", at)
        elif i < len(toks) and toks[i][0] == "atom" and name in _PREFIX:
            args.append(toks[i][1])
            cols.append(toks[i][2])
            i += 1
        elif i < len(toks) and toks[i][0] == "atom" and name not in COMMANDS:
            raise _unknown_command(name, col)     # `qurey on.`: the command is what is wrong
        if i >= len(toks) or toks[i][:2] != ("punct", "."):
            at = toks[i][2] if i < len(toks) else len(line.rstrip()) + 1
            found = f"found {toks[i][1]!r}" if i < len(toks) else "a command ends with '.'"
            raise ShellError(f"expected '.' after {name}: {found}", at)
        i += 1
        commands.append(Command(name, tuple(args), col, tuple(cols)))
    return commands


# --- the session ---------------------------------------------------------------------------

class _Loaded:
    """A loaded domain and the fingerprint of the files it was read from."""

    __slots__ = ("domain", "stamp", "show")

    def __init__(self, domain, stamp: tuple) -> None:
        self.domain = domain
        self.stamp = stamp
        self.show = (list(domain.program.show), domain.program.show_given)   # the file's own

    def restore_show(self) -> None:
        """The file's show specifications again (a ``show SPEC.`` lasts until the next loadf)."""
        self.domain.program.show, self.domain.program.show_given = list(self.show[0]), self.show[1]


def _stamp(files: list[str]) -> tuple:
    """What tells a changed domain: the size and a hash of each file it was read from (its
    includes too); an unreadable file is a change (the reload then reports it)."""
    out: list[tuple] = []
    for f in files:
        try:
            with open(f, "rb") as fh:
                data = fh.read()
        except OSError:
            out.append((f, None))
            continue
        out.append((f, len(data), hashlib.sha1(data).hexdigest()))
    return tuple(out)


class Session:
    """The state of a CCALC session: the domains loaded (by path), the current one, and the
    parameters ``num`` and ``solver``.

    ``run(line, lineno)`` parses and executes one line and returns a :class:`Reply`;
    ``execute(command)`` runs one parsed goal.  Errors never escape: each becomes a located
    line in ``Reply.err`` and the session goes on."""

    def __init__(self, source: str = "<stdin>", externals: Callable[[], object] | None = None) -> None:
        self.source = source
        self.num = 1                 # 0: all
        self.solver: str | None = None
        self.loaded: dict[str, _Loaded] = {}
        self.current: str | None = None
        self._externals = externals
        self._shown: dict[int, set[int]] = {}
        self._lineno = 1             # the line of the goal being run (for located warnings)

    # the names readline completes
    def labels(self) -> list[str]:
        """The current theory's query labels (and ``states``)."""
        d = self.domain
        return [] if d is None else [*d.labels, *(["states"] if "states" not in d.labels else [])]

    def nm_labels(self) -> list[str]:
        d = self.domain
        return [] if d is None else list(d.nm_labels)

    @property
    def domain(self):
        return None if self.current is None else self.loaded[self.current].domain

    def run(self, line: str, lineno: int = 1) -> Reply:
        """Parse and run every goal of ``line``; stops at ``halt.``."""
        try:
            commands = parse_line(line)
        except ShellError as exc:
            return Reply(err=self._located(lineno, exc), failed=True)
        out: list[str] = []          # joined once: a line of 8,000 goals stays linear
        err: list[str] = []
        reply = Reply()
        for cmd in commands:
            r = self.execute(cmd, lineno)
            out.append(r.out)
            err.append(r.err)
            reply.failed |= r.failed
            if r.halt:
                reply.halt = True
                break
        reply.out, reply.err = "".join(out), "".join(err)
        return reply

    def _located(self, lineno: int, exc: ShellError) -> str:
        return f"{self.source}:{lineno}:{exc.col}: error: {exc.message}\n"

    def execute(self, cmd: Command, lineno: int = 1) -> Reply:
        """Run one goal; a :class:`ShellError` or a domain's error becomes a located line."""
        from_domain = _domain_error()
        self._lineno = lineno
        handler = getattr(self, f"_cmd_{cmd.name}", None) if cmd.name in COMMANDS else None
        if handler is None:
            return Reply(err=self._located(lineno, _unknown_command(cmd.name, cmd.col, f"{cmd.name}/{len(cmd.args)}")),
                         failed=True)
        try:
            return handler(cmd)
        except ShellError as exc:
            return Reply(err=self._located(lineno, exc), failed=True)
        except from_domain as exc:
            if getattr(exc, "loc", None) is None:   # about the command (a missing file): locate it there
                at = cmd.arg_cols[0] if cmd.arg_cols else cmd.col
                return Reply(err=self._located(lineno, ShellError(str(exc), at)), failed=True)
            return Reply(err=exc.render() + "\n", failed=True)  # type: ignore[attr-defined]

    def _arity(self, cmd: Command, *allowed: int) -> None:
        if len(cmd.args) not in allowed:
            forms = HELP[cmd.name][0]
            raise ShellError(f"{cmd.name} takes {' or '.join(map(str, allowed))} argument"
                             f"{'s' if allowed != (1,) else ''}: {forms}", cmd.col)

    def _need_domain(self, cmd: Command):
        d = self.domain
        if d is None:
            raise ShellError(f"{cmd.name}: no theory loaded (loadf 'FILE'. first)", cmd.col)
        return d

    # --- the commands ---

    def _cmd_halt(self, cmd: Command) -> Reply:
        self._arity(cmd, 0)
        return Reply(halt=True)

    def _cmd_help(self, cmd: Command) -> Reply:
        self._arity(cmd, 0, 1)
        if cmd.args:
            topic = cmd.args[0]
            if topic not in HELP:
                raise ShellError(f"no help on '{topic}'{did_you_mean(topic, COMMANDS)} (topics: "
                                 f"{', '.join(COMMANDS)})", cmd.arg_cols[0])
            form, text = HELP[topic]
            return Reply(out=f"{form}\n    {text}\n")
        lines = ["Commands (each ends with '.', as in Prolog):"]
        for c in COMMANDS:
            lines += [f"  {HELP[c][0]}", f"      {HELP[c][1]}"]
        return Reply(out="\n".join(lines) + "\n")

    def _cmd_show_parameters(self, cmd: Command) -> Reply:
        self._arity(cmd, 0)
        return Reply(out=f"num = {self.num or 'all'}\nsolver = {self.solver or 'glucose4'}\n")

    def _cmd_set(self, cmd: Command) -> Reply:
        self._arity(cmd, 2)
        what, value = cmd.args
        if what == "num":
            if value == "all":
                self.num = 0
            elif value.isascii() and value.isdigit() and int(value) > 0:   # not '²': isdigit() alone takes it
                self.num = int(value)
            else:
                raise ShellError(f"set(num, N): N is a positive integer or 'all', not '{value}'", cmd.arg_cols[1])
            return Reply()
        if what == "solver":
            from cplus.sat.solver import solver_names
            names = solver_names()
            if value not in names:
                raise ShellError(f"unknown solver '{value}'{did_you_mean(value, names)} (pysat's: "
                                 f"{', '.join(names)})", cmd.arg_cols[1])
            self.solver = value
            return Reply()
        raise ShellError(f"unknown parameter '{what}'{did_you_mean(what, ('num', 'solver'))} (num, solver)",
                         cmd.arg_cols[0])

    def _cmd_loadf(self, cmd: Command) -> Reply:
        self._arity(cmd, 1)
        return self.load(cmd.args[0])

    def load(self, path: str) -> Reply:
        """Make ``path`` the current theory (CCALC's ``loadf``: it replaces the theory before);
        a file loaded before and unchanged since is reused, grounding and all."""
        from cplus.api import Domain
        key = os.path.abspath(path)
        old = self.loaded.get(key)
        note = f"% loading file {path}\n"
        if old is not None:
            if _stamp(old.domain.program.files or [key]) == old.stamp:
                self.current = key
                old.restore_show()
                return Reply(out=f"% {path} unchanged: reusing the loaded theory\n")
            note = f"% reloading {path} (changed)\n"
        t0 = time.perf_counter()
        externals = self._externals() if self._externals is not None else None
        domain = Domain.load(path, externals)  # type: ignore[arg-type]
        files = domain.program.files or [key]
        self.loaded[key] = _Loaded(domain, _stamp(files))
        self.current = key
        warnings = self._new_warnings(domain)
        queries = ", ".join(domain.labels) or "none"
        nm = f"; nmqueries: {', '.join(domain.nm_labels)}" if domain.nm_labels else ""
        return Reply(out=f"{note}% done ({time.perf_counter() - t0:.2f} s); queries: {queries}{nm}\n",
                     err=warnings)

    def _cmd_query(self, cmd: Command) -> Reply:
        self._arity(cmd, 1)
        return self._solve(cmd, cmd.args[0], nmquery=False)

    def _cmd_nmquery(self, cmd: Command) -> Reply:
        self._arity(cmd, 1)
        return self._solve(cmd, cmd.args[0], nmquery=True)

    def _cmd_sat(self, cmd: Command) -> Reply:
        self._arity(cmd, 0)
        return self._solve(cmd, "states", nmquery=False, every=True)

    def _solve(self, cmd: Command, label: str, nmquery: bool, every: bool = False) -> Reply:
        """The text ``cplus plan --query LABEL -n NUM`` prints (``--nmquery``; ``sat``: every state)."""
        from cplus.errors import QueryError
        from cplus.sat.solver import DEFAULT_SOLVER
        domain = self._need_domain(cmd)
        try:
            q = domain.spec(label, nmquery)
        except QueryError as exc:
            raise ShellError(exc.message.replace("--nmquery", "nmquery " + label + "."),
                             cmd.arg_cols[0] if cmd.args else cmd.col) from None
        if q.invariant is not None:
            return Reply(out=domain.format_proof(domain.prove(label, self.solver)))
        wanted = 0 if every else self.num
        result = domain.solve(label, wanted, self.solver or DEFAULT_SOLVER, nmquery=nmquery)
        if every:       # CCALC's sat: the states, each headed `State k:` when there are several
            from cplus.output import Display, format_result
            text = format_result(Display(domain.program), result.failed, result.histories, None, heading="State")
            return Reply(out="% Displaying possible states:\n" + text, err=self._new_warnings(domain))
        return Reply(out=domain.format(result), err=self._new_warnings(domain))

    def _new_warnings(self, domain) -> str:
        """The domain's diagnostics not shown yet (grounding adds some), each rendered once."""
        seen = self._shown.setdefault(id(domain), set())
        fresh = [d for d in domain.diagnostics.items if id(d) not in seen]
        seen.update(id(d) for d in fresh)
        return "".join(d.render() + "\n" for d in fresh)

    def _cmd_show(self, cmd: Command) -> Reply:
        """``show.`` lists the theory; ``show SPEC.`` replaces its show specifications for the
        queries after it, as CCALC's ``show/1`` does (CCALC's bare ``show.`` prompts for
        specifications instead: a line-based session lists, docs/shell.md)."""
        self._arity(cmd, 0, 1)
        domain = self._need_domain(cmd)
        if not cmd.args:
            return Reply(out=describe(domain))
        from cplus.errors import CPlusError, Diagnostics
        from cplus.resolve.show import resolve_show
        diagnostics = Diagnostics()
        offset = len(":- show ")
        try:
            specs = resolve_show(domain.program, cmd.args[0], diagnostics)
        except CPlusError as exc:
            at = cmd.arg_cols[0] + max(0, (exc.loc.start - offset) if exc.loc is not None else 0)
            raise ShellError(exc.message, at) from None
        domain.program.show, domain.program.show_given = specs, True
        warnings = "".join(f"{self.source}:{self._lineno}:"
                           f"{cmd.arg_cols[0] + max(0, d.loc.start - offset) if d.loc else cmd.col}"
                           f": warning: {d.message}\n" for d in diagnostics.items)
        shown = ", ".join(s if isinstance(s, str) else _pattern_text(s) for s in specs) or "nothing"
        return Reply(out=f"% show: {shown}\n", err=warnings)


def _domain_error() -> type[Exception]:
    """The domain's error class, imported only once something may have raised it (so that an
    unknown command does not import the planner)."""
    import sys
    errors = sys.modules.get("cplus.errors")
    if errors is None:
        return _NeverRaised
    return errors.CPlusError


class _NeverRaised(Exception):
    """Stands for the domain's errors before the planner is imported (none can be raised)."""


def describe(domain) -> str:
    """``show.``: the theory's constants with their declarations, its show/hide specification
    and its queries, as comment lines (so that a script's output stays parseable)."""
    prog = domain.program
    lines = [f"% {domain.path}"]
    decls = sorted((d for d in prog.signature.constants.values() if not d.hidden and not d.auto_ab),
                   key=lambda d: d.order)
    for d in decls:
        args = f"({','.join(map(str, d.argsorts))})" if d.argsorts else ""
        dom = str(d.domain)
        kind = d.kind if dom == "boolean" else f"{d.kind}({dom})"
        lines.append(f"  {d.name}{args} :: {kind}")
    show = [s if isinstance(s, str) else _pattern_text(s) for s in prog.show] or ["positive"]
    lines.append(f"% show: {', '.join(show)}")
    if prog.hide_all:
        lines.append("% hide: all")
    elif prog.hide:
        lines.append(f"% hide: {', '.join(map(_pattern_text, prog.hide))}")
    lines.append(f"% queries: {', '.join(domain.labels) or 'none'}")
    if domain.nm_labels:
        lines.append(f"% nmqueries: {', '.join(domain.nm_labels)}")
    return "\n".join(lines) + "\n"


def _pattern_text(p) -> str:
    """A show/hide pattern as written: ``loc(B)=table``, ``-on``, ``loc``."""
    from cplus.signature import render_value

    def term(v) -> str:
        name = getattr(v, "name", None)
        return name if isinstance(name, str) and hasattr(v, "sort") else render_value(v)
    text = p.name + (f"({','.join(term(a) for a in p.args)})" if p.args else "")
    if p.value is not None:
        text += f"={term(p.value)}"
    text = ("-" if p.negated else "") + text
    return text if p.step is None else f"{p.step}: {text}"
