"""The examples in the docstrings of the public entry points run as tests."""
from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["cplus", "cplus.api", "cplus.planner", "cplus.parser", "cplus.ground.pf", "cplus.ground.equations",
           "cplus.ground.arith", "cplus.sat.solver"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
