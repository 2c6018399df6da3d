"""``:- include``: the one statement that reads another file.

Kept apart because it is the only resolver that touches the file system (through the
``read`` callback and ``os.path``); an included file's statements then go through the same
statement loop as the main file's, so its declarations and macros hold in what follows.
"""
from __future__ import annotations

import os

from cplus import ast
from cplus.errors import IncludeError
from cplus.resolve.core import _Core

_INCLUDE_LIMIT = 64


class _Includes(_Core):
    def _st_Include(self, stmt: ast.Include) -> None:
        base_dir = os.path.dirname(self.stack[-1]) if not self.stack[-1].startswith("<") else os.getcwd()
        for name, loc in stmt.paths:
            path = self._find_include(name, base_dir)
            if path is None:
                raise IncludeError(f"cannot find included file '{name}'", loc)
            key = os.path.abspath(path)
            if key in self.stack:
                chain = " -> ".join(os.path.basename(p) for p in self.stack[self.stack.index(key):])
                raise IncludeError(f"include cycle: {chain} -> {os.path.basename(key)}", loc)
            if key in self.included:
                continue
            if len(self.stack) > _INCLUDE_LIMIT:
                raise IncludeError("includes nested too deeply", loc)
            self._file(self.read(path, loc), key)

    @staticmethod
    def _find_include(name: str, base_dir: str) -> str | None:
        candidates = [os.path.join(base_dir, name), name, os.path.join(base_dir, name + ".cp"), name + ".cp"]
        for c in candidates:
            if os.path.isfile(c):
                return c
        return None
