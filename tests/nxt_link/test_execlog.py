"""Execution log: cplus.execlog/1 round trip and validation."""
from __future__ import annotations

import json

import pytest

from nxt_link.errors import ExecLogError
from nxt_link.execlog import BrickLog, ExecutionLog, LogEvent


def sample() -> ExecutionLog:
    return ExecutionLog((
        BrickLog("r1", ("A", "B"), 50, ((0, 0), (5, -3)), ((0, 0), (4, -2)),
                 (LogEvent(0.01, "link ok", "session 7"), LogEvent(1.5, "start acked"))),
        BrickLog("r2", ("C",), 50, ((0,), (1,)), ((0,), (1,)), ()),
    ), 0.012)


def test_round_trip():
    log = sample()
    text = log.dumps()
    assert json.loads(text)["format"] == "cplus.execlog/1"
    assert ExecutionLog.loads(text) == log
    assert log.brick("r1").tracking_error_deg == ((0, 0), (-1, 1))


def mutate(path: list, value) -> str:
    data = sample().to_json()
    target = data
    for key in path[:-1]:
        target = target[key]
    if value is KeyError:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return json.dumps(data)


@pytest.mark.parametrize("path, value, message", [
    (["format"], "cplus.execlog/2", "format: expected 'cplus.execlog/1'"),
    (["bricks"], [], "bricks: must be a non-empty list"),
    (["bricks", 0, "name"], "", r"bricks\[0\].name"),
    (["bricks", 1, "name"], "r1", "duplicate brick 'r1'"),
    (["bricks", 0, "ports"], ["A", "D"], r"bricks\[0\].ports"),
    (["bricks", 0, "tick_ms"], 0, r"bricks\[0\].tick_ms"),
    (["bricks", 0, "measured_deg", 1], [4], r"bricks\[0\].measured_deg\[1\]: must be 2 integers"),
    (["bricks", 0, "measured_deg", 1], [4, 1.5], r"measured_deg\[1\]"),
    (["bricks", 0, "measured_deg"], [[0, 0]], "2 reference rows but 1 measured rows"),
    (["bricks", 0, "events", 0, "t_s"], "soon", r"events\[0\]"),
    (["start_skew_bound_s"], -1, "start_skew_bound_s"),
    (["bricks", 0, "reference_deg"], KeyError, r"reference_deg: must be a list"),
])
def test_loader_names_the_offending_field(path, value, message):
    with pytest.raises(ExecLogError, match=message):
        ExecutionLog.loads(mutate(path, value))


def test_not_json_is_one_clear_error():
    with pytest.raises(ExecLogError, match="not JSON"):
        ExecutionLog.loads("{oops")
