"""Source locations, the project's exception tree, and warnings.

Every error a user can cause carries a :class:`Location` and renders as
``file:line:col: error: message`` followed by the source line and a caret, the way
compilers do.  Library code raises; only the CLI prints and picks exit codes.
"""
from __future__ import annotations

import bisect

from cplus.record import Record

__all__ = [
    "Source", "Location", "Diagnostic", "Diagnostics",
    "CPlusError", "CPlusSyntaxError", "IncludeError", "ResolveError", "SortError",
    "GroundingError", "OutOfMemoryError", "DefinitenessError", "QueryError", "InputError",
]


class Source:
    """The text of one input file; turns character offsets into line and column."""

    __slots__ = ("path", "text", "_starts")

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.text = text
        self._starts: list[int] | None = None

    def _line_starts(self) -> list[int]:
        if self._starts is None:
            starts = [0]
            find = self.text.find
            pos = find("\n")
            while pos >= 0:
                starts.append(pos + 1)
                pos = find("\n", pos + 1)
            self._starts = starts
        return self._starts

    def line_col(self, offset: int) -> tuple[int, int]:
        """1-based line and column of a character offset."""
        starts = self._line_starts()
        line = bisect.bisect_right(starts, offset) - 1
        return line + 1, offset - starts[line] + 1

    def line_text(self, line: int) -> str:
        starts = self._line_starts()
        if not 1 <= line <= len(starts):
            return ""
        begin = starts[line - 1]
        end = self.text.find("\n", begin)
        return self.text[begin:] if end < 0 else self.text[begin:end]

    def __repr__(self) -> str:
        return f"Source({self.path!r})"


class Location(Record):
    """A span of a source file (character offsets; line and column are derived)."""

    _fields = ("source", "start", "end")
    _compare = ("start", "end")
    __slots__ = _fields

    source: Source
    start: int
    end: int

    def __init__(self, source: Source, start: int, end: int) -> None:
        self.source = source
        self.start = start
        self.end = end

    @property
    def path(self) -> str:
        return self.source.path

    @property
    def line(self) -> int:
        return self.source.line_col(self.start)[0]

    @property
    def col(self) -> int:
        return self.source.line_col(self.start)[1]

    @classmethod
    def of_token(cls, source: Source, line: int, col: int) -> Location:
        """The span of the token that starts at a 1-based line and column, up to a space, ``=``,
        a line end or ``]``: how TOML readers, which know only where a complaint starts, point
        at the whole key or value."""
        lines = source.text.splitlines(keepends=True)
        offset = sum(len(x) for x in lines[:line - 1]) + col - 1
        offset = max(0, min(offset, len(source.text)))
        end = offset
        while end < len(source.text) and source.text[end] not in " =\n\r]":
            end += 1
        return cls(source, offset, max(end, offset + 1))

    def __str__(self) -> str:
        line, col = self.source.line_col(self.start)
        return f"{self.source.path}:{line}:{col}"

    def excerpt(self) -> str:
        """The source line with a caret under the span (first line of it only)."""
        line, col = self.source.line_col(self.start)
        text = self.source.line_text(line).replace("\t", " ")
        end_line, end_col = self.source.line_col(max(self.start, self.end - 1))
        width = max(1, end_col - col + 1) if end_line == line else max(1, len(text) - col + 1)
        width = min(width, max(1, len(text) - col + 1))
        if len(text) > _EXCERPT:   # a window around the caret, so that a message stays readable
            first = max(0, col - 1 - _EXCERPT // 2)
            window = text[first:first + _EXCERPT]
            prefix = "..." if first else ""
            suffix = "..." if first + _EXCERPT < len(text) else ""
            text = prefix + window + suffix
            col = col - first + len(prefix)
            width = min(width, len(window) - (col - 1 - len(prefix)))
        return f"  {text}\n  {' ' * (col - 1)}{'^' * max(1, width)}"


_EXCERPT = 100
"""Longest source line shown whole under an error; longer ones are cut around the caret."""


class CPlusError(Exception):
    """Root of every error the C+ tool chain reports to a user."""

    kind = "error"

    def __init__(self, message: str, loc: Location | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.loc = loc

    def render(self) -> str:
        if self.loc is None:
            return f"error: {self.message}"
        return f"{self.loc}: error: {self.message}\n{self.loc.excerpt()}"

    def __str__(self) -> str:
        return self.message if self.loc is None else f"{self.loc}: {self.message}"


class InputError(CPlusError):
    """The input file cannot be read as C+ text (missing, binary, not UTF-8)."""


class CPlusSyntaxError(CPlusError):
    """The text does not follow the grammar of C+."""


class IncludeError(CPlusError):
    """An ``:- include`` names a missing file or closes a cycle."""


class ResolveError(CPlusError):
    """An unknown or misused name: constant, object, sort, variable or macro."""


class SortError(ResolveError):
    """A term of the wrong sort, or a value outside a constant's domain."""


class GroundingError(CPlusError):
    """Something that only shows when variables are bound (division by zero, ...)."""


class OutOfMemoryError(GroundingError, MemoryError):
    """Grounding, encoding or solving ran out of memory (the address-space limit reached
    before any estimate said so): located at what was being built.  It is a
    :class:`MemoryError` too, so that a caller with a memory limit of its own (a batch job's)
    still sees the limit it set reached."""


class DefinitenessError(CPlusError):
    """A law whose head is not a literal: the causal theory would not be definite."""


class QueryError(CPlusError):
    """A malformed query, or a query label that does not exist."""


class Diagnostic(Record):
    """A warning: something accepted but probably not what the author meant."""

    _fields = ("message", "loc")
    __slots__ = _fields

    message: str
    loc: Location | None

    def __init__(self, message: str, loc: Location | None = None) -> None:
        self.message = message
        self.loc = loc

    def render(self) -> str:
        if self.loc is None:
            return f"warning: {self.message}"
        return f"{self.loc}: warning: {self.message}\n{self.loc.excerpt()}"


class Diagnostics:
    """Collects warnings; the CLI prints them, API users read :attr:`items`."""

    def __init__(self) -> None:
        self.items: list[Diagnostic] = []
        self._seen: set[tuple[str, int | None]] = set()

    def warn(self, message: str, loc: Location | None = None) -> None:
        key = (message, None if loc is None else loc.start)
        if key not in self._seen:
            self._seen.add(key)
            self.items.append(Diagnostic(message, loc))
