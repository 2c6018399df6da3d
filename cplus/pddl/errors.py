"""The error of PDDL input, apart from the reader and the translation so that both raise it
without importing each other."""
from __future__ import annotations

from cplus.errors import CPlusError

__all__ = ["PddlError"]


class PddlError(CPlusError):
    """A PDDL file that cannot be read, or asks for what cplus does not translate."""
