"""Parse C+ source text into :mod:`cplus.ast` statements.

A file is first cut into statements (each ends with a ``.`` followed by white space,
``%`` or the end of the file; ``..`` never ends one), then every statement is parsed on its
own with the LALR grammar in ``grammar/cplus.lark``.  Cutting first keeps error positions
exact, lets Cplus2ASP-only blocks (``:- begin_asp.`` ... ``:- end_asp.``) be skipped
without parsing them, and mirrors what CCALC's Prolog reader does with a clause it cannot
read at the end of a file.

>>> from cplus.parser import parse_program
>>> prog = parse_program("flip causes lit.  % a comment", "x.cp")
>>> law = prog.statements[0]
>>> law.kind, law.action.name, law.head.name
('causes', 'flip', 'lit')
"""
from __future__ import annotations

import os
import re
from functools import lru_cache
from typing import TYPE_CHECKING

from cplus import ast, lalr
from cplus.errors import CPlusSyntaxError, Diagnostics, Location, Source
from cplus.lalr import Token, Tree
from cplus.limits import MAX_INT, MAX_NESTING
from cplus.signature import USER_KINDS

if TYPE_CHECKING:
    from lark import Lark
    from lark.exceptions import UnexpectedInput

__all__ = ["parse_program", "split_statements", "RESERVED"]

RESERVED = frozenset("""
    abs after all always by caused causes constants constraint decrements default exogenous hide
    if include increments inertial label macros maxstep mod nmquery noconcurrency nonexecutable objects of
    query show sorts unless variables where
""".split())
"""CCALC's keywords that structure statements: they cannot name a sort, object, constant,
variable or macro (the grammar's IDENT excludes exactly these).  Constant kinds
(``inertialFluent``, ``rigid``, ...), ``true``, ``false``, ``none``, ``min``, ``max`` and
``maxAdditive`` stay names: they occur where names do.  Cplus2ASP's additions (``never``,
``impossible``, ``strong_noconcurrency``) are keywords only where a statement begins, since
CCALC files may use them as names."""

_CHAIN_MIN = 9
"""Chains of one associative operator longer than this are regrouped into a balanced tree."""

_GRAMMAR = os.path.join(os.path.dirname(__file__), "grammar", "cplus.lark")
"""The grammar (paths are strings here: importing pathlib would cost every command 5 ms)."""

_SCAN = re.compile(r"%|/\*|'|\.")
_BLOCK_START = re.compile(r"\s*(?::-\s*|#)begin_(asp|lua|f2lp|python)\s*$")
_WORD = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def _cache_dir() -> str | None:
    """Where the parse tables are kept (None: there is no home directory to keep them in)."""
    base = os.environ.get("XDG_CACHE_HOME")
    if not base:
        home = os.path.expanduser("~")
        if home == "~":
            return None
        base = os.path.join(home, ".cache")
    return os.path.join(base, "cplus")


def _read(path: str) -> str:
    with open(path, encoding="utf-8") as f:
        return f.read()


@lru_cache(maxsize=1)
def _lark() -> Lark:
    """lark's LALR parser of the grammar: it builds the tables and explains syntax errors.
    Building its tables takes a fifth of a second, so lark keeps them in the user's cache
    directory (keyed by a hash of the grammar and options); when that directory is not
    writable the tables are simply built each time."""
    from lark import Lark

    text = _read(_GRAMMAR)
    options = dict(parser="lalr", propagate_positions=True, maybe_placeholders=False)
    cache_dir = _cache_dir()
    if cache_dir is not None:
        try:
            os.makedirs(cache_dir, exist_ok=True)
            return Lark(text, cache=os.path.join(cache_dir, f"grammar-{_lark_version()}.cache"), **options)
        except OSError:
            pass
    return Lark(text, **options)


def _lark_version() -> str:
    import hashlib

    import lark
    digest = hashlib.sha256(_read(_GRAMMAR).encode() + lark.__version__.encode()).hexdigest()
    return digest[:16]


@lru_cache(maxsize=1)
def _parser() -> lalr.Parser:
    """The parser of well-formed statements (:mod:`cplus.lalr`): its tables are read from the
    user's cache directory, where they are kept with the grammar's text they were built
    from, without importing lark; built by lark and stored there when missing or stale."""
    import marshal
    import sys
    import zlib

    grammar = _read(_GRAMMAR)
    cache_dir = _cache_dir()
    if cache_dir is None:
        return lalr.Parser(lalr.tables_of(_lark()))
    path = os.path.join(cache_dir, f"tables-{sys.implementation.cache_tag}-{zlib.crc32(grammar.encode()):08x}.marshal")
    try:
        with open(path, "rb") as f:
            fmt, text, tables = marshal.loads(f.read())
        if fmt == lalr.FORMAT and text == grammar:
            return lalr.Parser(tables)
    except (OSError, ValueError, EOFError, TypeError, KeyError):   # unreadable or damaged: rebuilt
        pass
    tables = lalr.tables_of(_lark())
    tmp = f"{path}.{os.getpid()}.tmp"
    try:
        os.makedirs(cache_dir, exist_ok=True)
        with open(tmp, "wb") as f:
            f.write(marshal.dumps((lalr.FORMAT, grammar, tables)))
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
    return lalr.Parser(tables)


