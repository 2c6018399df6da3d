"""Hostile input on the robot surfaces (issue 19): every item is refused before anything moves
with a located ``file:line:col: error:`` or a one-line message and exit code 2, in bounded time
and memory, and never with a traceback. Each test reads what a user reads: the exit code and
the stderr line, through the CLI's main function."""
from __future__ import annotations

import io
import shutil
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cplus.cli import main
from cplus.errors import Source
from cplus.robot.online import events as ev

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery"


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


@pytest.fixture
def delivery(tmp_path) -> Path:
    """A copy of the delivery domain, its binding and world (so tests may edit them)."""
    for name in ("delivery.cp", "robot.toml", "world.toml"):
        shutil.copy(DELIVERY / name, tmp_path / name)
    return tmp_path / "delivery.cp"


# -- --events --------------------------------------------------------------------------------

@pytest.mark.parametrize("cycle", ["@²", "@٣", "@" + "9" * 5000, "@1000000001", "@0", "@-1", "@"])
def test_an_event_file_cycle_that_is_not_ascii_digits_in_range_is_located(delivery, tmp_path, capsys, cycle):
    events = tmp_path / "ev.txt"
    events.write_text(f"# a comment\n{cycle} press\n", encoding="utf-8")
    code, _, err = run(["online", str(delivery), "--simulate", "--events", str(events)], capsys)
    assert code == 2
    assert err.startswith(f"{events}:2:1: error: '{cycle[:60]}") and "whole number from 1 to 1000000000" in err


def test_a_bad_line_on_standard_input_is_noted_and_later_lines_still_count(delivery, capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.StringIO("@² press\n" + "x" * (ev.MAX_LINE + 5) + "\n@2 press\n"))
    code, _, err = run(["online", str(delivery), "--simulate", "--events", "-"], capsys)
    assert code == 0
    assert "ignored <stdin> line 1: '@²': a cycle is written @N" in err
    assert f"ignored <stdin> line 2: longer than {ev.MAX_LINE} characters" in err
    assert "events press | replan (after press" in err      # line 3 arrived: the reader lived on


def test_a_line_of_standard_input_that_is_not_utf8_is_noted(delivery, capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(b"\xff\xfe press\n@2 press\n"), encoding="utf-8"))
    code, _, err = run(["online", str(delivery), "--simulate", "--events", "-"], capsys)
    assert code == 0 and "ignored <stdin> line 1: not UTF-8 text" in err and "events press" in err


def test_a_long_event_file_costs_linear_work(delivery, tmp_path, capsys, monkeypatch):
    """20,000 lines due at once: delivering them never compares lines with each other (taking
    the due lines out of a list by equality made 4,000 lines take 41 s)."""
    compared = []
    monkeypatch.setattr(ev.EventLine, "__eq__", lambda self, other: compared.append(1) or self is other)
    events = tmp_path / "ev.txt"
    events.write_text("press\n" * 20000 + "@3 press\n" * 20000)
    code, _, err = run(["online", str(delivery), "--simulate", "--events", str(events), "--quiet"], capsys)
    assert code == 0 and len(compared) < 1000


@given(st.text(max_size=40) | st.text(st.sampled_from("@ press()#\t1230²٣\u0966"), max_size=20))
def test_any_event_line_parses_or_is_a_located_error(text):
    try:
        line = ev.parse_line(text, Source("ev.txt", text))
    except ev.EventsError as exc:
        assert exc.loc is not None
        return
    if line is not None:
        assert line.cycle is None or 1 <= line.cycle <= ev.MAX_CYCLE
        assert line.events


@given(st.integers(min_value=-10, max_value=10 ** 12))
def test_every_cycle_in_range_is_read_and_every_other_refused(n):
    text = f"@{n} press"
    try:
        line = ev.parse_line(text, Source("ev.txt", text))
    except ev.EventsError:
        assert not 1 <= n <= ev.MAX_CYCLE
    else:
        assert line is not None and line.cycle == n
