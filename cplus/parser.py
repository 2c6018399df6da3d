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
from pathlib import Path

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from cplus import ast
from cplus.errors import CPlusSyntaxError, Diagnostics, Location, Source

__all__ = ["parse_program", "split_statements"]

_GRAMMAR = Path(__file__).with_name("grammar") / "cplus.lark"

_SCAN = re.compile(r"%|/\*|'|\.")
_BLOCK_START = re.compile(r"\s*(?::-\s*|#)begin_(asp|lua|f2lp|python)\s*$")
_WORD = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


@lru_cache(maxsize=1)
def _lark() -> Lark:
    """The LALR parser.  Building its tables takes a fifth of a second, so lark keeps them in
    the user's cache directory (keyed by a hash of the grammar and options); when that
    directory is not writable the tables are simply built each time."""
    text = _GRAMMAR.read_text(encoding="utf-8")
    options = dict(parser="lalr", propagate_positions=True, maybe_placeholders=False)
    cache_dir = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "cplus"
    try:
        cache_dir.mkdir(parents=True, exist_ok=True)
        return Lark(text, cache=str(cache_dir / f"grammar-{_lark_version()}.cache"), **options)
    except OSError:
        return Lark(text, **options)


def _lark_version() -> str:
    import hashlib

    import lark
    digest = hashlib.sha256(_GRAMMAR.read_bytes() + lark.__version__.encode()).hexdigest()
    return digest[:16]


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
    source = Source(path, text)
    statements: list[ast.Statement] = []
    parser = _lark()
    for begin, end in split_statements(source, diagnostics):
        first = _skip_blank(text, begin)
        if first >= end:
            raise CPlusSyntaxError("empty statement: a '.' with nothing before it",
                                   Location(source, end, end + 1))
        chunk = text[begin:end]
        try:
            tree = parser.parse(chunk)
        except UnexpectedInput as exc:
            raise _syntax_error(exc, source, begin, end, chunk) from None
        builder = _Builder(source, begin)
        stmt = builder.transform(tree)
        statements.append(stmt)
    return ast.ParsedFile(source, tuple(statements))


_READABLE = {
    "IDENT": "a name", "INT": "an integer", "PARAM": "a macro parameter", "QUOTED": "a quoted file name",
    "CMPOP": "a comparison", "ADDOP": "'+' or '-'", "MULOP": "'*', '//' or 'mod'",
    "EQUIV": "'<->>'", "INCDEC": "'increments'", "QUANT": "'\\/' or '/\\'", "STARSORT": "a sort",
    "$END": "the end of the statement", "ABS": "'abs'",
}


_DIRECTIVES = {"sorts", "objects", "constants", "variables", "macros", "include", "show", "hide", "query",
               "maxAdditive"}
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
    directive = _DIRECTIVE.match(_strip_comments(chunk))
    if directive and directive.group(1) not in _DIRECTIVES:
        at = begin + chunk.index(directive.group(1))
        return CPlusSyntaxError(f"unknown directive ':- {directive.group(1)}' (known: "
                                f"{', '.join(sorted(_DIRECTIVES))})", Location(source, at, at + len(directive.group(1))))
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
        return CPlusSyntaxError(f"unexpected character {ch!r}", Location(source, at, at + 1))
    assert isinstance(exc, UnexpectedToken)
    tok = exc.token
    at = begin + (tok.start_pos or 0)
    expected = sorted({_describe(t) for t in exc.expected})
    hint = f"; expected {', '.join(expected)}" if 0 < len(expected) <= 5 else ""
    return CPlusSyntaxError(f"unexpected {str(tok)!r}{hint}",
                            Location(source, at, at + max(1, len(str(tok)))))


def _num(tok: Token) -> int:
    return int(str(tok))


