"""Resolve parsed statements into a :class:`~cplus.program.Program`.

Statements are processed in order, as CCALC reads them: declarations fill the
:class:`~cplus.signature.Signature`, macros are expanded at every later use (on the syntax
tree, so precedence is kept), includes are followed (relative to the including file;
repeats are ignored, cycles are errors), names are bound, and each law is classified and
expanded into basic laws.  The only I/O is through the ``read`` callback that returns an
included file's parsed statements.

One module per kind of statement (``declarations``, ``macros``, ``includes``, ``laws``,
``queries``, ``show``), over the expressions they share (``terms``, ``formulas``) and one
state (``core``, which also checks the finished domain); the external functions a law may
call are in ``registry``. The resolvers are mixins of one object rather than classes passing
a context around because they are not independent: every statement reads and extends the
same signature, macros and variables, and terms, sorts and integer expressions call one
another (``var(s, k)`` names a sort, a sort ``lo..hi`` has integer bounds). As mixins each
keeps its methods and ``self.sig`` exactly as one class had them, a statement still reaches
its ``_st_<Kind>`` method by one ``getattr``, and nothing is added to a call on the path
every law takes.
"""
from __future__ import annotations

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

__all__ = ["resolve", "External", "Externals", "BUILTIN_EXTERNALS", "Reader"]


def resolve(main: ast.ParsedFile, read: Reader, externals: Externals | None = None,
            diagnostics: Diagnostics | None = None) -> Program:
    """Resolve a parsed file (and everything it includes) into a Program."""
    r = _Resolver(read, externals or BUILTIN_EXTERNALS, diagnostics or Diagnostics())
    r.run(main)
    return r.program


class _Resolver(_Includes, _Declarations, _Laws, _Queries, _Show):
    """Every statement resolver, over the one state of :class:`~cplus.resolve.core._Core`."""
