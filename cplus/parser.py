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

import re

from cplus import ast, lalr
from cplus.errors import CPlusSyntaxError, Diagnostics, Location, Source
from cplus.lalr import Token, Tree
from cplus.limits import MAX_NESTING
from cplus.parse_declarations import _DeclarationRules
from cplus.parse_errors import _syntax_error, _unterminated
from cplus.parse_formulas import _FormulaRules
from cplus.parse_tables import _lark, _parser
from cplus.parse_text import _BLOCK_START, _NMQUERY, _SCAN, RESERVED, _nm_arrows, _skip_blank, _strip_comments

__all__ = ["parse_program", "split_statements", "RESERVED"]


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


class _Builder(_DeclarationRules, _FormulaRules):
    """Lark tree -> :mod:`cplus.ast` (one instance per statement: it knows the offset): the
    walk of :class:`~cplus.parse_tree._TreeWalk` with the rules for declarations
    (:mod:`cplus.parse_declarations`) and for laws and formulas (:mod:`cplus.parse_formulas`).
    """
