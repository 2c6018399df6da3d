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
    ":conditional-effects", ":adl", ":action-costs", ":derived-predicates",
})
"""The requirements a domain may declare; any other is refused at its place, by name."""

_REFUSED_SECTIONS = {"(:durative-action": ":durative-actions",
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


_STAND_IN = "cplus-derived-rule-"


class _DerivedText:
    """The ``(:derived (NAME ?x - t ...) CONDITION)`` sections of a domain, for
    unified-planning's reader, which has no derived predicates: each section is blanked
    (offsets kept) and its head's parameters and its condition, copied verbatim, become a
    stand-in action ``(:action cplus-derived-rule-N :parameters (...) :precondition CONDITION
    :effect (and))`` before the domain's last parenthesis, so that the reader parses the
    condition (nothing here reads PDDL beyond finding the parentheses). ``:derived-predicates``
    is blanked from the requirements, which the reader does not know. Errors the reader finds
    in the copied text are mapped back to the section (:meth:`relocate`)."""

    def __init__(self, source: Source) -> None:
        self.source = source
        code = _code(source.text)
        low = code.lower()
        text = list(source.text)

        def blank(start: int, end: int) -> None:
            for i in range(start, end):
                if text[i] != "\n":
                    text[i] = " "
        self.sections: list[tuple[int, int, str, Location]] = []   # start, end, head name, its place
        copies: list[tuple[str, int, bool]] = []   # the stand-ins' text: piece, its place in the file, copied?
        for k, m in enumerate(re.finditer(r"\(\s*:derived(?![\w-])", low)):
            start, end = m.start(), _matching(code, m.start())
            form = Location(source, start, m.end())
            if end >= len(code):
                raise PddlError("this (:derived ...) is not closed", form)
            h = re.compile(r"\s*\(\s*([^\s()]+)").match(code, m.end())
            if not h:
                raise PddlError("expected (:derived (NAME ?x - type ...) CONDITION)", form)
            head_open = code.index("(", m.end())
            head_close = _matching(code, head_open)
            body = code[head_close + 1:end]
            if not body.strip():
                raise PddlError("this derived predicate has no condition: expected "
                                "(:derived (NAME ?x - type ...) CONDITION)", form)
            name = Location(source, h.start(1), h.end(1))
            self.sections.append((start, end + 1, h.group(1), name))
            name_text = f"{_STAND_IN}{k + 1}"
            copies += [(f" (:action {name_text} :parameters (", start, False),
                       (code[h.end(1):head_close], h.end(1), True), (") :precondition ", start, False),
                       (body, head_close + 1, True), (" :effect (and))\n", start, False)]
            blank(start, end + 1)
        self.count = len(self.sections)
        for r in re.finditer(r"\(\s*:requirements\b", low):
            close = _matching(code, r.start())
            tokens = re.findall(r":[a-z0-9_-]+", low[r.end():close])
            for t in re.finditer(r":derived-predicates(?![\w-])", low[r.end():close]):
                blank(r.end() + t.start(), r.end() + t.end())
            if tokens and all(t == ":derived-predicates" for t in tokens):
                blank(r.start(), close + 1)          # the reader refuses an empty list
        self.copies = copies
        self.insert_at = self.inserted = 0
        if copies:
            opening = re.match(r"\s*\(", code)
            self.insert_at = _matching(code, opening.end() - 1) if opening else len(code)
            inserted = "\n" + "".join(piece for piece, _, _ in copies)
            self.inserted = len(inserted)
            text[self.insert_at:self.insert_at] = list(inserted)
        self.text = "".join(text)
        self.augmented = Source(source.path, self.text)

    def original(self, at: int) -> int:
        """The offset in the file of an offset in the augmented text."""
        if not self.inserted or at < self.insert_at:
            return at
        if at >= self.insert_at + self.inserted:
            return at - self.inserted
        pos = self.insert_at + 1
        for piece, origin, copied in self.copies:
            if pos <= at < pos + len(piece):
                return origin + (at - pos) if copied else origin
            pos += len(piece)
        return self.insert_at

    def relocate(self, err: PddlError) -> PddlError:
        if err.loc is None or err.loc.source is not self.augmented:
            return err
        at = self.original(err.loc.start)
        return PddlError(err.message.replace(_STAND_IN, "derived-predicate rule "), Location(self.source, at, at + 1))


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
    derived = _DerivedText(domain)
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
                reader_class().parse_problem_string(derived.text)
            except Exception as exc:  # noqa: BLE001 - every complaint of the reader is the file's
                raise derived.relocate(_located(exc, [derived.augmented])) from None
            try:
                parsed = reader_class().parse_problem_string(derived.text, problem.text)
            except Exception as exc:  # noqa: BLE001
                raise derived.relocate(_located(exc, [problem, derived.augmented])) from None
            from cplus.pddl.translate import check_kind
            check_kind(parsed, Location(domain, 0, 1))     # the stand-ins' conditions too
            if derived.count:
                _take_derived(parsed, derived, problem)
    finally:
        env.error_used_name = strict
    return parsed


def _take_derived(parsed, derived: _DerivedText, problem: Source) -> None:
    """Take the stand-in actions out of the problem and keep their rules beside it
    (:func:`cplus.pddl.derived.attach`), checked: each head a declared predicate, of its arity,
    its parameters' types within the predicate's; no derived predicate in an effect or in the
    initial state; the rules stratified."""
    from cplus.pddl.derived import Rule, attach, strata
    stand_ins = {f"{_STAND_IN}{k + 1}": section for k, section in enumerate(derived.sections)}
    rules = []
    for k, (_start, _end, name, loc) in enumerate(derived.sections):
        action = parsed.action(f"{_STAND_IN}{k + 1}")
        fluents = [f for f in parsed.fluents if f.name.lower() == name.lower()]
        if not fluents:
            raise PddlError(f"derived predicate '{name}' is not declared in :predicates", loc)
        fluent = fluents[0]
        if not fluent.type.is_bool_type():
            raise PddlError(f"'{name}' is a function, not a predicate: it cannot be derived", loc)
        if len(fluent.signature) != len(action.parameters):
            raise PddlError(f"derived predicate '{name}' has {len(fluent.signature)} argument(s) in :predicates "
                            f"and {len(action.parameters)} here", loc)
        for q, decl in zip(action.parameters, fluent.signature):
            if not _subtype(q.type, decl.type):
                raise PddlError(f"parameter ?{q.name} of derived predicate '{name}' is of type {q.type}, which is "
                                f"not within {decl.type}, the type :predicates gives it", loc)
        em = parsed.environment.expression_manager
        rules.append(Rule(fluent, list(action.parameters), em.And(action.preconditions), loc))
    kept = [a for a in parsed.actions if a.name not in stand_ins]
    parsed.clear_actions()
    parsed.add_actions(kept)
    heads = {r.fluent.name for r in rules}
    code = _code(derived.source.text).lower()
    for a in kept:
        for e in a.effects:
            if e.fluent.is_fluent_exp() and e.fluent.fluent().name in heads:
                raise PddlError(f"action {a.name} changes derived predicate '{e.fluent.fluent().name}': a derived "
                                "predicate holds where its rules say, no action may set it",
                                _place(derived.source, code, rf"\(\s*:action\s+{re.escape(a.name.lower())}(?![\w-])",
                                       ":effect", e.fluent.fluent().name.lower()))
    for fe, v in parsed.explicit_initial_values.items():
        if fe.is_fluent_exp() and fe.fluent().name in heads and v.is_true():
            raise PddlError(f"derived predicate '{fe.fluent().name}' is given in :init: it holds where its rules "
                            "say, and cannot be set", _place(problem, _code(problem.text).lower(), r"\(\s*:init\b",
                                                            None, fe.fluent().name.lower()))
    strata(rules)
    attach(parsed, rules)


def _subtype(t, ancestor) -> bool:
    while t is not None:
        if t == ancestor:
            return True
        t = t.father
    return False


def _place(source: Source, code: str, opener: str, after: str | None, name: str) -> Location:
    """Where ``(name`` first occurs in the form that ``opener`` begins (after the keyword
    ``after`` when given), else that form's opening, else the file's start."""
    m = re.search(opener, code)
    if not m:
        return Location(source, 0, 1)
    end = _matching(code, m.start())
    start = m.start()
    if after:
        k = code.find(after, start, end)
        start = k if k >= 0 else start
    hit = re.compile(r"\(\s*(" + re.escape(name) + r")(?![\w-])").search(code, start, end)
    if hit:
        return Location(source, hit.start(1), hit.end(1))
    return Location(source, m.start(), m.end())
