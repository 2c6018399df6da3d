"""Reading a PDDL domain and problem with unified-planning's reader, with errors located
like the C+ front end's (``file:line:col: error: ...``).

The reading itself is unified-planning's (:class:`unified_planning.io.PDDLReader`): this
module only checks, before and after it, what cplus can translate, and turns the reader's
complaints into :class:`PddlError` with a place in the file.
"""
from __future__ import annotations

import os
import re

from cplus.errors import InputError, Location, Source
from cplus.pddl.errors import PddlError

__all__ = ["PddlError", "SUPPORTED_REQUIREMENTS", "read_problem", "require_up"]


SUPPORTED_REQUIREMENTS = frozenset({
    ":strips", ":typing", ":negative-preconditions", ":disjunctive-preconditions", ":equality",
    ":existential-preconditions", ":universal-preconditions", ":quantified-preconditions",
    ":conditional-effects", ":adl", ":action-costs",
})
"""The requirements a domain may declare; any other is refused at its place, by name."""

_REFUSED_SECTIONS = {"(:derived": ":derived-predicates", "(:durative-action": ":durative-actions",
                     "(:process": ":time", "(:event": ":time", "(:constraints": ":constraints",
                     "(:functions": None}


def require_up():
    """unified-planning's PDDL reader, or a one-line error naming the extra to install."""
    try:
        from unified_planning.io import PDDLReader
    except ImportError:
        raise InputError("PDDL input needs unified-planning: install the 'up' extra "
                         "(pip install 'cplus[up]')") from None
    return PDDLReader


def _source(path: str) -> Source:
    try:
        with open(path, "rb") as fh:
            data = fh.read(8 * 1024 * 1024 + 1)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, not a PDDL file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if len(data) > 8 * 1024 * 1024:
        raise InputError(f"{path}: larger than 8 MiB: not read as PDDL")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a text file (byte {exc.start} is not UTF-8)") from None
    if "\0" in text:
        raise InputError(f"{path}: not a text file (it holds NUL bytes)")
    return Source(path, text)


def _code(text: str) -> str:
    """The text with PDDL comments blanked (offsets kept)."""
    return re.sub(r";[^\n]*", lambda m: " " * len(m.group()), text)


def _first_form(source: Source, what: str) -> None:
    """Refuse a file that is not a PDDL ``(define (WHAT ...`` at its first word."""
    code = _code(source.text)
    m = re.match(r"\s*", code)
    start = m.end() if m else 0
    if not re.match(r"\(\s*define\s*\(\s*" + what + r"\b", code[start:], re.IGNORECASE):
        loc = Location(source, start, min(len(code), start + 1))
        raise PddlError(f"not a PDDL {what}: expected '(define ({what} NAME)'", loc)


def _check_requirements(source: Source) -> None:
    code = _code(source.text).lower()
    m = re.search(r"\(\s*:requirements\b([^)]*)\)", code)
    if m:
        for r in re.finditer(r":[a-z0-9_-]+", m.group(1)):
            if r.group() not in SUPPORTED_REQUIREMENTS:
                at = m.start(1) + r.start()
                raise PddlError(f"requirement {r.group()} is not supported by cplus (supported: "
                                f"{' '.join(sorted(SUPPORTED_REQUIREMENTS))})", Location(source, at, at + len(r.group())))
    either = re.search(r"\(\s*either\b", code)
    if either:
        raise PddlError("'either' types are not read by unified-planning's PDDL reader, which cplus uses: "
                        "declare a common supertype instead", Location(source, either.start(), either.end()))
    for opener, requirement in _REFUSED_SECTIONS.items():
        for s in re.finditer(re.escape(opener) + r"\b", code):
            if opener == "(:functions":       # with :action-costs: total-cost and static costs (checked after reading)
                body = code[s.end():_matching(code, s.start())]
                names = re.findall(r"\(\s*([^\s()]+)", body)
                bad = [n for n in names if n != "total-cost"]
                if bad and not (m and ":action-costs" in m.group(1)):
                    at = s.start() + code[s.start():].find(bad[0])
                    raise PddlError(f"function '{bad[0]}' needs :numeric-fluents, which is not supported by cplus "
                                    "(only :action-costs' total-cost and static costs are)",
                                    Location(source, at, at + len(bad[0])))
                continue
            raise PddlError(f"{opener[1:]} needs {requirement}, which is not supported by cplus",
                            Location(source, s.start(), s.end()))


