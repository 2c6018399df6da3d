"""The lexical layer of the C+ parser: CCALC's reserved words, the patterns that cut a file into
statements, and skipping white space and comments.

Shared by the statement cutter (:mod:`cplus.parser`) and the explanations of syntax errors
(:mod:`cplus.parse_errors`), which is why it is a module of its own: both import it, neither
imports the other.
"""
from __future__ import annotations

import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    pass


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

_SCAN = re.compile(r"%|/\*|'|\.")
_BLOCK_START = re.compile(r"\s*(?::-\s*|#)begin_(asp|lua|f2lp|python)\s*$")
_WORD = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


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