def _parse(source: Source, begin: int, end: int) -> Tree | Token:
    """The tree of the statement at ``begin:end``; lark itself explains one that is not
    well formed (it is imported only then)."""
    chunk = source.text[begin:end]
    if _NMQUERY.match(chunk):
        chunk = _nm_arrows(chunk)
    try:
        return _parser().parse(chunk)
    except lalr.NoParse:
        pass
    from lark.exceptions import UnexpectedInput
    try:
        tree = _lark().parse(chunk)
    except UnexpectedInput as exc:
        raise _syntax_error(exc, source, begin, end, chunk) from None
    return lalr.from_lark(tree)


_NMQUERY = re.compile(r"(?:\s|%[^\n]*\n|/\*.*?\*/)*:-\s*nmquery(?![A-Za-z0-9_])", re.S)
_ARROWS = re.compile(r"%[^\n]*|/\*.*?\*/|'[^'\n]*'|[()\[\]]|@?<=|<-(?!>)|@?=>", re.S)


def _nm_arrows(chunk: str) -> str:
    """An nmquery with CCALC's rule arrows marked for the grammar: ``<=`` and ``<-`` (``H <= B``,
    ``<= B``) become ``<~``, ``=>`` (``B => H``) becomes ``~>``, where they stand outside
    parentheses and brackets.  In CCALC these arrows are operators looser than every
    connective (precedences.std: ``op(1060, xfx, [<=, =>, <-, :-])``), never comparisons; the
    same text elsewhere stays Cplus2ASP's ``=<`` and ``>=``.  Same length, so positions hold."""
    out = list(chunk)
    depth = 0
    for m in _ARROWS.finditer(chunk):
        tok = m.group()
        if tok in "([":
            depth += 1
        elif tok in ")]":
            depth = max(0, depth - 1)
        elif depth == 0 and tok in ("<=", "<-"):
            out[m.start():m.end()] = "<~"
        elif depth == 0 and tok == "=>":
            out[m.start():m.end()] = "~>"
    return "".join(out)


def _strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r"%[^\n]*", " ", text)


def split_statements(source: Source, diagnostics: Diagnostics) -> list[tuple[int, int]]:
    """Cut ``source`` into statements: a list of (start, end) offsets, period excluded.

    Raises :class:`CPlusSyntaxError` for an unterminated block comment, quoted name or
    Cplus2ASP block.
    """
    text = source.text
    n = len(text)
    spans: list[tuple[int, int]] = []
    start = 0
    pos = 0
    while True:
        m = _SCAN.search(text, pos)
        if m is None:
            break
        tok = m.group()
        at = m.start()
        if tok == "%":
            nl = text.find("\n", at)
            pos = n if nl < 0 else nl + 1
        elif tok == "/*":
            close = text.find("*/", at + 2)
            if close < 0:
                raise CPlusSyntaxError("unterminated comment: '/*' has no matching '*/'",
                                       Location(source, at, at + 2))
            pos = close + 2
        elif tok == "'":
            close = text.find("'", at + 1)
            nl = text.find("\n", at + 1)
            if close < 0 or (0 <= nl < close):
                raise CPlusSyntaxError("unterminated quoted name", Location(source, at, at + 1))
            pos = close + 1
        else:  # '.'
            nxt = text[at + 1] if at + 1 < n else ""
            prev = text[at - 1] if at > 0 else ""
            if nxt == "." or prev == ".":
                pos = at + 1
                continue
            if not (nxt == "" or nxt.isspace() or nxt == "%"):
                pos = at + 1
                continue
            block = _BLOCK_START.match(_strip_comments(text[start:at]))
            if block is None:
                spans.append((start, at))
                start = pos = at + 1
                continue
            begin = _skip_blank(text, start)
            where = Location(source, begin, at + 1)
            end_re = re.compile(r"(?::-\s*|#)end_" + block.group(1) + r"\s*\.")
            found = end_re.search(text, at + 1)
            if found is None:
                raise CPlusSyntaxError(
                    f"unterminated Cplus2ASP block: no 'end_{block.group(1)}.' follows", where)
            diagnostics.warn("skipping a Cplus2ASP-only block (CCALC has no such statement)", where)
            start = pos = found.end()
    if _strip_comments(text[start:]).strip():
        unterminated = _unterminated(source, start)
        if unterminated is not None:
            raise unterminated
        diagnostics.warn("the text at the end of the file is not ended by '.'; it is ignored",
                         Location(source, _skip_blank(text, start), n))
    return spans


def _skip_blank(text: str, pos: int) -> int:
    """First offset at or after ``pos`` that is not white space or a comment."""
    n = len(text)
    while pos < n:
        if text[pos].isspace():
            pos += 1
        elif text[pos] == "%":
            nl = text.find("\n", pos)
            pos = n if nl < 0 else nl + 1
        elif text.startswith("/*", pos):
            close = text.find("*/", pos + 2)
            pos = n if close < 0 else close + 2
        else:
            break
    return pos


