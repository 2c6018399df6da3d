#!/usr/bin/env python3
"""The ``clingo`` command the peer's tool chain (Cplus2ASP 4) calls, made of PyPI's clingo 5.

Installed as ``clingo`` on the peer's ``PATH`` by ``bench/build_peer.sh`` and run by the
interpreter of a virtual environment that has the ``clingo`` package; it is no part of cplus.
Two things stand between that tool chain and clingo 5:

* PyPI's package installs no ``clingo`` program, and ``python -m clingo`` grounds the base
  program once and solves it, ignoring ``#include <incmode>``; the tool chain needs clingo's own
  main loop, which an ``Application`` without a ``main`` method handed to ``clingo_main`` runs
  (``base`` and ``check(0)``, then ``step(t)`` and ``check(t)`` for t = 1, 2, ... until a model);
* the program it writes is still gringo 3 in two places: an additive fluent's sum
  ``#sum{V: contrib_F(..., ACTION, V, ...), ...}`` must become ``#sum{V,ACTION: ...}`` (clingo 5
  sums a *set* of tuples: two actions contributing the same amount would count once), and
  ``#show`` lines whose patterns have unbound variables are commented out.

The tool chain passes program files and options such as ``-c maxstep=7`` (sometimes as one
argument); files are rewritten into temporary copies, the options handed on as they are.
"""
from __future__ import annotations

import os
import re
import sys
import tempfile

SUM = re.compile(r"#sum\{(\w+):(contrib_\w+\([^)]*\bACTION\b)")
SHOW = re.compile(r"^(\s*#show\b[^.]*\b[A-Z]\w*[^.]*\.)", re.M)


def rewrite(program: str) -> str:
    """The program as clingo 5 reads it (see the module's docstring)."""
    program = SUM.sub(r"#sum{\1,ACTION:\2", program)
    return SHOW.sub(r"% \1", program)


def arguments(argv: list[str], workdir: str) -> list[str]:
    out: list[str] = []
    for i, arg in enumerate(argv):
        if arg.startswith("-c "):
            out += ["-c", arg[3:].strip()]
        elif not arg.startswith("-") and os.path.isfile(arg) and not (i and argv[i - 1] == "-c"):
            with open(arg) as f:
                text = rewrite(f.read())
            copy = os.path.join(workdir, f"{len(out)}-{os.path.basename(arg)}")
            with open(copy, "w") as f:
                f.write(text)
            out.append(copy)
        else:
            out.append(arg)
    return out


def main() -> int:
    from clingo.application import Application, clingo_main

    class Clingo(Application):
        """No ``main`` method: clingo's own main loop runs, incremental mode included."""
        program_name = "clingo"

    with tempfile.TemporaryDirectory(prefix="peer-clingo-") as work:
        return clingo_main(Clingo(), arguments(sys.argv[1:], work))


if __name__ == "__main__":
    raise SystemExit(main())
