"""Where each key of a TOML document sits, so scene errors can say ``file:line:col``.

`tomllib` parses TOML but forgets positions. This module scans the same text once more and
maps every key path to the line and column of its key (or, for an array element, of the
element's first character). It runs only on text `tomllib` has already accepted, so it does not
need to diagnose syntax; it only needs to follow the structure: table headers, arrays of
tables, dotted keys, quoted keys, strings (with their escapes and multi-line forms), arrays
spanning lines, inline tables and comments.

Paths use the same shape as the parsed document: ``("robots", "r1", "arm_length")``,
``("obstacles", 0, "points", 2)`` for the third point of the first ``[[obstacles]]``.

>>> locs = locate_keys('[grid]\\nx_min = 0\\n[[obstacles]]\\npoints = [[0, 0], [1, 0]]\\n')
>>> locs[("grid", "x_min")], locs[("obstacles", 0, "points", 1)]
((2, 1), (4, 19))
"""

from __future__ import annotations

import math
import re
import tomllib
from abc import ABC, abstractmethod
from typing import Any

__all__ = ["KeyPath", "KeyPathReader", "MAX_INTEGER", "MAX_NUMBER", "integer_problem", "kind_of", "locate_keys",
           "nearest_location", "number_problem", "parse_toml", "toml_error"]

MAX_NUMBER = 1e9
"""The largest magnitude a number of a scene, world or binding file may have: a millimetre,
second, degree or grid unit a billion times over is a typo (and a value near ``1e308``
overflows to infinity in the first product, or costs a bignum as an integer)."""

MAX_INTEGER = 2 ** 31 - 1
"""The largest magnitude of an integer field unless its schema says less (an int32)."""

_LONG_DIGITS = re.compile(r"[0-9_]{4301,}")


def parse_toml(text: str) -> dict[str, Any]:
    """``tomllib.loads``, with the one ``ValueError`` it lets through made a
    :class:`tomllib.TOMLDecodeError` with a position: an integer of more than 4,300 digits
    (Python's limit on converting digit strings) would otherwise escape as a traceback."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        raise
    except ValueError:
        m = _LONG_DIGITS.search(text)
        pos = m.start() if m else 0
        line = text.count("\n", 0, pos) + 1
        col = pos - (text.rfind("\n", 0, pos) + 1) + 1
        raise tomllib.TOMLDecodeError(f"a number of more than 4300 digits (at line {line}, column {col})") from None


def number_problem(value: object, lo: float = -MAX_NUMBER, hi: float = MAX_NUMBER) -> str | None:
    """Why ``value`` is not a number in ``lo..hi`` (a phrase), or None. Integers are compared
    as they are (``float(10**400)`` raises), NaN and infinities are refused."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return f"must be a number, not {kind_of(value)}"
    if isinstance(value, float) and not math.isfinite(value):
        return f"must be finite, not {value}"
    if not lo <= value <= hi:
        return f"= {_short(value)} is outside {lo:g}..{hi:g}"
    return None


def integer_problem(value: object, lo: int = -MAX_INTEGER, hi: int = MAX_INTEGER) -> str | None:
    """Why ``value`` is not an integer in ``lo..hi`` (a phrase), or None."""
    if isinstance(value, bool) or not isinstance(value, int):
        return f"must be an integer, not {kind_of(value)}"
    if not lo <= value <= hi:
        return f"= {_short(value)} is outside {lo}..{hi}"
    return None


def _short(value: int | float) -> str:
    """A number for a message: a huge integer by its size, not its thousand digits."""
    if isinstance(value, int) and abs(value) >= 10 ** 15:
        return f"{'-' if value < 0 else ''}an integer of {len(str(abs(value)))} digits"
    return f"{value:g}" if isinstance(value, float) else str(value)

KeyPath = tuple[str | int, ...]

_BARE_KEY_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")