def parse_program(text: str, path: str = "<input>",
                  diagnostics: Diagnostics | None = None) -> ast.ParsedFile:
    """Parse the text of one file into statements (includes are not followed here)."""
    diagnostics = diagnostics if diagnostics is not None else Diagnostics()
    text = text.removeprefix("\ufeff")  # a UTF-8 byte-order mark is not part of the text
    source = Source(path, text)
    statements: list[ast.Statement] = []
    for begin, end in split_statements(source, diagnostics):
        first = _skip_blank(text, begin)
        if first >= end:
            raise CPlusSyntaxError("empty statement: a '.' with nothing before it",
                                   Location(source, end, end + 1))
        tree = _parse(source, begin, end)
        stmt = _Builder(source, begin).build(tree)
        deep = _too_deep(stmt)
        if deep is not None:
            raise CPlusSyntaxError(f"this expression is nested more than {MAX_NESTING} levels deep "
                                   "(parentheses, negations, implications, arguments); write it in "
                                   "smaller parts", deep.loc)
        statements.append(stmt)
    return ast.ParsedFile(source, tuple(statements))


_EXPR_NODES = (ast.Num, ast.Name, ast.Param, ast.MaxStep, ast.Unary, ast.Binary, ast.Quant, ast.Stamp,
               ast.Range, ast.SortRef)


def _too_deep(stmt) -> ast.Expr | None:
    """The first expression node nested deeper than MAX_NESTING, if any."""
    stack: list[tuple[object, int]] = [(stmt, 0)]
    while stack:
        obj, depth = stack.pop()
        if isinstance(obj, _EXPR_NODES):
            depth += 1
            if depth > MAX_NESTING:
                return obj
        if isinstance(obj, tuple):
            stack.extend((child, depth) for child in obj if isinstance(child, tuple))
    return None


_READABLE = {
    "IDENT": "a name", "INT": "an integer", "PARAM": "a macro parameter", "QUOTED": "a quoted file name",
    "CMPOP": "a comparison", "ADDOP": "'+' or '-'", "MULOP": "'*', '//' or 'mod'",
    "EQUIV": "'<->>'", "INCDEC": "'increments'", "QUANT": "'\\/' or '/\\'", "STARSORT": "a sort",
    "$END": "the end of the statement", "ABS": "'abs'",
}


_DIRECTIVES = {"sorts", "objects", "constants", "variables", "macros", "include", "show", "hide", "query",
               "nmquery", "maxAdditive"}
_DIRECTIVE = re.compile(r"\s*:-\s*([A-Za-z][A-Za-z0-9_]*)")


def _describe(name: str) -> str:
    if "END" in name.upper() and name.startswith(("$", "<")):
        return "the end of the statement"
    if name in _READABLE:
        return _READABLE[name]
    for term in _lark().terminals:
        if term.name == name:
            pattern = term.pattern.value
            return f"'{pattern}'" if term.pattern.type == "str" else name.lower()
    return name.lower()


def _syntax_error(exc: UnexpectedInput, source: Source, begin: int, end: int,
                  chunk: str) -> CPlusSyntaxError:
    from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedToken

    directive = _DIRECTIVE.match(_strip_comments(chunk))
    if directive and directive.group(1) not in _DIRECTIVES:
        at = begin + chunk.index(directive.group(1))
        near = _did_you_mean(directive.group(1), _DIRECTIVES)
        suggestion = "" if near is None else f"did you mean ':- {near}'? "
        return CPlusSyntaxError(f"unknown directive ':- {directive.group(1)}' ({suggestion}known: "
                                f"{', '.join(sorted(_DIRECTIVES))})", Location(source, at, at + len(directive.group(1))))
    missing = _missing_period(exc, source, begin, chunk)
    if missing is not None:
        return missing
    if isinstance(exc, UnexpectedEOF) or (
            isinstance(exc, UnexpectedToken) and exc.token.type == "$END"):
        expected = sorted({_describe(t) for t in getattr(exc, "expected", ())})
        hint = f" (expected {', '.join(expected)})" if 0 < len(expected) <= 5 else ""
        return CPlusSyntaxError(f"the statement ends too early{hint}", Location(source, end, end + 1))
    if isinstance(exc, UnexpectedCharacters):
        at = begin + exc.pos_in_stream  # type: ignore[operator]
        ch = chunk[exc.pos_in_stream]  # type: ignore[index]
        if ch == ".":
            return CPlusSyntaxError("unexpected '.': a statement ends with '.' followed by a space "
                                    "or a new line", Location(source, at, at + 1))
        pos: int = exc.pos_in_stream  # type: ignore[assignment]
        word = _WORD.match(chunk, pos)
        if word and (pos == 0 or not chunk[pos - 1].isalnum()):
            return _unexpected(word.group(), at, source, (), chunk, begin)
        if chunk.startswith("!=", pos):
            return _unexpected("!=", at, source, ())
        return CPlusSyntaxError(f"unexpected character {ch!r}", Location(source, at, at + 1))
    assert isinstance(exc, UnexpectedToken)
    tok = exc.token
    return _unexpected(str(tok), begin + (tok.start_pos or 0), source, exc.expected, chunk, begin)


def _statement_end(text: str) -> int | None:
    """Where the statement ``text`` ends (after its last token), or None when it is not one."""
    try:
        tree = _parser().parse(text)
    except lalr.NoParse:
        return None
    return tree.end_pos if isinstance(tree, Token) else tree.meta.end_pos


_PERIOD_TRIES = 8
"""Line breaks before a syntax error tried as the place of a missing '.' (the error path only)."""


