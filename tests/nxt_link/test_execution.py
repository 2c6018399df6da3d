"""execute_streams against in-memory emulated bricks: exact delivery, faults, refusals."""
from __future__ import annotations

import math

import pytest

from nxt_link.emulator.emulator import FaultParams
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import BrickSession, SessionTiming
from nxt_link.programs.stream_protocol import State
from nxt_link.wire import errors

TIMING = SessionTiming(ack_timeout_s=0.3, max_silent_s=5.0, homing_timeout_s=3.0)
OPTIONS = ExecutionOptions(timing=TIMING)


def two_streams(wave, n: int = 120) -> list[SetpointStream]:
    return [SetpointStream("r1", ("A", "B"), 50, wave(n, (120, 90))),
            SetpointStream("r2", ("A", "C"), 50, wave(n, (-100, 45)))]


def rms(values: list[int]) -> float:
    return math.sqrt(sum(v * v for v in values) / len(values))


def test_two_bricks_follow_their_setpoints(rig, wave):
    rig.add("r1")
    rig.add("r2")
    progress = []
    log = execute_streams(two_streams(wave), rig.bricks, options=OPTIONS,
                          on_progress=progress.append)
    for stream in two_streams(wave):
        b = log.brick(stream.brick)
        # the brick followed exactly the setpoints sent, and its log has one row per tick
        assert rig.emulators[stream.brick].program.reference_rows() == list(stream.rows)
        assert b.reference_deg == stream.rows
        assert b.measured_deg == tuple(rig.emulators[stream.brick].program.measured_rows())
        errs = [e for row in b.tracking_error_deg for e in row]
        assert max(map(abs, errs)) <= 25 and rms(errs) <= 12
        assert [e.event for e in b.events] == [
            "link ok", "upload verified", "homing", "ready", "start sent", "start acked",
            "log read"]
    phases = [p.phase for p in progress if p.brick == "r1"]
    assert phases[0] == "connect" and phases[-1] == "done"
    for name in ("upload", "homing", "start", "run", "log"):
        assert name in phases
    run = [p.done for p in progress if p.brick == "r1" and p.phase == "run"]
    assert run == sorted(run) and run[-1] == 120
    assert log.start_skew_bound_s <= 0.05


def test_drops_corruption_and_a_disconnect_lose_and_duplicate_nothing(rig, wave):
    faults = FaultParams(drop=0.15, corrupt=0.05, disconnect_after=25, seed=7)
    rig.add("r1", faults=faults)
    rig.add("r2", faults=FaultParams(drop=0.15, corrupt=0.05, disconnect_after=60, seed=8))
    log = execute_streams(two_streams(wave), rig.bricks, options=OPTIONS)
    for stream in two_streams(wave):
        emu = rig.emulators[stream.brick]
        st = emu.stats
        frames = st.frames_in + st.frames_out + st.dropped_out
        assert (st.dropped_in + st.dropped_out) / frames >= 0.10
        assert st.disconnects == 1
        # after recovery the brick holds exactly the setpoints sent, in order
        assert emu.program.reference_rows() == list(stream.rows)
        b = log.brick(stream.brick)
        assert b.measured_deg == tuple(emu.program.measured_rows())
        events = [e.event for e in b.events]
        assert "reconnected" in events and "timeout" in events
        errs = [e for row in b.tracking_error_deg for e in row]
        assert max(map(abs, errs)) <= 25


def test_program_is_started_when_nothing_runs(rig):
    rig.add("r1", program_running=False)
    stream = SetpointStream("r1", ("B",), 20, tuple((k,) for k in range(50)))
    log = execute_streams([stream], rig.bricks, options=OPTIONS)
    assert log.brick("r1").events[0].event == "program started"
    assert rig.emulators["r1"].firmware.program_name == "cplus_follow.rxe"


def test_missing_program_is_a_clear_error(rig):
    rig.add("r1", program_running=False)
    rig.emulators["r1"].firmware.files.clear()
    stream = SetpointStream("r1", ("A",), 50, ((0,), (1,)))
    with pytest.raises(errors.ExecutionFailed) as info:
        execute_streams([stream], rig.bricks, options=OPTIONS)
    assert isinstance(info.value.__cause__, errors.StreamError)
    assert str(info.value).startswith("brick r1 has no cplus_follow.rxe: compile")
    assert info.value.brick == "r1" and info.value.log.brick("r1").reached == "connect"