class _Scanner:
    """A cursor over the text that knows its line and column."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.pos = 0
        self.line = 1
        self.col = 1
        self.locations: dict[KeyPath, tuple[int, int]] = {}
        self.aot_counts: dict[KeyPath, int] = {}

    # -- low-level movement ------------------------------------------------------------
    def peek(self, n: int = 1) -> str:
        return self.text[self.pos : self.pos + n]

    def at_end(self) -> bool:
        return self.pos >= len(self.text)

    def advance(self, n: int = 1) -> None:
        for _ in range(n):
            if self.pos >= len(self.text):
                return
            if self.text[self.pos] == "\n":
                self.line += 1
                self.col = 1
            else:
                self.col += 1
            self.pos += 1

    def skip_blank(self, newlines: bool) -> None:
        """Skip spaces, tabs, comments and (when asked) line breaks."""
        while not self.at_end():
            ch = self.peek()
            if ch in " \t\r" or (newlines and ch == "\n"):
                self.advance()
            elif ch == "#":
                while not self.at_end() and self.peek() != "\n":
                    self.advance()
            else:
                return

    # -- tokens ------------------------------------------------------------------------
    def read_string(self) -> str:
        """Read a basic, literal or multi-line string and return its (roughly decoded) text."""
        quote = self.peek()
        triple = self.peek(3) == quote * 3
        delim = quote * 3 if triple else quote
        self.advance(len(delim))
        chars: list[str] = []
        while not self.at_end():
            if self.peek(len(delim)) == delim:
                # a multi-line string may end with up to two extra quotes
                while triple and self.peek(len(delim) + 1) == quote * (len(delim) + 1):
                    chars.append(quote)
                    self.advance()
                self.advance(len(delim))
                return "".join(chars)
            ch = self.peek()
            if quote == '"' and ch == "\\":
                chars.append(self.peek(2)[1:])
                self.advance(2)
                continue
            chars.append(ch)
            self.advance()
        return "".join(chars)

    def read_key(self) -> list[tuple[str, tuple[int, int]]]:
        """Read a possibly dotted key; return each part with its position."""
        parts: list[tuple[str, tuple[int, int]]] = []
        while True:
            self.skip_blank(newlines=False)
            start = (self.line, self.col)
            if self.peek() in ('"', "'"):
                parts.append((self.read_string(), start))
            else:
                begin = self.pos
                while not self.at_end() and self.peek() in _BARE_KEY_CHARS:
                    self.advance()
                parts.append((self.text[begin : self.pos], start))
            self.skip_blank(newlines=False)
            if self.peek() == ".":
                self.advance()
                continue
            return parts

    def skip_scalar(self) -> None:
        """Skip a number, boolean or date: everything up to a delimiter."""
        while not self.at_end() and self.peek() not in ",]}\n#":
            self.advance()

    # -- structure ---------------------------------------------------------------------
    def record(self, path: KeyPath, where: tuple[int, int]) -> None:
        self.locations.setdefault(path, where)

    def resolve(self, keys: list[str]) -> KeyPath:
        """Turn a header's keys into a path, entering the last element of arrays of tables."""
        out: list[str | int] = []
        for key in keys:
            out.append(key)
            count = self.aot_counts.get(tuple(out))
            if count is not None:
                out.append(count - 1)
        return tuple(out)

    def value(self, path: KeyPath) -> None:
        self.skip_blank(newlines=False)
        ch = self.peek()
        if ch in ('"', "'"):
            self.read_string()
        elif ch == "[":
            self.advance()
            index = 0
            while True:
                self.skip_blank(newlines=True)
                if self.at_end():
                    return
                if self.peek() == "]":
                    self.advance()
                    return
                if self.peek() == ",":
                    self.advance()
                    continue
                self.record(path + (index,), (self.line, self.col))
                self.value(path + (index,))
                index += 1
        elif ch == "{":
            self.advance()
            while True:
                self.skip_blank(newlines=True)
                if self.at_end():
                    return
                if self.peek() == "}":
                    self.advance()
                    return
                if self.peek() == ",":
                    self.advance()
                    continue
                self.key_value(path)
        else:
            self.skip_scalar()

    def key_value(self, table: KeyPath) -> None:
        parts = self.read_key()
        path = table
        for name, where in parts:
            path = path + (name,)
            self.record(path, where)
        self.skip_blank(newlines=False)
        if self.peek() == "=":
            self.advance()
        self.value(path)

    def header(self) -> KeyPath:
        where = (self.line, self.col)
        is_array = self.peek(2) == "[["
        self.advance(2 if is_array else 1)
        keys = [name for name, _ in self.read_key()]
        self.advance(2 if is_array else 1)
        if is_array:
            parent = self.resolve(keys[:-1])
            own = parent + (keys[-1],)
            index = self.aot_counts.get(own, 0)
            self.aot_counts[own] = index + 1
            self.record(own, where)
            path: KeyPath = own + (index,)
        else:
            path = self.resolve(keys)
        for end in range(1, len(path) + 1):  # parents first defined by this header
            self.record(path[:end], where)
        return path

    def document(self) -> dict[KeyPath, tuple[int, int]]:
        table: KeyPath = ()
        while True:
            self.skip_blank(newlines=True)
            if self.at_end():
                return self.locations
            if self.peek() == "[":
                table = self.header()
            else:
                before = self.pos
                self.key_value(table)
                if self.pos == before:  # not valid TOML; never loop forever
                    self.advance()


