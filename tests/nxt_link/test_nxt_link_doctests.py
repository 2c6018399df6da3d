"""The examples in the nxt_link docstrings run as tests."""
from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["nxt_link.errors", "nxt_link.telegram", "nxt_link.framing", "nxt_link.clock",
           "nxt_link.stream_protocol", "nxt_link.brick", "nxt_link.execlog"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
