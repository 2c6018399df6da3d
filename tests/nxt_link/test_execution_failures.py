"""When an execution fails: nothing gathered is lost, the others stop at once, and the start
skew is measured; refusals before anything moves (in memory, on a virtual clock)."""
from __future__ import annotations

import pytest

from nxt_link.host.brick import Brick, RetryPolicy
from nxt_link.host.execlog import ExecutionLog
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import State
from nxt_link.wire import errors

TIMING = SessionTiming(ack_timeout_s=0.3, max_silent_s=4.0, homing_timeout_s=3.0)
OPTIONS = ExecutionOptions(timing=TIMING)


def two_streams(wave, n: int = 100) -> list[SetpointStream]:
    return [SetpointStream("r1", ("A", "B"), 50, wave(n, (120, 90))),
            SetpointStream("r2", ("A", "C"), 50, wave(n, (-100, 45)))]


def silence_when(condition, since: list[float], clock):
    """A damage hook that swallows every frame once ``condition()`` holds (the brick is gone)."""
    def hook(index: int, data: bytes) -> bytes:
        if since or condition():
            if not since:
                since.append(clock.now())
            return b""
        return data
    return hook


def test_a_brick_lost_mid_run_stops_the_other_at_once_and_nothing_gathered_is_lost(rig, wave):
    gone_at: list[float] = []
    rig.add("r1")
    emu2 = None

    def r2_running_a_while() -> bool:
        p = emu2.program
        return p.state == State.RUNNING and p.logged >= 30

    rig.add("r2", damage=silence_when(r2_running_a_while, gone_at, rig.clock))
    emu2 = rig.emulators["r2"]
    with pytest.raises(errors.ExecutionFailed) as info:
        execute_streams(two_streams(wave, 200), rig.bricks, options=OPTIONS)  # 10 s
    failure = info.value
    log: ExecutionLog = failure.log
    assert failure.brick == "r2" and isinstance(failure.__cause__, errors.LinkTimeoutError)
    assert str(failure) == "brick r2: no valid answer from the brick program for 4 s"
    # given up once r2 had sent nothing valid for max_silent_s (counted from its last answer)
    assert not log.complete and log.stopped.brick == "r2"
    assert TIMING.max_silent_s <= log.stopped.t_s - gone_at[0] <= TIMING.max_silent_s + 1.0
    # r1 was told to stop at once and stopped, mid-trajectory
    r1 = log.brick("r1")
    stop_events = [e for e in r1.events if e.event == "stopped"]
    assert stop_events and stop_events[0].t_s - log.stopped.t_s < 0.5
    program1 = rig.emulators["r1"].program
    assert program1.state == State.STOPPED and 30 <= program1.logged < 200
    # every row r1 logged was read back, exactly
    assert r1.reached == "log" and r1.measured_deg == tuple(program1.measured_rows())
    # r2 logged rows nobody could read back: they are there, as unknown rows
    r2 = log.brick("r2")
    assert r2.reached == "run" and 20 <= len(r2.measured_deg) <= 30  # as last reported
    assert all(row is None for row in r2.measured_deg)
    # the log says so in JSON too, and loads back
    again = ExecutionLog.loads(log.dumps())
    assert again == log and again.to_json()["complete"] is False
    assert again.to_json()["stopped"]["reason"] == str(failure)


def test_a_brick_lost_while_its_log_is_read_keeps_the_rows_read(rig, wave):
    gone_at: list[float] = []
    rig.add("r1")
    frames = {"logdata": 0}

    def after_three_log_answers() -> bool:
        return frames["logdata"] >= 3

    hook = silence_when(after_three_log_answers, gone_at, rig.clock)

    def count_then_maybe_silence(index: int, data: bytes) -> bytes:
        out = hook(index, data)
        if out and len(data) > 8 and data[3] == 0x13 and data[4] == 0 and data[7] == sp.Kind.LOGDATA:
            frames["logdata"] += 1
        return out

    rig.add("r2", damage=count_then_maybe_silence)
    with pytest.raises(errors.ExecutionFailed) as info:
        execute_streams(two_streams(wave), rig.bricks, options=OPTIONS)
    log = info.value.log
    r1, r2 = log.brick("r1"), log.brick("r2")
    assert r1.complete and r1.measured_deg == tuple(rig.emulators["r1"].program.measured_rows())
    assert r2.reached == "log" and len(r2.measured_deg) == 100
    truth = rig.emulators["r2"].program.measured_rows()
    read = [k for k, row in enumerate(r2.measured_deg) if row is not None]
    assert len(read) >= 3 * 11 and all(r2.measured_deg[k] == truth[k] for k in read)