def locate_keys(text: str) -> dict[KeyPath, tuple[int, int]]:
    """Map each key path of a TOML document to the (line, col) where it is written.

    Tables defined by a header map to the header's position. Keys are recorded at their
    first occurrence.
    """
    return _Scanner(text).document()


def nearest_location(locations: dict[KeyPath, tuple[int, int]], path: KeyPath) -> tuple[int, int]:
    """The position of ``path``, or of its closest written ancestor, or (1, 1).

    A missing field has no position of its own; its table's header (or the file's start)
    is the best place to point at.
    """
    for end in range(len(path), 0, -1):
        where = locations.get(path[:end])
        if where is not None:
            return where
    return (1, 1)


def toml_error(exc: tomllib.TOMLDecodeError) -> tuple[str, int, int]:
    """``tomllib``'s complaint as ``("invalid TOML: ...", line, col)``: its message carries the
    position in words ("(at line 3, column 7)"), which a located error shows separately."""
    message = str(exc)
    m = re.search(r"\(at line (\d+), column (\d+)\)", message)
    line, col = (int(m.group(1)), int(m.group(2))) if m else (1, 1)
    bare = re.sub(r"\s*\(at (line \d+, column \d+|end of document)\)", "", message)
    return f"invalid TOML: {bare}", line, col


def kind_of(value: object) -> str:
    """What a TOML value is, for messages ("must be a number, not a string")."""
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


class KeyPathReader(ABC):
    """Reads a parsed TOML document by key path; the schema readers (scene, binding, world)
    add their typed accessors and say how a complaint is located (:meth:`fail`)."""

    def __init__(self, data: dict[str, Any], locations: dict[KeyPath, tuple[int, int]]) -> None:
        self.data = data
        self.locations = locations

    @abstractmethod
    def fail(self, path: KeyPath, message: str) -> Exception:
        """The schema's own error for ``message``, located at ``path``."""

    @staticmethod
    def show(path: KeyPath) -> str:
        out = ""
        for part in path:
            out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
        return out or "the top level"

    def has(self, path: KeyPath) -> bool:
        node: Any = self.data
        for part in path:
            if isinstance(node, dict) and isinstance(part, str) and part in node:
                node = node[part]
            elif isinstance(node, list) and isinstance(part, int) and part < len(node):
                node = node[part]
            else:
                return False
        return True

    def get(self, path: KeyPath) -> Any:
        node: Any = self.data
        for part in path:
            node = node[part]
        return node

    def require(self, path: KeyPath) -> Any:
        if not self.has(path):
            parent = path[:-1]
            raise self.fail(parent, f"missing required field '{path[-1]}' in {self.show(parent)}")
        return self.get(path)