def _missing_period(exc: UnexpectedInput, source: Source, begin: int, chunk: str) -> CPlusSyntaxError | None:
    """A statement that lacks its '.' runs into the next one, and the parser stumbles on the
    next one's first word, a line or more after the mistake.  When the text before a line
    break is a whole statement, and what follows the break is one too or the error is on its
    first token, the '.' is missing there: say so, at the end of the statement that lacks it."""
    from lark.exceptions import UnexpectedCharacters, UnexpectedToken

    if isinstance(exc, UnexpectedToken) and exc.token.type != "$END":
        at: int = exc.token.start_pos or 0
    elif isinstance(exc, UnexpectedCharacters):
        at = exc.pos_in_stream  # type: ignore[assignment]
    else:
        return None
    cut = chunk.rfind("\n", 0, at)
    for _ in range(_PERIOD_TRIES):
        if cut < 0:
            return None
        end = _statement_end(chunk[:cut])
        if end is not None and (_skip_blank(chunk, cut) == at or _statement_end(chunk[cut:]) is not None):
            where = Location(source, begin + end, begin + end + 1)
            return CPlusSyntaxError("missing '.' at the end of this statement (the next line starts "
                                    "another one)", where)
        cut = chunk.rfind("\n", 0, cut)
    return None


def _unterminated(source: Source, start: int) -> CPlusSyntaxError | None:
    """The error for text at the end of a file that is a whole statement but for its '.'
    (None when it is not a statement: that text is skipped with a warning, as CCALC does)."""
    end = _statement_end(source.text[start:])
    if end is None:
        return None
    return CPlusSyntaxError("missing '.' at the end of the file's last statement",
                            Location(source, start + end, start + end + 1))


_CPLUS2ASP_HINTS = {
    "!=": "write '\\=' for 'not equal'",
    "|": "'|' is not a connective in CCALC: write '++' for 'or'",
}


_KEYWORDS = RESERVED | {"may", "cause", "possibly", "rigid", "never", "impossible"}
"""Every word the grammar reads as a keyword somewhere: what a misspelled word is compared to."""

_LAW_OPENERS = ("caused", "possibly", "nonexecutable", "default", "exogenous", "inertial", "constraint",
                "always", "rigid", "never", "impossible")
"""The keywords a law can begin with."""


def _did_you_mean(word: str, candidates) -> str | None:
    """The keyword closest to a misspelled word, if one is close (difflib's ratio 0.75)."""
    import difflib

    close = difflib.get_close_matches(word, sorted(candidates), n=1, cutoff=0.75)
    return close[0] if close and close[0] != word else None


def _expected_keywords(expected) -> set[str]:
    """The keywords among the terminals the parser expected."""
    words: set[str] = set()
    for name in expected:
        for term in _lark().terminals:
            if term.name == name:
                if term.pattern.type == "str":
                    words.add(term.pattern.value)
                else:
                    words.update(w for w in re.findall(r"[A-Za-z]+", term.pattern.value) if w in _KEYWORDS)
    return {w for w in words if w in _KEYWORDS}


def _unexpected(text: str, at: int, source: Source, expected, chunk: str = "", begin: int = 0) -> CPlusSyntaxError:
    described = sorted({_describe(t) for t in expected})
    hint = f"; expected {', '.join(described)}" if 0 < len(described) <= 5 else ""
    first = _WORD.match(chunk, _skip_blank(chunk, 0))
    opener = first.group() if first and first.group() not in _KEYWORDS and begin + first.start() < at else None
    if text in RESERVED:
        hint = f" ('{text}' is a keyword and cannot be used as a name){hint}"
    elif text in _CPLUS2ASP_HINTS:
        hint = f" ({_CPLUS2ASP_HINTS[text]}){hint}"
    elif _WORD.fullmatch(text) and (near := _did_you_mean(text, _expected_keywords(expected) if expected else _KEYWORDS)):
        hint = f" (did you mean '{near}'?){hint}"
    elif opener is not None and (near := _did_you_mean(opener, _LAW_OPENERS)):
        hint = f" ('{opener}' is not a keyword: did you mean '{near}'?){hint}"
    return CPlusSyntaxError(f"unexpected {text!r}{hint}", Location(source, at, at + max(1, len(text))))


def _int_value(text: str) -> int | None:
    """The value of an integer literal, or None when it exceeds MAX_INT (checked on the digits
    first: Python refuses to convert strings of more than a few thousand digits)."""
    digits = text.lstrip("0") or "0"
    if len(digits) > len(str(MAX_INT)):
        return None
    value = int(digits)
    return value if value <= MAX_INT else None


_CPLUS2ASP_CMP = {"<=": "=<", "=>": ">=", "<>": "\\=", "@<=": "@=<", "@=>": "@>="}
"""Cplus2ASP's spellings of CCALC's comparisons (same meaning, so accepted)."""

_CONNECTIVES = {"and_": "&", "or_": "++", "comma": ",", "andand": "&&", "oror": "||"}
_UNARY_RUNS = ("neg", "uminus", "abs_")