def test_other_program_running_is_a_clear_error(rig):
    rig.add("r1", program_running=False)
    fw = rig.emulators["r1"].firmware
    fw.files.add("tetris.rxe")
    fw.start_program_now("tetris.rxe")
    with pytest.raises(errors.ExecutionFailed, match="is running 'tetris.rxe', not"):
        execute_streams([SetpointStream("r1", ("A",), 50, ((0,),))], rig.bricks, options=OPTIONS)


def test_brick_that_does_not_answer_is_a_timeout(rig):
    rig.add("r1", faults=FaultParams(delay_ms=5000))
    with pytest.raises(errors.ExecutionFailed, match="brick r1 did not answer") as info:
        execute_streams([SetpointStream("r1", ("A",), 50, ((0,),))], rig.bricks, options=OPTIONS)
    assert isinstance(info.value.__cause__, errors.LinkTimeoutError)


@pytest.mark.parametrize("streams, message", [
    ([SetpointStream("r1", ("A",), 50, ((0,), (0,), (80,)))], "needs 1600 deg/s"),
    ([SetpointStream("r3", ("A",), 50, ((0,),))], "stream 'r3' has no brick"),
    ([SetpointStream("r1", ("A",), 50, ((0,),)), SetpointStream("r1", ("B",), 50, ((0,),))],
     "two streams for brick 'r1'"),
    ([SetpointStream("r1", ("A",), 50, ((0,),)), SetpointStream("r2", ("A",), 50, ((0,), (0,)))],
     "different durations"),
    ([], "no setpoint stream"),
])
def test_unexecutable_streams_are_refused_before_anything_is_sent(rig, streams, message):
    rig.add("r1")
    rig.add("r2")
    with pytest.raises(errors.SetpointError, match=message):
        execute_streams(streams, rig.bricks, options=OPTIONS)
    assert all(e.stats.frames_in == 0 for e in rig.emulators.values())


@pytest.mark.parametrize("kwargs, message", [
    (dict(ports=("A", "D")), "ports must be 1-3 distinct letters"),
    (dict(ports=("A", "A")), "ports must be 1-3 distinct letters"),
    (dict(tick_ms=5), "tick_ms must be an integer in 10..10000"),
    (dict(rows=()), "no setpoints"),
    (dict(rows=((0, 0),)), "tick 0 has 2 values for 1 ports"),
    (dict(rows=((1.5,),)), "is not an integer degree"),
    (dict(rows=((0,), (400,)), limits_deg=((-360, 360),)), "400 deg is outside the limits"),
    (dict(rows=((40000,),)), "outside the limits"),
    (dict(rows=tuple((0,) for _ in range(3001))), "exceed the brick program's 3000 values"),
])
def test_malformed_streams_are_refused_on_creation(kwargs, message):
    base = dict(brick="r1", ports=("A",), tick_ms=50, rows=((0,),))
    with pytest.raises(errors.SetpointError, match=message):
        SetpointStream(**{**base, **kwargs})


def test_log_read_back_resumes_where_it_stopped(rig, wave):
    brick = rig.add("r1")
    rows = wave(60, (100,))
    s = BrickSession(brick, ("A",), 50, rows, ((-500, 500),), timing=TIMING)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    s.post_go(rig.clock.now())
    s.confirm_go()
    while s.poll_progress().state != State.DONE:
        rig.clock.sleep(0.25)

    class Interrupted(Exception):
        pass

    def interrupt_after_two_chunks(done: int, total: int) -> None:
        if done >= 46:
            raise Interrupted

    with pytest.raises(Interrupted):
        s.read_log(interrupt_after_two_chunks)
    seen: list[int] = []
    measured = s.read_log(lambda done, total: seen.append(done))
    assert seen[0] > 46  # resumed: the rows already received were not fetched again
    assert list(measured) == rig.emulators["r1"].program.measured_rows()


def test_program_not_running_is_a_clear_error_when_not_started_for_us(rig):
    rig.add("r1", program_running=False)
    options = ExecutionOptions(timing=TIMING, start_program=False)
    with pytest.raises(errors.ExecutionFailed) as info:
        execute_streams([SetpointStream("r1", ("A",), 50, ((0,),))], rig.bricks, options=options)
    assert str(info.value) == ("brick r1: no program is running (start cplus_follow.rxe on the "
                               "brick)")