def test_ctrl_c_stops_every_brick_and_keeps_the_log(rig, wave):
    rig.add("r1")
    rig.add("r2")

    def interrupt(p) -> None:
        if p.phase == "run" and p.done >= 20:
            raise KeyboardInterrupt

    with pytest.raises(errors.ExecutionInterrupted) as info:
        execute_streams(two_streams(wave), rig.bricks, options=OPTIONS, on_progress=interrupt)
    assert isinstance(info.value, KeyboardInterrupt)
    log = info.value.log
    assert log.stopped.reason == "interrupted"
    for name in ("r1", "r2"):
        assert rig.emulators[name].program.state == State.STOPPED
        assert log.brick(name).reached == "stopped"


def test_a_motor_far_from_its_first_setpoint_is_refused_before_anything_moves(rig, wave):
    rig.add("r1")
    rig.add("r2")
    rig.emulators["r2"].firmware.outputs[2].rotation_count = 40  # someone turned the arm
    with pytest.raises(errors.SetpointError) as info:
        execute_streams(two_streams(wave), rig.bricks, options=OPTIONS)
    assert str(info.value).startswith("brick r2 motor C stands at 40 deg, the trajectory starts "
                                      "at 0 deg (40 deg away, more than 10)")
    for emu in rig.emulators.values():
        assert emu.program.state == State.IDLE and emu.program.rows_stored == 0
    # allowed when asked for
    rig.emulators["r2"].firmware.outputs[2].rotation_count = 8
    log = execute_streams(two_streams(wave, 40), rig.bricks, options=OPTIONS)
    assert log.complete


class LateGo:
    """A transport that loses every GO written before ``until`` (as a bad radio would)."""

    def __init__(self, inner, until: list[float]) -> None:
        self.inner, self.until = inner, until
        self.name, self.clock = inner.name, inner.clock

    def send(self, telegram: bytes) -> None:
        is_go = len(telegram) > 4 and telegram[1] == 0x09 and telegram[4] == sp.Kind.GO
        if is_go and self.clock.now() < self.until[0]:
            return
        self.inner.send(telegram)

    def __getattr__(self, name):
        return getattr(self.inner, name)


def test_the_start_skew_is_measured_from_the_log(rig, wave):
    rig.add("r1")
    rig.add("r2")
    until = [float("inf")]
    late = Brick(LateGo(rig.bricks["r2"].transport, until), name="r2",
                 policy=rig.bricks["r2"].policy)
    bricks = {"r1": rig.bricks["r1"], "r2": late}

    def hold_back_r2_until_after_the_start(p) -> None:
        if p.phase == "homing" and p.done == 1 and p.brick == "r2":
            until[0] = rig.clock.now() + OPTIONS.start_delay_s + 0.5

    log = execute_streams(two_streams(wave), bricks, options=OPTIONS,
                          on_progress=hold_back_r2_until_after_the_start)
    t1 = rig.emulators["r1"].program.t0
    t2 = rig.emulators["r2"].program.t0
    true_skew = (t2 - t1) / 1000.0
    skew = log.start_skew()
    assert true_skew > 0.4
    assert skew.min <= true_skew <= skew.max  # the measurement is sound
    assert skew.min > 0.05 * 2  # and certain: more than two ticks of 50 ms
    assert abs(skew.estimate - true_skew) < 0.06
    # on time, the same measurement shows (almost) nothing
    rig2 = type(rig)()
    rig2.add("r1")
    rig2.add("r2")
    on_time = execute_streams(two_streams(wave), rig2.bricks, options=OPTIONS).start_skew()
    assert on_time.min == 0.0 and on_time.estimate < 0.02 and on_time.max < 0.06


