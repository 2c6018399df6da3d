"""The examples in the nxt_link docstrings run as tests."""
from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["nxt_link.wire.errors", "nxt_link.wire.telegram", "nxt_link.wire.reply_checks", "nxt_link.wire.framing", "nxt_link.wire.clock",
           "nxt_link.programs.stream_protocol", "nxt_link.host.brick", "nxt_link.host.execlog"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