def _as_sort(e):
    """A sort written in a declaration, as the grammar reads it (an expression), classified:
    ``s`` and ``s*`` and ``s+none`` become :class:`ast.SortRef`, ranges stay ranges, and
    anything else (a macro call) is left for the resolver to expand."""
    if isinstance(e, ast.Name) and not e.args:
        return ast.SortRef(e.loc, e.name)
    if isinstance(e, ast.Binary) and e.op == "+" and isinstance(e.left, ast.Name) and not e.left.args \
            and isinstance(e.right, ast.Name) and e.right.name == "none" and not e.right.args:
        return ast.SortRef(e.loc, e.left.name, True)
    return e


class _Combine:
    """A step of the walk: take the last ``count`` values and combine them."""

    __slots__ = ("count", "finish")

    def __init__(self, count: int, finish) -> None:
        self.count = count
        self.finish = finish


def _spine(node: Tree) -> tuple[list, list]:
    """The operands and operators of a left-nested chain of one operator (``+``/``-`` count
    as one), without recursion."""
    rule = str(node.data)
    group = None if rule != "arith" else ("+", "-") if str(node.children[1]) in ("+", "-") else ("*",)
    operands: list = []
    ops: list = []
    cur = node
    while isinstance(cur, Tree) and str(cur.data) == rule and (group is None or str(cur.children[1]) in group):
        operands.append(cur.children[-1])
        if group is not None:
            ops.append(cur.children[1])
        cur = cur.children[0]
    operands.append(cur)
    operands.reverse()
    ops.reverse()
    return operands, ops


def _balanced(rule: str, ops: list):
    """Combine a chain's operand values into a balanced tree of Binary nodes."""
    def finish(builder: _Builder, values: list):
        if rule == "arith" and ops[0] != "*":
            values = [values[0]] + [ast.Unary(Location(builder.source, builder.base + op.start_pos, v.loc.end), "-", v)
                                    if str(op) == "-" else v for op, v in zip(ops, values[1:])]
        op = _CONNECTIVES.get(rule) or ("*" if str(ops[0]) == "*" else "+")

        def tree(lo: int, hi: int):
            if hi - lo == 1:
                return values[lo]
            mid = (lo + hi + 1) // 2
            left, right = tree(lo, mid), tree(mid, hi)
            return ast.Binary(builder._span(left, right), op, left, right)
        return tree(0, len(values))
    return finish


def _minus_leftmost(e, loc: Location):
    """``-`` applied to the leftmost operand of an arithmetic term (Prolog's prefix minus)."""
    if isinstance(e, ast.Binary) and e.op in ast.ARITH_OPS:
        return ast.Binary(e.loc, e.op, _minus_leftmost(e.left, loc), e.right)
    return ast.Unary(Location(loc.source, loc.start, e.loc.end), "cneg", e)


def _unary_run(rule: str, metas: list):
    """Apply the prefix operator of a shortened run (one or two of them) to its operand."""
    def finish(builder: _Builder, values: list):
        value = values[0]
        for meta in reversed(metas):
            value = getattr(builder, rule)(meta, [value])
        return value
    return finish


