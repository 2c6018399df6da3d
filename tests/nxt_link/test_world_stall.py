"""A motor that stalls mid-trajectory (``--stall PORT@SECONDS[+DURATION]``)."""
from __future__ import annotations

import pytest

from nxt_link.emulator.stall import Stall
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming

OPTIONS = ExecutionOptions(timing=SessionTiming(ack_timeout_s=0.3, max_silent_s=5.0,
                                                homing_timeout_s=3.0))


def ramp(n: int) -> tuple[tuple[int, int], ...]:
    """Port A and B both turn steadily: 4 degrees per 50 ms tick (80 deg/s)."""
    return tuple((4 * k, 4 * k) for k in range(n))


def run(rig, stalls: tuple[Stall, ...], n: int = 60):
    rig.add("r1", stalls=stalls)
    stream = SetpointStream("r1", ("A", "B"), 50, ramp(n))
    log = execute_streams([stream], rig.bricks, options=OPTIONS)
    return log.brick("r1"), rig.emulators["r1"]


def test_a_stalled_motor_stops_following_and_the_error_grows(rig):
    b, emu = run(rig, (Stall(port=0, after_s=1.0),))
    schedule = emu.stalls[0]
    assert schedule.active and schedule.moved_at_ms is not None
    a = [row[0] for row in b.measured_deg]
    other = [row[1] - ref[1] for row, ref in zip(b.measured_deg, b.reference_deg)]
    # port A: frozen about 1 s (20 ticks) after it started to turn, at about 80 degrees
    assert 60 <= a[-1] <= 100 and a[-1] == a[-10] == a[-25]
    err_a = [ref[0] - row[0] for row, ref in zip(b.measured_deg, b.reference_deg)]
    assert max(map(abs, err_a[:15])) <= 15 and err_a[-1] >= 100
    # the other motor does not notice
    assert max(map(abs, other)) <= 15
    # the brick's own largest-error figure (QUERY) shows it too
    assert emu.program.max_err >= 100


def test_a_stall_with_a_duration_releases_the_motor(rig):
    b, emu = run(rig, (Stall(port=1, after_s=0.5, duration_s=0.5),), n=80)
    assert emu.stalls[0].ended
    err = [ref[1] - row[1] for row, ref in zip(b.measured_deg, b.reference_deg)]
    assert max(err) >= 30  # held for half a second while the reference moved on
    assert abs(err[-1]) <= 15  # then it caught up


def test_a_motor_that_never_turns_never_stalls(rig):
    rig.add("r1", stalls=(Stall(port=2, after_s=0.1),))
    stream = SetpointStream("r1", ("A",), 50, tuple((4 * k,) for k in range(20)))
    execute_streams([stream], rig.bricks, options=OPTIONS)
    assert rig.emulators["r1"].stalls[0].moved_at_ms is None


@pytest.mark.parametrize("text, stall", [
    ("A@2.5", Stall(0, 2.5)), ("c@0", Stall(2, 0.0)), (" B @ 1 + 0.25 ", Stall(1, 1.0, 0.25)),
])
def test_parse(text, stall):
    assert Stall.parse(text) == stall
    assert Stall.parse(str(stall)) == stall


@pytest.mark.parametrize("text", ["", "A", "A@", "D@1", "A@-1", "A@1+", "A@1+-2", "A@inf",
                                  "A@1.2.3"])
def test_parse_refuses_nonsense(text):
    with pytest.raises(ValueError, match="PORT@SECONDS|seconds|stall"):
        Stall.parse(text)
