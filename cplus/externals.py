"""Loading user-defined external functions (``--extern file.py``).

CCALC evaluates external predicates such as the payload domain's ``collision/4`` in Prolog
while grounding.  Here an external is a Python callable registered by name and arity.
Only files named explicitly on the command line are executed; every public top-level
function of such a file becomes an external usable both as a predicate (in formulas,
truth of the result) and as a function (in terms, its integer or object result).
"""
from __future__ import annotations

import importlib.util
import inspect
import os

from cplus.errors import InputError
from cplus.resolve import External, Externals

__all__ = ["load_extern_file"]


def load_extern_file(path: str, registry: Externals) -> list[str]:
    """Execute ``path`` and register its public functions; returns their names."""
    if not os.path.isfile(path):
        raise InputError(f"no such extern file: '{path}'")
    name = "cplus_extern_" + os.path.splitext(os.path.basename(path))[0]
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise InputError(f"'{path}' is not a Python file")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        raise InputError(f"loading extern file '{path}' failed: {type(exc).__name__}: {exc}") from None
    added = []
    for fname, fn in vars(module).items():
        if fname.startswith("_") or not inspect.isfunction(fn) or fn.__module__ != name:
            continue
        params = inspect.signature(fn).parameters.values()
        if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params):
            raise InputError(f"extern '{fname}' in '{path}' must have a fixed number of arguments")
        registry.add(External(fname, len(list(params)), fn, None))
        added.append(fname)
    return added
