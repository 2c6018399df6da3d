"""The examples in the trajectory package's docstrings run and give what they show.

Every module has at least one example, so a module whose examples were lost (or never
collected) fails here instead of passing with nothing checked.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import trajectory

MODULES = sorted(m.name for m in pkgutil.iter_modules(trajectory.__path__, "trajectory."))


def test_every_module_is_listed() -> None:
    assert "trajectory.checker" in MODULES and "trajectory.scene" in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no docstring examples"
    assert result.failed == 0
