"""Reading C+ files from disk: the I/O edge of the front end.

:func:`load_program` reads a file, follows its includes and returns the resolved
:class:`~cplus.program.Program`.  Files must be UTF-8 text; binary input and undecodable
bytes are reported with their position instead of a traceback.
"""
from __future__ import annotations

import os

from cplus import ast
from cplus.errors import Diagnostics, InputError, Location, Source
from cplus.parser import parse_program
from cplus.program import Program
from cplus.resolve import BUILTIN_EXTERNALS, Externals, resolve

__all__ = ["read_text", "load_program", "load_text"]


def read_text(path: str, loc: Location | None = None) -> str:
    """The text of a C+ file; ``loc`` is where it was included from (for errors)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except FileNotFoundError:
        raise InputError(f"no such file: '{path}'", loc) from None
    except IsADirectoryError:
        raise InputError(f"'{path}' is a directory, not a C+ file", loc) from None
    except OSError as exc:
        raise InputError(f"cannot read '{path}': {exc.strerror}", loc) from None
    if b"\x00" in data:
        at = data.index(b"\x00")
        raise InputError(f"'{path}' looks like a binary file (NUL byte at offset {at}), not C+ text",
                         _byte_loc(path, data, at) or loc)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"'{path}' is not UTF-8 text (byte 0x{data[exc.start]:02x})",
                         _byte_loc(path, data, exc.start) or loc) from None


def _byte_loc(path: str, data: bytes, at: int) -> Location | None:
    prefix = data[:at].decode("utf-8", errors="replace")
    text = data.decode("utf-8", errors="replace")
    return Location(Source(path, text), len(prefix), len(prefix) + 1)


def _reader(diagnostics: Diagnostics):
    def read(path: str, loc: Location | None) -> ast.ParsedFile:
        return parse_program(read_text(path, loc), _display(path), diagnostics)
    return read


def _display(path: str) -> str:
    rel = os.path.relpath(path)
    return rel if not rel.startswith("..") else path


def load_program(path: str, externals: Externals | None = None,
                 diagnostics: Diagnostics | None = None) -> Program:
    """Parse and resolve a C+ file and everything it includes."""
    diagnostics = diagnostics if diagnostics is not None else Diagnostics()
    main = parse_program(read_text(path), _display(path), diagnostics)
    return resolve(main, _reader(diagnostics), externals or BUILTIN_EXTERNALS, diagnostics)


def load_text(text: str, path: str = "<input>", externals: Externals | None = None,
              diagnostics: Diagnostics | None = None) -> Program:
    """Resolve C+ source given as a string (includes are read relative to the cwd)."""
    diagnostics = diagnostics if diagnostics is not None else Diagnostics()
    main = parse_program(text, path, diagnostics)
    return resolve(main, _reader(diagnostics), externals or BUILTIN_EXTERNALS, diagnostics)
