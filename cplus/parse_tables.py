"""Where the C+ parser's tables come from: the grammar file, lark's parser of it (kept in the
user's cache directory), and the tables :mod:`cplus.lalr` parses with, read from that cache
without importing lark.

Apart from the parser (:mod:`cplus.parser`) because this is the part that touches the file
system and lark, and the part whose cost every command pays at start-up.
"""
from __future__ import annotations

import os
from functools import lru_cache
from typing import TYPE_CHECKING

from cplus import lalr

if TYPE_CHECKING:
    from lark import Lark


_GRAMMAR = os.path.join(os.path.dirname(__file__), "grammar", "cplus.lark")
"""The grammar (paths are strings here: importing pathlib would cost every command 5 ms)."""

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