class Unplugged:
    """A transport whose link drops for good once ``when()`` holds (a reopen fails too)."""

    def __init__(self, inner, when) -> None:
        self.inner, self.when = inner, when
        self.name, self.clock = inner.name, inner.clock
        self.gone = False

    def _check(self) -> None:
        if self.gone or self.when():
            self.gone = True
            raise errors.LinkDisconnectedError(f"{self.name}: link lost")

    def send(self, telegram: bytes) -> None:
        self._check()
        self.inner.send(telegram)

    def recv(self, deadline):
        self._check()
        return self.inner.recv(deadline)

    def discard_input(self, quiet_s: float) -> int:
        self._check()
        return self.inner.discard_input(quiet_s)

    def reconnect(self, deadline) -> None:
        self.clock.advance_to(deadline.at)
        raise errors.LinkDisconnectedError(f"{self.name}: could not reconnect")

    def close(self) -> None:
        self.inner.close()


def test_a_link_that_cannot_be_reopened_ends_the_run_at_once(rig, wave):
    rig.add("r1")
    rig.add("r2")
    program2 = rig.emulators["r2"].program
    unplugged = Brick(Unplugged(rig.bricks["r2"].transport,
                                lambda: program2.state == State.RUNNING and program2.logged >= 20),
                      name="r2", policy=rig.bricks["r2"].policy)
    with pytest.raises(errors.ExecutionFailed) as info:
        execute_streams(two_streams(wave), {"r1": rig.bricks["r1"], "r2": unplugged},
                        options=OPTIONS)
    assert str(info.value) == ("brick r2: link lost and memory:r2 could not be reopened within "
                               "2 s")
    log = info.value.log
    assert log.stopped.brick == "r2"
    program1 = rig.emulators["r1"].program
    assert program1.state == State.STOPPED
    assert log.brick("r1").measured_deg == tuple(program1.measured_rows())


def test_an_exception_from_on_progress_stops_every_brick_before_it_is_raised(rig, wave):
    """A monitor that gives up (the payload arms' tracking fault) raises from on_progress: every
    brick is told to STOP before the caller sees the exception, so the arms do not run on with
    a trajectory the caller has abandoned."""
    rig.add("r1")
    rig.add("r2")

    class GiveUp(Exception):
        pass

    def monitor(p) -> None:
        if p.phase == "run" and p.done >= 30:
            raise GiveUp(p.brick)
    with pytest.raises(GiveUp):
        execute_streams(two_streams(wave, 200), rig.bricks, options=OPTIONS, on_progress=monitor)
    for name in ("r1", "r2"):
        program = rig.emulators[name].program
        assert program.state == State.STOPPED and program.logged < 200


def test_ctrl_c_with_every_brick_silent_ends_within_the_stop_limit(rig, wave):
    """Ctrl-C must end within its limit (the shutdown watchdog's 1.5 s) however many bricks are
    silent: STOP goes to all at once, and the confirmations share one second (on the bricks'
    clock), each overrunning it by at most one reply attempt, never by a read's retries."""
    silent: list[float] = []
    hooks = {name: silence_when(lambda: bool(silent), [], rig.clock) for name in ("r1", "r2")}
    for name in ("r1", "r2"):
        rig.add(name, policy=RetryPolicy(), damage=hooks[name])   # a real link's timeouts
    interrupted: list[float] = []

    def interrupt(p) -> None:
        if p.phase == "run" and p.done >= 20:
            silent.append(rig.clock.now())                  # both links die, then Ctrl-C
            interrupted.append(rig.clock.now())
            raise KeyboardInterrupt

    with pytest.raises(errors.ExecutionInterrupted) as info:
        execute_streams(two_streams(wave), rig.bricks, options=OPTIONS, on_progress=interrupt)
    took = rig.clock.now() - interrupted[0]
    assert took <= 1.0 + RetryPolicy().reply_timeout_s, took
    log = info.value.log
    assert log.stopped.reason == "interrupted" and not log.complete
    for name in ("r1", "r2"):
        assert log.brick(name).reached == "run"    # not confirmed: no "stopped" claimed
        assert not [e for e in log.brick(name).events if e.event == "stopped"]
