"""Resolve parsed statements into a :class:`~cplus.program.Program`.

Statements are processed in order, as CCALC reads them: declarations fill the
:class:`~cplus.signature.Signature`, macros are expanded at every later use (on the syntax
tree, so precedence is kept), includes are followed (relative to the including file;
repeats are ignored, cycles are errors), names are bound, and each law is classified and
expanded into basic laws.  The only I/O is through the ``read`` callback that returns an
included file's parsed statements.
"""
from __future__ import annotations

import os

from cplus import ast
from cplus.errors import Diagnostics
from cplus.program import Program
from cplus.resolve.core import Reader
from cplus.resolve.declarations import _Declarations
from cplus.resolve.includes import _Includes
from cplus.resolve.laws import _Laws
from cplus.resolve.queries import _Queries
from cplus.resolve.registry import BUILTIN_EXTERNALS, External, Externals
from cplus.resolve.show import _Show
from cplus.resolve.validate import _EndChecks

__all__ = ["resolve", "External", "Externals", "BUILTIN_EXTERNALS", "Reader"]


def resolve(main: ast.ParsedFile, read: Reader, externals: Externals | None = None,
            diagnostics: Diagnostics | None = None) -> Program:
    """Resolve a parsed file (and everything it includes) into a Program."""
    r = _Resolver(read, externals or BUILTIN_EXTERNALS, diagnostics or Diagnostics())
    r.run(main)
    return r.program


class _Resolver(_Includes, _Declarations, _Laws, _Queries, _Show, _EndChecks):
    # ------------------------------------------------------------------ driver
    def run(self, main: ast.ParsedFile) -> None:
        path = main.source.path  # type: ignore[attr-defined]
        self._file(main, os.path.abspath(path) if not path.startswith("<") else path)
        self._finish()
