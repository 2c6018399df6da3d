"""Loading user-defined external functions (``--extern file.py``).

CCALC evaluates external predicates such as the payload domain's ``collision/4`` in Prolog
while grounding.  Here an external is a Python callable registered by name and arity.
Only files named explicitly on the command line are executed; every public top-level
function of such a file becomes an external usable both as a predicate (in formulas, it
must return True or False) and as a function (in terms, an integer or an object of the
domain); the grounder checks what it returns (:func:`cplus.ground.compile.compile_term`).

What such a file prints must not mix with a command's output (``--json``, DIMACS on
standard output): while it is loaded and while each of its functions runs, standard output
is standard error, at the file-descriptor level (:func:`stdout_to_stderr`), so that a C
extension's ``printf`` or a child process it starts is diverted too.  The switch is
process-wide: another thread's output in those moments goes to standard error as well.
"""
from __future__ import annotations

import contextlib
import functools
import importlib.util
import inspect
import os
import sys
import threading
from collections.abc import Callable, Iterator

from cplus.errors import InputError
from cplus.resolve import External, Externals

__all__ = ["load_extern_file", "stdout_to_stderr"]

_SWITCH = threading.RLock()


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Standard output goes to standard error meanwhile: Python's ``sys.stdout`` and file
    descriptor 1 (what was written before is flushed to the real standard output first; what
    was written meanwhile, C's buffers included, is flushed before it is switched back)."""
    with _SWITCH:
        out = sys.stdout
        _flush(out)
        saved = _divert()
        sys.stdout = sys.stderr
        try:
            yield
        finally:
            sys.stdout = out
            _flush(sys.stderr)
            _flush_c()
            if saved is not None:
                os.dup2(saved, 1)
                os.close(saved)


def _flush(stream) -> None:
    try:
        stream.flush()
    except (OSError, ValueError, AttributeError):   # closed, or not a stream: nothing to keep
        pass


def _divert() -> int | None:
    """File descriptor 1 pointed at 2; returns a copy of the old one (None when either is not open)."""
    try:
        saved = os.dup(1)
    except OSError:
        return None
    try:
        os.dup2(2, 1)
    except OSError:
        os.close(saved)
        return None
    return saved


_LIBC: list = []


def _flush_c() -> None:
    """``fflush(NULL)``: what C code buffered for standard output is written while it still
    points at standard error."""
    if not _LIBC:
        try:
            import ctypes
            _LIBC.append(ctypes.CDLL(None).fflush)
        except (ImportError, OSError, AttributeError):  # pragma: no cover - no C library to ask
            _LIBC.append(None)
    if _LIBC[0] is not None:
        _LIBC[0](None)


def _diverted(fn: Callable) -> Callable:
    """``fn`` with its standard output sent to standard error."""
    @functools.wraps(fn)
    def external(*args):
        with stdout_to_stderr():
            return fn(*args)
    return external


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
        with stdout_to_stderr():
            spec.loader.exec_module(module)
    except Exception as exc:
        raise InputError(f"loading extern file '{path}' failed: {type(exc).__name__}: {exc}") from None
    except SystemExit as exc:
        raise InputError(f"loading extern file '{path}' tried to end the program (sys.exit({exc.code!r}))") from None
    added = []
    for fname, fn in vars(module).items():
        if fname.startswith("_") or not inspect.isfunction(fn) or fn.__module__ != name:
            continue
        params = inspect.signature(fn).parameters.values()
        if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params):
            raise InputError(f"extern '{fname}' in '{path}' must have a fixed number of arguments")
        registry.add(External(fname, len(list(params)), _diverted(fn), None))
        added.append(fname)
    return added
