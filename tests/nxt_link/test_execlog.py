"""Execution log: cplus.execlog/1 round trip and validation."""
from __future__ import annotations

import json

import pytest

from nxt_link.host.execlog import BrickLog, ExecutionLog, LogEvent, Stopped
from nxt_link.wire.errors import ExecLogError


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


def incomplete() -> ExecutionLog:
    return ExecutionLog((
        BrickLog("r1", ("A",), 50, ((0,), (5,), (9,)), ((0,), None), (), (1.0, 1.02), "log"),
        BrickLog("r2", ("C",), 50, ((0,), (1,), (2,)), (), (), (1.01, 1.05), "run"),
    ), 0.05, Stopped(3.2, "brick r2: no valid answer from the brick program for 10 s", "r2"))


def test_an_incomplete_log_round_trips_with_its_reason_and_time():
    log = incomplete()
    data = json.loads(log.dumps())
    assert data["complete"] is False
    assert data["stopped"] == {"t_s": 3.2, "reason": "brick r2: no valid answer from the brick "
                                                     "program for 10 s", "brick": "r2"}
    assert data["bricks"][0]["measured_deg"] == [[0], None]
    assert ExecutionLog.loads(log.dumps()) == log
    assert log.brick("r1").measured_ticks == (0,) and log.brick("r1").tracking_error_deg == ((0,),)


def test_a_complete_log_has_every_row():
    with pytest.raises(ExecLogError, match="a row is missing in a complete log"):
        ExecutionLog((BrickLog("r1", ("A",), 50, ((0,), (1,)), ((0,), None), ()),))
    data = incomplete().to_json()
    data["complete"] = True
    with pytest.raises(ExecLogError, match=r"measured_deg\[1\]: must be 1 integers"):
        ExecutionLog.from_json(data)
    old = sample().to_json()
    del old["complete"]  # files written before "complete" existed are complete
    assert ExecutionLog.from_json(old).complete


@pytest.mark.parametrize("key, value, message", [
    ("stopped", None, "an incomplete log needs stopped"),
    ("time_scale", 0, "time_scale: must be a number > 0"),
    ("complete", "no", "complete: must be true or false"),
])
def test_incomplete_logs_validate(key, value, message):
    data = incomplete().to_json()
    data[key] = value
    with pytest.raises(ExecLogError, match=message):
        ExecutionLog.from_json(data)
    data = incomplete().to_json()
    data["bricks"][0]["start_s"] = [2.0, 1.0]
    with pytest.raises(ExecLogError, match=r"bricks\[0\].start_s"):
        ExecutionLog.from_json(data)


def test_start_skew_from_the_start_windows():
    skew = incomplete().start_skew()
    assert skew.estimate == pytest.approx(0.02)  # middles 1.01 and 1.03
    assert skew.min == 0.0 and skew.max == pytest.approx(0.05)
    scaled = ExecutionLog(incomplete().bricks, 0.5, incomplete().stopped, time_scale=10)
    assert scaled.start_skew().estimate == pytest.approx(0.2)  # the bricks' seconds
    assert sample().start_skew() is None  # no windows