def _matching(code: str, start: int) -> int:
    depth = 0
    for i in range(start, len(code)):
        if code[i] == "(":
            depth += 1
        elif code[i] == ")":
            depth -= 1
            if depth == 0:
                return i
    return len(code)


def _name_of(source: Source, what: str) -> tuple[str, Location] | None:
    m = re.search(r"\(\s*" + what + r"\s+([^\s()]+)", _code(source.text), re.IGNORECASE)
    if not m:
        return None
    return m.group(1).lower(), Location(source, m.start(1), m.end(1))


def _located(exc: Exception, sources: list[Source]) -> PddlError:
    """unified-planning's complaint as a located error: pyparsing's exceptions carry a line and
    column; its SyntaxErrors sometimes name a line (``line N``) or quote the text at fault."""
    message = str(getattr(exc, "msg", None) or exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    line = getattr(exc, "lineno", None)
    col = getattr(exc, "col", None) or getattr(exc, "column", None)
    source = sources[-1]
    m = re.search(r"line:? (\d+),? col(?:umn)?:? (\d+)", message)
    if m and not isinstance(line, int):
        line, col = int(m.group(1)), int(m.group(2))
        message = message[:m.start()].rstrip(" .,:").removesuffix(". From") or message
    if isinstance(line, int) and isinstance(col, int):
        starts = [0] + [m.end() for m in re.finditer("\n", source.text)]
        at = starts[min(line, len(starts)) - 1] + col - 1
        return PddlError(message, Location(source, at, at + 1))
    for quoted in re.findall(r"'([^']{2,})'|\"([^\"]{2,})\"", message):
        word = (quoted[0] or quoted[1]).strip()
        for src in sources:
            at = src.text.lower().find(word.lower())
            if at >= 0:
                return PddlError(message, Location(src, at, at + len(word)))
    return PddlError(message, Location(source, 0, 1))


def read_problem(domain_path: str, problem_path: str):
    """The :class:`unified_planning.model.Problem` of a domain and problem file, checked.

    Raises:
        InputError: a file that is missing or not text; unified-planning not installed.
        PddlError: located: not PDDL, a syntax error, an unsupported requirement or
            construct, a problem whose ``:domain`` is not the domain's name.
    """
    reader_class = require_up()
    domain, problem = _source(domain_path), _source(problem_path)
    _first_form(domain, "domain")
    _first_form(problem, "problem")
    _check_requirements(domain)
    _check_requirements(problem)
    named = _name_of(domain, "domain")
    wanted = _name_of(problem, ":domain")
    if named and wanted and named[0] != wanted[0]:
        raise PddlError(f"this problem is for domain '{wanted[0]}', and {os.path.basename(domain_path)} "
                        f"defines domain '{named[0]}'", wanted[1])
    # PDDL lets a type and a predicate share a name (IPC 2000's schedule: temperature);
    # unified-planning refuses it unless its environment says otherwise. The global environment:
    # its reader builds forall variables there whatever environment it is given.
    from unified_planning.environment import get_environment
    env = get_environment()
    strict = env.error_used_name
    env.error_used_name = False
    import warnings
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")      # its warning of the shared name, pyparsing's deprecations
            try:
                reader_class().parse_problem_string(domain.text)
            except Exception as exc:  # noqa: BLE001 - every complaint of the reader is the file's
                raise _located(exc, [domain]) from None
            try:
                parsed = reader_class().parse_problem_string(domain.text, problem.text)
            except Exception as exc:  # noqa: BLE001
                raise _located(exc, [problem, domain]) from None
    finally:
        env.error_used_name = strict
    from cplus.pddl.translate import check_kind
    check_kind(parsed, Location(domain, 0, 1))
    return parsed


