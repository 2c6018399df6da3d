"""Reading C+ files from disk: the I/O edge of the front end.

:func:`load_program` reads a file, follows its includes and returns the resolved
:class:`~cplus.program.Program`.  Files must be UTF-8 text (a byte-order mark is allowed);
binary input and undecodable bytes are reported with their position instead of a traceback.
The path ``-`` is standard input.  Only regular files and pipes are read, and at most
:data:`~cplus.limits.MAX_FILE_BYTES` of them: ``/dev/zero`` or a terminal device is refused
by its type, a huge file by its size, before anything is read.
"""
from __future__ import annotations

import os
import stat
import sys

from cplus import ast
from cplus.errors import Diagnostics, InputError, Location, Source
from cplus.limits import MAX_FILE_BYTES, count
from cplus.parser import parse_program
from cplus.program import Program
from cplus.resolve import BUILTIN_EXTERNALS, Externals, resolve

__all__ = ["read_text", "load_program", "load_text", "STDIN", "display_name"]

STDIN = "-"
"""The path that means standard input."""

_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a directory"))


def read_text(path: str, loc: Location | None = None) -> str:
    """The text of a C+ file (``-``: standard input); ``loc`` is where it was included from."""
    if path == STDIN:
        try:
            data = _read_capped(sys.stdin.buffer, "standard input", loc)
        except (AttributeError, OSError, ValueError) as exc:   # no stdin, or a closed one
            raise InputError(f"cannot read standard input ({exc})", loc) from None
        path = display_name(path)
    else:
        data = _read_file(path, loc)
    if b"\x00" in data:
        at = data.index(b"\x00")
        raise InputError(f"'{path}' looks like a binary file (NUL byte at offset {at}), not C+ text",
                         _byte_loc(path, data, at) or loc)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"'{path}' is not UTF-8 text (byte 0x{data[exc.start]:02x})",
                         _byte_loc(path, data, exc.start) or loc) from None


def _read_file(path: str, loc: Location | None) -> bytes:
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"no such file: '{path}'", loc) from None
    except OSError as exc:
        raise InputError(f"cannot read '{path}': {exc.strerror}", loc) from None
    for test, kind in _KINDS:
        if test(info.st_mode):
            raise InputError(f"'{path}' is {kind}, not a C+ file", loc)
    if stat.S_ISREG(info.st_mode) and info.st_size > MAX_FILE_BYTES:
        raise InputError(f"'{path}' has {count(info.st_size)} bytes; a C+ file may have at most "
                         f"{count(MAX_FILE_BYTES)}", loc)
    try:
        with open(path, "rb") as fh:
            return _read_capped(fh, f"'{path}'", loc)
    except OSError as exc:
        raise InputError(f"cannot read '{path}': {exc.strerror}", loc) from None


def _read_capped(stream, name: str, loc: Location | None) -> bytes:
    """At most MAX_FILE_BYTES from a stream (a pipe says its size only by ending)."""
    data = stream.read(MAX_FILE_BYTES + 1)
    if len(data) > MAX_FILE_BYTES:
        raise InputError(f"{name} has more than {count(MAX_FILE_BYTES)} bytes, the limit for a C+ file", loc)
    return data


def display_name(path: str) -> str:
    """How a file is named in messages: relative to the working directory when below it."""
    if path == STDIN:
        return "<stdin>"
    rel = os.path.relpath(path)
    return rel if not rel.startswith("..") else path


def _byte_loc(path: str, data: bytes, at: int) -> Location | None:
    prefix = data[:at].decode("utf-8", errors="replace")
    text = data.decode("utf-8", errors="replace")
    return Location(Source(path, text), len(prefix), len(prefix) + 1)


def _reader(diagnostics: Diagnostics):
    def read(path: str, loc: Location | None) -> ast.ParsedFile:
        return parse_program(read_text(path, loc), display_name(path), diagnostics)
    return read


def load_program(path: str, externals: Externals | None = None,
                 diagnostics: Diagnostics | None = None) -> Program:
    """Parse and resolve a C+ file and everything it includes."""
    diagnostics = diagnostics if diagnostics is not None else Diagnostics()
    main = parse_program(read_text(path), display_name(path), diagnostics)
    return resolve(main, _reader(diagnostics), externals or BUILTIN_EXTERNALS, diagnostics)


def load_text(text: str, path: str = "<input>", externals: Externals | None = None,
              diagnostics: Diagnostics | None = None) -> Program:
    """Resolve C+ source given as a string (includes are read relative to the cwd)."""
    diagnostics = diagnostics if diagnostics is not None else Diagnostics()
    main = parse_program(text, path, diagnostics)
    return resolve(main, _reader(diagnostics), externals or BUILTIN_EXTERNALS, diagnostics)