@v_args(meta=True)
class _Builder(Transformer):
    """Lark tree -> :mod:`cplus.ast` (one instance per statement: it knows the offset)."""

    def __init__(self, source: Source, base: int) -> None:
        super().__init__()
        self.source = source
        self.base = base

    def _loc(self, meta) -> Location:
        if getattr(meta, "empty", True):
            return Location(self.source, self.base, self.base)
        return Location(self.source, self.base + meta.start_pos, self.base + meta.end_pos)

    def _tloc(self, tok: Token) -> Location:
        return Location(self.source, self.base + tok.start_pos, self.base + tok.end_pos)  # type: ignore[operator]

    # -------------------------------------------------------------- statements
    def statement(self, meta, ch):
        return ch[0]

    def noconcurrency(self, meta, ch):
        return ast.NoConcurrency(self._loc(meta), str(ch[0]) == "strong_noconcurrency")

    def unknown_directive(self, meta, ch):
        raise CPlusSyntaxError(f"unknown directive ':- {ch[0]}'", self._tloc(ch[0]))

    def sorts(self, meta, ch):
        decls: list[ast.SortDecl] = []
        for item in ch:
            decls.extend(self._sort_item(item, None))
        return ast.Sorts(self._loc(meta), tuple(decls))

    def _sort_item(self, item, parent):
        name_tok, groups = item
        yield ast.SortDecl(self._tloc(name_tok), str(name_tok), parent)
        current = str(name_tok)
        for group in groups:
            if group[0] == "leaf":
                tok = group[1]
                yield ast.SortDecl(self._tloc(tok), str(tok), current)
                current = str(tok)
            else:
                for sub in group[1]:
                    yield from self._sort_item(sub, current)

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
        return ast.ConstName(self._loc(meta), str(ch[0]), tuple(ch[1:]))

    def kind_with_domain(self, meta, ch):
        return ast.ConstSpec(self._loc(meta), str(ch[0]), ch[1])

    def plain_spec(self, meta, ch):
        spec = ch[0]
        if isinstance(spec, ast.SortRef) and not spec.star:
            # `c :: inertialFluent` (a kind without domain) or `c :: location` (rigid)
            return ast.ConstSpec(self._loc(meta), spec.name, None)
        return ast.ConstSpec(self._loc(meta), None, spec)

    def attribute_spec(self, meta, ch):
        domain = ch[0] if not isinstance(ch[0], Token) else None
        rest = ch[1:] if domain is not None else ch
        parent_tok, *parent_args = rest
        parent = ast.ConstName(self._tloc(parent_tok), str(parent_tok), tuple(parent_args))
        return ast.ConstSpec(self._loc(meta), "attribute", domain, parent)

    def sort_name(self, meta, ch):
        return ast.SortRef(self._tloc(ch[0]), str(ch[0]))

    def star_sort(self, meta, ch):
        return ast.SortRef(self._tloc(ch[0]), str(ch[0])[:-1], True)

    def plus_none_sort(self, meta, ch):
        return ast.SortRef(self._loc(meta), str(ch[0]), True)

    def range(self, meta, ch):
        return ast.Range(self._loc(meta), ch[0], ch[1])

    def range_from_name(self, meta, ch):
        return ast.Range(self._loc(meta), ast.Name(self._tloc(ch[0]), str(ch[0])), ch[1])

    def variables(self, meta, ch):
        return ast.Variables(self._loc(meta), tuple(ch))

    def variable_item(self, meta, ch):
        *names, sort = ch
        return ast.VariableItem(self._loc(meta), tuple((str(t), self._tloc(t)) for t in names), sort)

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

    def query(self, meta, ch):
        return ast.Query(self._loc(meta), tuple(ch))

    def q_label(self, meta, ch):
        return ast.QueryLabel(self._loc(meta), str(ch[0]))

    def q_maxstep(self, meta, ch):
        lo, hi = ch[0]
        return ast.QueryMaxstep(self._loc(meta), lo, hi)

    def ms_exact(self, meta, ch):
        return (ch[0], ch[0])

    def ms_range(self, meta, ch):
        return (ch[0], ch[1])

    def ms_open(self, meta, ch):
        return (ch[0], None)

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
        return ast.Unary(self._loc(meta), "not", ch[0])

    def compare(self, meta, ch):
        return ast.Binary(self._loc(meta), str(ch[1]), ch[0], ch[2])

    def arith(self, meta, ch):
        return ast.Binary(self._loc(meta), str(ch[1]), ch[0], ch[2])

    def abs_(self, meta, ch):
        return ast.Unary(self._loc(meta), "abs", ch[-1])

    def uminus(self, meta, ch):
        return ast.Unary(self._loc(meta), "-", ch[0])

    def number(self, meta, ch):
        return ast.Num(self._tloc(ch[0]), _num(ch[0]))

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