class _Builder:
    """Lark tree -> :mod:`cplus.ast` (one instance per statement: it knows the offset).

    The tree is walked with an explicit stack, never by recursion, so that a law with
    thousands of conjuncts or a long chain of minus signs cannot exhaust Python's stack.
    While walking, chains of one associative operator longer than ``_CHAIN_MIN`` are regrouped
    into a balanced tree (``a - b`` becoming ``a + -b`` inside sums: equal for integers and
    equally undefined otherwise), and runs of prefix operators are shortened to what they mean
    (``- - - p`` is ``-p``; an even run keeps two, so ``--p`` stays recognisable).  Every later
    pass over the syntax tree then recurses at most ``MAX_NESTING`` levels deep.
    """

    def __init__(self, source: Source, base: int) -> None:
        self.source = source
        self.base = base

    # -------------------------------------------------------------- the walk
    def build(self, tree: Tree | Token):
        values: list = []
        todo: list = [tree]
        while todo:
            item = todo.pop()
            if isinstance(item, _Combine):
                n = item.count
                args = values[len(values) - n:] if n else []
                del values[len(values) - n:]
                values.append(item.finish(self, args))
            elif isinstance(item, Tree):
                todo.extend(self._plan(item))
            else:
                values.append(item)
        (result,) = values
        return result

    def _plan(self, node: Tree) -> list:
        """What to do for ``node``: a combine step, then its operands (reversed: a stack)."""
        rule = str(node.data)
        children = node.children
        if rule in _UNARY_RUNS:
            run = [node]
            while isinstance(run[-1].children[-1], Tree) and str(run[-1].children[-1].data) == rule:
                run.append(run[-1].children[-1])
            if len(run) > 1:
                keep = [run[0]] if (len(run) % 2 or rule == "abs_") else [run[0], run[-1]]
                operand = run[-1].children[-1]
                return [_Combine(1, _unary_run(rule, [n.meta for n in keep])), operand]
        if rule in _CONNECTIVES or (rule == "arith" and str(children[1]) in ("+", "-", "*")):
            operands, ops = _spine(node)
            if len(operands) > _CHAIN_MIN:
                return [_Combine(len(operands), _balanced(rule, ops)), *reversed(operands)]
        method = getattr(self, rule)
        return [_Combine(len(children), lambda b, args, m=method, meta=node.meta: m(meta, args)),
                *reversed(children)]

    def _loc(self, meta) -> Location:
        if getattr(meta, "empty", True):
            return Location(self.source, self.base, self.base)
        return Location(self.source, self.base + meta.start_pos, self.base + meta.end_pos)

    def _tloc(self, tok: Token) -> Location:
        return Location(self.source, self.base + tok.start_pos, self.base + tok.end_pos)

    def _span(self, first, last) -> Location:
        return Location(self.source, first.loc.start, last.loc.end)

    # -------------------------------------------------------------- statements
    def statement(self, meta, ch):
        return ch[0]

    def noconcurrency(self, meta, ch):
        return ast.NoConcurrency(self._loc(meta), str(ch[0]) == "strong_noconcurrency")

    def unknown_directive(self, meta, ch):
        raise CPlusSyntaxError(f"unknown directive ':- {ch[0]}'", self._tloc(ch[0]))

    def sorts(self, meta, ch):
        """``a >> b >> (c; d >> e)``: each sort with its parent, depth first, without recursion."""
        decls: list[ast.SortDecl] = []
        todo: list = [("item", item, None) for item in reversed(ch)]
        while todo:
            what, thing, parent = todo.pop()
            if what == "decl":
                decls.append(ast.SortDecl(self._tloc(thing), str(thing), parent))
                continue
            name_tok, groups = thing
            steps: list = [("decl", name_tok, parent)]
            current = str(name_tok)
            for group in groups:
                if group[0] == "leaf":
                    steps.append(("decl", group[1], current))
                    current = str(group[1])
                else:
                    steps.extend(("item", sub, current) for sub in group[1])
            todo.extend(reversed(steps))
        return ast.Sorts(self._loc(meta), tuple(decls))

    def sort_item(self, meta, ch):
        return (ch[0], ch[1:])

    def sort_leaf(self, meta, ch):
        return ("leaf", ch[0])

    def sort_many(self, meta, ch):
        return ("many", ch)

    def objects(self, meta, ch):
        return ast.Objects(self._loc(meta), tuple(ch))

    def object_item(self, meta, ch):
        *terms, sort = ch
        return ast.ObjectItem(self._loc(meta), tuple(terms), str(sort), self._tloc(sort))

    def constants(self, meta, ch):
        return ast.Constants(self._loc(meta), tuple(ch))

    def constant_item(self, meta, ch):
        *names, spec = ch
        return ast.ConstantItem(self._loc(meta), tuple(names), spec)

    def const_name(self, meta, ch):
        return ast.ConstName(self._loc(meta), str(ch[0]), tuple(_as_sort(a) for a in ch[1:]))

    def plain_spec(self, meta, ch):
        """``c :: K``, ``c :: K(D)``, ``c :: D``: K a constant kind (D defaults to boolean), D a
        sort, a range, ``s*`` or ``s+none`` (then c is rigid), or a macro call giving one."""
        spec = ch[0]
        loc = self._loc(meta)
        if isinstance(spec, ast.Name) and not spec.args:
            return ast.ConstSpec(loc, spec.name, None)   # a kind, a sort or a macro: the resolver knows
        if isinstance(spec, ast.Name) and spec.name in USER_KINDS:
            if len(spec.args) != 1:
                raise CPlusSyntaxError(f"'{spec.name}' takes one domain: write '{spec.name}(D)'", spec.loc)
            return ast.ConstSpec(loc, spec.name, _as_sort(spec.args[0]))
        return ast.ConstSpec(loc, None, _as_sort(spec))

    def attribute_spec(self, meta, ch):
        domain = _as_sort(ch[0]) if not isinstance(ch[0], Token) else None
        rest = ch[1:] if domain is not None else ch
        parent_tok, *parent_args = rest
        parent = ast.ConstName(self._tloc(parent_tok), str(parent_tok), tuple(_as_sort(a) for a in parent_args))
        return ast.ConstSpec(self._loc(meta), "attribute", domain, parent)

    def star_sort(self, meta, ch):
        return ast.SortRef(self._tloc(ch[0]), str(ch[0])[:-1], True)

    def range(self, meta, ch):
        return ast.Range(self._loc(meta), ch[0], ch[1])

    def variables(self, meta, ch):
        return ast.Variables(self._loc(meta), tuple(ch))

    def variable_item(self, meta, ch):
        *names, sort = ch
        return ast.VariableItem(self._loc(meta), tuple((str(t), self._tloc(t)) for t in names), _as_sort(sort))

    def macros(self, meta, ch):
        return ast.Macros(self._loc(meta), tuple(ch))

    def macro_item(self, meta, ch):
        name, *params, body = ch
        for k, p in enumerate(params, start=1):
            if int(str(p)[1:]) != k:
                raise CPlusSyntaxError(f"macro parameters must be #1, #2, ... in order; found {p}",
                                       self._tloc(p))
        return ast.MacroDef(self._loc(meta), str(name), len(params), body)

    def include(self, meta, ch):
        return ast.Include(self._loc(meta), tuple(ch))

    def include_quoted(self, meta, ch):
        return (str(ch[0])[1:-1], self._tloc(ch[0]))

    def include_name(self, meta, ch):
        return (str(ch[0]), self._tloc(ch[0]))

    def show(self, meta, ch):
        return self._showhide(meta, ch, False)

    def hide(self, meta, ch):
        return self._showhide(meta, ch, True)

    def _showhide(self, meta, ch, hide):
        all_ = any(c == "all" for c in ch)
        pats = tuple(c for c in ch if c != "all")
        return ast.ShowHide(self._loc(meta), hide, all_, pats)

    def show_all(self, meta, ch):
        return "all"

    def show_pattern(self, meta, ch):
        if len(ch) == 1:
            return ch[0]
        if str(ch[1]) != "=":
            raise CPlusSyntaxError("a show/hide pattern is an atom 'c(args)' or 'c(args)=v'",
                                   self._tloc(ch[1]))
        return ast.Binary(self._loc(meta), "=", ch[0], ch[2])

    def show_negative(self, meta, ch):
        return ast.Unary(self._loc(meta), "not", ch[0])

    def show_stamped_pattern(self, meta, ch):
        """``t: c(args)``: CCALC's show specification of one step (``process_show_internal``)."""
        return ast.Stamp(self._loc(meta), ch[0], self.show_pattern(meta, ch[1:]))

    def show_stamped_negative(self, meta, ch):
        return ast.Stamp(self._loc(meta), ch[0], ast.Unary(self._loc(meta), "not", ch[1]))

    def query(self, meta, ch):
        return ast.Query(self._loc(meta), tuple(ch))

    def nmquery(self, meta, ch):
        return ast.Query(self._loc(meta), tuple(ch), nm=True)

    def nm_caused(self, meta, ch):
        return ast.QueryRule(self._loc(meta), ch[0], ch[1][1] if len(ch) > 1 else None, False)

    def nm_default(self, meta, ch):
        return ast.QueryRule(self._loc(meta), ch[0], ch[1][1] if len(ch) > 1 else None, True)

    def nm_fact(self, meta, ch):
        return ast.QueryRule(self._loc(meta), ch[0], None, False)

    def nm_rule(self, meta, ch):
        """CCALC's ``H <= B`` (also ``H <- B``): ``caused H if B``."""
        return ast.QueryRule(self._loc(meta), ch[0], ch[2], False)

    def nm_constraint(self, meta, ch):
        """CCALC's ``<= B``: ``caused false if B``."""
        return ast.QueryRule(self._loc(meta), ast.Name(self._tloc(ch[0]), "false"), ch[1], False)

    def nm_rule_rightwards(self, meta, ch):
        """CCALC's ``B => H``: ``caused H if B``."""
        return ast.QueryRule(self._loc(meta), ch[2], ch[0], False)

    def q_label(self, meta, ch):
        return ast.QueryLabel(self._loc(meta), ch[0])

    def q_maxstep(self, meta, ch):
        lo, hi = ch[0]
        return ast.QueryMaxstep(self._loc(meta), lo, hi)

    def ms_exact(self, meta, ch):
        return (ch[0], ch[0])

    def ms_range(self, meta, ch):
        hi = ch[1]
        if isinstance(hi, ast.Name) and hi.name == "infinity" and not hi.args:
            hi = None
        return (ch[0], hi)

    def q_formula(self, meta, ch):
        return ast.QueryItem(self._loc(meta), ch[0])

    def max_additive(self, meta, ch):
        value = ch[-1]
        if len(ch) == 2 and str(ch[0]) != "=":
            raise CPlusSyntaxError("write ':- maxAdditive :: N.'", self._tloc(ch[0]))
        return ast.MaxAdditive(self._loc(meta), value)

    # -------------------------------------------------------------- laws
    def tail(self, meta, ch):
        parts: dict[str, ast.Expr] = {}
        for kind, expr in ch:
            parts[kind] = expr
        return parts

    def if_part(self, meta, ch):
        return ("if_", ch[0])

    def after_part(self, meta, ch):
        return ("after", ch[0])

    def unless_part(self, meta, ch):
        return ("unless", ch[0])

    def where_part(self, meta, ch):
        return ("where", ch[0])

    def _law(self, meta, kind, head, tail, **extra):
        return ast.Law(self._loc(meta), kind, head, if_=tail.get("if_"), after=tail.get("after"),
                       unless=tail.get("unless"), where=tail.get("where"), **extra)

    def caused(self, meta, ch):
        return self._law(meta, "caused", ch[0], ch[1])

    def possibly_caused(self, meta, ch):
        return self._law(meta, "default", ch[0], ch[1])

    def causes(self, meta, ch):
        return self._law(meta, "causes", ch[1], ch[2], action=ch[0])

    def may_cause(self, meta, ch):
        return self._law(meta, "may_cause", ch[1], ch[2], action=ch[0])

    def increments(self, meta, ch):
        action, incdec, target, amount, tail = ch
        return self._law(meta, "increments", target, tail, action=action, amount=amount,
                         decrement=str(incdec) == "decrements")

    def nonexecutable(self, meta, ch):
        return self._law(meta, "nonexecutable", ch[0], ch[1])

    def default(self, meta, ch):
        return self._law(meta, "default", ch[0], ch[1])

    def exogenous(self, meta, ch):
        return self._law(meta, "exogenous", ch[0], ch[1])

    def inertial(self, meta, ch):
        return self._law(meta, "inertial", ch[0], ch[1])

    def constraint(self, meta, ch):
        return self._law(meta, "constraint", ch[0], ch[1])

    def always(self, meta, ch):
        return self._law(meta, "always", ch[0], ch[1])

    def rigid(self, meta, ch):
        return self._law(meta, "rigid", ch[0], ch[1])

    def never(self, meta, ch):
        return self._law(meta, "never", ch[1], ch[2])

    def fact(self, meta, ch):
        return self._law(meta, "fact", ch[0], ch[1])

    # -------------------------------------------------------------- expressions
    def stamp(self, meta, ch):
        return ast.Stamp(self._loc(meta), ch[0], ch[1])

    def _bin(self, meta, op, ch):
        return ast.Binary(self._loc(meta), op, ch[0], ch[-1])

    def comma(self, meta, ch):
        return self._bin(meta, ",", ch)

    def oror(self, meta, ch):
        return self._bin(meta, "||", ch)

    def andand(self, meta, ch):
        return self._bin(meta, "&&", ch)

    def equiv(self, meta, ch):
        return self._bin(meta, "<->>", ch)

    def implies(self, meta, ch):
        return self._bin(meta, "->>", ch)

    def or_(self, meta, ch):
        return self._bin(meta, "++", ch)

    def and_(self, meta, ch):
        return self._bin(meta, "&", ch)

    def neg(self, meta, ch):
        arg = ch[0]
        if isinstance(arg, ast.Binary) and arg.op in ast.COMPARE_OPS and not self._parenthesized(meta, arg):
            # `-c=v`: Prolog's prefix minus binds tighter than `=`, so CCALC reads `(-c)=v`
            # (the minus on the leftmost operand: `-c+1=v` is `((-c)+1)=v`)
            return ast.Binary(arg.loc, arg.op, _minus_leftmost(arg.left, self._loc(meta)), arg.right)
        if isinstance(arg, ast.Range):   # `-n..n` in a macro body: the minus belongs to the bound
            start = self.base + meta.start_pos
            lo = ast.Unary(Location(self.source, start, arg.lo.loc.end), "-", arg.lo)
            return ast.Range(self._loc(meta), lo, arg.hi)
        return ast.Unary(self._loc(meta), "not", arg)

    def _parenthesized(self, meta, arg) -> bool:
        """Whether the operand of the ``-`` at ``meta`` opens with a parenthesis that encloses it
        whole (``-(c=v)``, negation) rather than only its left side (``-(c)=v``)."""
        text = self.source.text
        at = _skip_blank(text, self.base + meta.start_pos + 1)
        return at < len(text) and text[at] == "(" and arg.loc.start > at

    def tilde(self, meta, ch):
        """Cplus2ASP's ``~c`` is the atom ``c=false`` of a Boolean constant: CCALC's ``-c``."""
        arg = ch[0]
        if not isinstance(arg, ast.Name):
            raise CPlusSyntaxError("'~' (a Cplus2ASP spelling) applies to a Boolean constant: "
                                   "'~c' is CCALC's '-c'; to negate a formula write '-(F)'", self._loc(meta))
        return ast.Unary(self._loc(meta), "not", arg)

    def compare(self, meta, ch):
        op = str(ch[1])
        return ast.Binary(self._loc(meta), _CPLUS2ASP_CMP.get(op, op), ch[0], ch[2])

    def arith(self, meta, ch):
        return ast.Binary(self._loc(meta), str(ch[1]), ch[0], ch[2])

    def abs_(self, meta, ch):
        return ast.Unary(self._loc(meta), "abs", ch[-1])

    def uminus(self, meta, ch):
        return ast.Unary(self._loc(meta), "-", ch[0])

    def number(self, meta, ch):
        value = _int_value(str(ch[0]))
        if value is None:
            text = str(ch[0])
            shown = text if len(text) <= 24 else f"{text[:12]}...{text[-6:]} ({len(text)} digits)"
            raise CPlusSyntaxError(f"the integer {shown} is too large: integers are limited to "
                                   f"{MAX_INT} (2^63-1)", self._tloc(ch[0]))
        return ast.Num(self._tloc(ch[0]), value)

    def name(self, meta, ch):
        return ast.Name(self._tloc(ch[0]), str(ch[0]))

    def app(self, meta, ch):
        return ast.Name(self._loc(meta), str(ch[0]), tuple(ch[1:]))

    def param(self, meta, ch):
        return ast.Param(self._tloc(ch[0]), int(str(ch[0])[1:]))

    def maxstep(self, meta, ch):
        return ast.MaxStep(self._loc(meta))

    def quant(self, meta, ch):
        *qvars, body = ch
        return ast.Quant(self._loc(meta), tuple(qvars), body)

    def quant_var(self, meta, ch):
        return ast.QuantVar(self._tloc(ch[1]), str(ch[0]) == "\\/", str(ch[1]))

    def quant_anon(self, meta, ch):
        """``[\\/var(s, k) | F]``: CCALC's anonymous variable of sort ``s`` as a quantified one."""
        quant, fn, sort, key = ch
        if str(fn) != "var":
            raise CPlusSyntaxError(f"a quantifier binds a variable or 'var(sort, k)', not '{fn}(...)'",
                                   self._tloc(fn))
        return ast.QuantVar(Location(self.source, self.base + fn.start_pos, self.base + meta.end_pos),
                            str(quant) == "\\/", f"var({sort},{key})")
