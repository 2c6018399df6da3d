"""The explanations of a C+ statement that does not parse: an unknown directive, a missing
'.', a statement that ends too early, a keyword used as a name, a misspelled keyword.

Only the error path imports lark (:func:`cplus.parse_tables._lark` explains the error);
a well-formed file never runs this module's functions.  Split from :mod:`cplus.parser`
because the wording of the errors is a concern of its own, and the longest one.
"""
from __future__ import annotations

import re
from typing import TYPE_CHECKING

from cplus import lalr
from cplus.errors import CPlusSyntaxError, Location, Source
from cplus.lalr import Token
from cplus.parse_tables import _lark, _parser
from cplus.parse_text import _WORD, RESERVED, _skip_blank, _strip_comments

if TYPE_CHECKING:
    from lark.exceptions import UnexpectedInput


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


