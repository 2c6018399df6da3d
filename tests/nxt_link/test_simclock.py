"""The simulated clock: a discrete-event scheduler whose waiters are threads, and emulated
bricks on it behind real ptys (pyserial), whose runs depend on nothing but their inputs."""
from __future__ import annotations

import dataclasses
import math
import os
import threading
import time

import pytest

import nxt_link
from nxt_link.wire.clock import (
    MONOTONIC,
    READABLE,
    STOPPED,
    TIME,
    Deadline,
    SimClock,
    SimulationStalled,
    VirtualClock,
    clock_of_device,
    join_threads,
    new_lock,
    start_thread,
)
from nxt_link.wire.errors import ExecutionFailed

pytestmark = pytest.mark.timeout(120)


def test_time_jumps_to_the_earliest_deadline_and_ties_go_in_registration_order():
    clock = SimClock()
    seen: list[tuple[float, str]] = []

    def worker(name: str, period: float, n: int) -> None:
        for _ in range(n):
            clock.sleep(period)
            seen.append((round(clock.now(), 9), name))
    with clock.participant("main"):
        threads = [start_thread(clock, n, worker, (n, p, k)) for n, p, k in (("a", 0.3, 4), ("b", 0.2, 6))]
        join_threads(clock, threads)
        assert clock.now() == pytest.approx(1.2)
    assert seen == [(0.2, "b"), (0.3, "a"), (0.4, "b"), (0.6, "a"), (0.6, "b"), (0.8, "b"), (0.9, "a"),
                    (1.0, "b"), (1.2, "a"), (1.2, "b")]


def test_time_does_not_pass_while_a_participant_runs():
    clock = SimClock()
    woke: list[float] = []

    def sleeper() -> None:
        clock.sleep(1.0)
        woke.append(clock.now())
    with clock.participant("main"):
        t = start_thread(clock, "sleeper", sleeper)
        time.sleep(0.3)                 # real time, holding the baton: the clock stands still
        assert clock.now() == 0.0 and not woke
        join_threads(clock, [t])
    assert woke == [1.0]


def test_bytes_on_their_way_wake_the_reader_at_the_same_instant():
    clock = SimClock()
    ch = clock.open_channel("/dev/pts/test")
    got: list[tuple[str, float]] = []

    def reader() -> None:
        got.append((clock.wait_readable(ch.to_pc, until=5.0), clock.now()))
        clock.consumed(ch.to_pc, 3)
        got.append((clock.wait_readable(ch.to_pc, until=clock.now() + 0.5), clock.now()))
    with clock.participant("main"):
        t = start_thread(clock, "reader", reader)
        clock.sleep(2.0)
        clock.wrote(ch.to_pc, 3)
        join_threads(clock, [t])
    assert got == [(READABLE, 2.0), (TIME, 2.5)]


def test_a_detached_participant_stops_waiting():
    clock = SimClock()
    ch = clock.open_channel("x")
    result: list[str] = []
    t = start_thread(clock, "server", lambda: result.append(clock.wait_readable(ch.to_brick, None)))
    time.sleep(0.05)
    clock.detach(t._sim_participant)  # type: ignore[attr-defined]
    t.join(5)
    assert result == [STOPPED]


def test_a_lock_waits_on_the_clock():
    """A participant waiting for a lock held by a sleeping one lets time pass."""
    clock = SimClock()
    lock = new_lock(clock)
    order: list[tuple[str, float]] = []

    def holder() -> None:
        with lock:
            clock.sleep(1.0)
            order.append(("holder", clock.now()))

    def other() -> None:
        clock.sleep(0.1)
        with lock:
            order.append(("other", clock.now()))
    with clock.participant("main"):
        threads = [start_thread(clock, "holder", holder), start_thread(clock, "other", other)]
        join_threads(clock, threads)
    assert order == [("holder", 1.0), ("other", 1.0)]


def test_a_participant_blocked_outside_the_clock_fails_the_run_instead_of_freezing_it():
    clock = SimClock(stall_timeout_s=1.5)         # over a second: the real time blocked, not a ratio
    errors: list[BaseException] = []

    def waiter() -> None:
        try:
            clock.sleep(1.0)
        except SimulationStalled as exc:
            errors.append(exc)
    with clock.participant("main"):
        t = start_thread(clock, "waiter", waiter)
        clock.sleep(0.5)
        time.sleep(3.5)          # blocked on something the clock does not know
        with pytest.raises(SimulationStalled, match="main kept running"):
            clock.sleep(0.1)
    t.join(5)
    assert errors and "waiter waits for t=1.000 s" in str(errors[0])


def test_a_participant_that_died_is_dropped():
    clock = SimClock()
    p = clock.register("ghost")

    def dies() -> None:
        clock.attach(p)           # and ends without unregistering
    threading.Thread(target=dies).start()
    with clock.participant("main"):
        clock.sleep(1.0)          # the ghost held the baton: dropped within a second or two
    assert clock.now() == 1.0


# -- bricks on the simulated clock, over ptys -------------------------------------------------

def _rows(n: int) -> tuple[tuple[int, ...], ...]:
    return tuple(tuple(int(round(a * math.sin(2 * math.pi * k / (40 * (1 + 0.5 * j)))))
                       for j, a in enumerate((200, 100, 50))) for k in range(n))


def _execute(faults: nxt_link.FaultParams, *, latency: bool = True, during=None, policy=None,
             timing=None) -> tuple[str, SimClock, list]:
    """Two emulated bricks on ptys and one PC thread, all on one simulated clock."""
    clock = SimClock()
    servers, bricks = [], {}
    with clock.participant("pc"):
        try:
            for name in ("r1", "r2"):
                cfg = nxt_link.EmulatorConfig(name=name, faults=dataclasses.replace(faults, seed=(faults.seed or 0) + len(servers)),
                                              link=nxt_link.LinkParams() if latency else nxt_link.LinkParams.instant())
                server = nxt_link.PtyBrickServer(nxt_link.BrickEmulator(cfg), clock=clock)
                server.start()
                servers.append(server)
                bricks[name] = nxt_link.Brick(nxt_link.SerialTransport(server.path, clock=clock, label=f"emulated {name}"),
                                              name=name, policy=policy)
            rows = _rows(60)
            streams = [nxt_link.SetpointStream(n, ("A", "B", "C"), 100, rows) for n in bricks]
            opts = nxt_link.ExecutionOptions(timing=timing or nxt_link.SessionTiming())
            try:
                log = nxt_link.execute_streams(streams, bricks, session_ids={"r1": 11, "r2": 12}, options=opts,
                                               on_progress=None if during is None else
                                               lambda p: during(p, servers))
            except ExecutionFailed as exc:
                log = exc.log  # type: ignore[assignment]
        finally:
            for b in bricks.values():
                b.close()
            for s in servers:
                s.stop()
    assert all(s.error is None for s in servers), [s.error for s in servers]
    return log.dumps(), clock, servers


@pytest.mark.slow
def test_the_same_seed_gives_the_same_log_byte_for_byte():
    faults = nxt_link.FaultParams(drop=0.15, corrupt=0.08, disconnect_after=120, seed=4)
    first, clock, servers = _execute(faults)
    second, _, _ = _execute(faults)
    assert first == second
    assert '"reconnected"' in first and clock.now() > 5
    assert all(s.emulator.stats.disconnects == 1 for s in servers)


@pytest.mark.slow
def test_a_brick_whose_frames_are_all_dropped_mid_run_is_lost_after_its_silence():
    """From the run phase on, r2's radio loses every frame: it is given up max_silent_s
    (simulated) after its last valid answer, and r1 is stopped."""
    def jam(p: nxt_link.Progress, servers) -> None:
        emu = servers[1].emulator
        if p.phase == "run" and emu.config.faults.drop == 0:
            emu.config = dataclasses.replace(emu.config, faults=nxt_link.FaultParams(drop=0.999999, seed=1))
    text, clock, _ = _execute(nxt_link.FaultParams(seed=1), during=jam)
    log = nxt_link.ExecutionLog.loads(text)
    assert log.stopped is not None and log.stopped.brick == "r2"
    assert "no valid answer from the brick program for 10 s" in log.stopped.reason
    again, _, _ = _execute(nxt_link.FaultParams(seed=1), during=jam)
    assert again == text


@pytest.mark.slow
def test_a_brick_switched_off_mid_run_is_lost():
    """r1's pty disappears during the run (a modelled disconnect for good): its link cannot
    be reopened within the reconnect timeout."""
    def switch_off(p: nxt_link.Progress, servers) -> None:
        if p.phase == "run" and p.brick == "r1" and p.done >= 10 and servers[0]._thread is not None:
            servers[0].stop()
    text, _, _ = _execute(nxt_link.FaultParams(seed=2), during=switch_off)
    log = nxt_link.ExecutionLog.loads(text)
    assert log.stopped is not None and log.stopped.brick == "r1"
    assert "could not be reopened within 10 s" in log.stopped.reason


def test_a_released_lock_is_handed_to_its_first_waiter_before_the_releaser_can_take_it_again():
    """On release the lock goes, still held, to the participant that has waited longest: the
    releaser, which keeps the baton, cannot take it back in between (first come, first served)."""
    clock = SimClock()
    lock = new_lock(clock)
    order: list[tuple[str, float]] = []

    def holder() -> None:
        with lock:
            clock.sleep(1.0)
            order.append(("holder", clock.now()))
        with lock:                                 # at once, still running: it queues behind b and c
            order.append(("holder again", clock.now()))

    def waiter(name: str, delay: float) -> None:
        clock.sleep(delay)
        with lock:
            order.append((name, clock.now()))
            clock.sleep(0.5)
    with clock.participant("main"):
        threads = [start_thread(clock, "holder", holder), start_thread(clock, "b", waiter, ("b", 0.1)),
                   start_thread(clock, "c", waiter, ("c", 0.2))]
        join_threads(clock, threads)
    assert order == [("holder", 1.0), ("b", 1.0), ("c", 1.5), ("holder again", 2.0)]
    assert not lock.held and lock.waiters == []


def test_joining_waits_for_every_participant_even_when_one_has_already_ended():
    clock = SimClock()
    with clock.participant("main"):
        threads = [start_thread(clock, "a", clock.sleep, (1.0,)), start_thread(clock, "b", clock.sleep, (2.0,))]
        clock.sleep(1.5)                           # a has ended, b has not
        join_threads(clock, threads)
        assert clock.now() == 2.0
    assert not any(t.is_alive() for t in threads)


def test_bytes_consumed_beyond_those_counted_leave_none_pending():
    clock = SimClock()
    ch = clock.open_channel("x")
    clock.wrote(ch.to_pc, 2)
    clock.consumed(ch.to_pc, 5)                    # a read that took more than was counted
    assert ch.to_pc.pending == 0
    clock.wrote(ch.to_pc, 1)
    assert ch.to_pc.pending == 1
    with clock.participant("main"):
        assert clock.wait_readable(ch.to_pc, until=10.0) == READABLE and clock.now() == 0.0
        clock.consumed(ch.to_pc, 1)
        assert clock.wait_readable(ch.to_pc, until=10.0) == TIME and clock.now() == 10.0


def test_a_device_is_found_through_a_symlink_to_its_pty(tmp_path):
    pty = tmp_path / "pts0"
    pty.touch()
    link = tmp_path / "rfcomm-brick"
    link.symlink_to(pty)
    clock = SimClock()
    ch = clock.open_channel(os.path.realpath(pty))
    assert clock_of_device(str(link)) is clock and clock_of_device(str(pty)) is clock
    assert clock_of_device(str(tmp_path / "other")) is None
    clock.close_channel(ch)
    assert clock_of_device(str(link)) is None


def test_a_closed_channel_has_nothing_in_flight_and_wakes_its_readers():
    clock = SimClock()
    ch = clock.open_channel("x")
    clock.wrote(ch.to_brick, 4)
    clock.wrote(ch.to_pc, 2)
    assert not ch.closed
    got: list[tuple[str, float]] = []
    with clock.participant("main"):
        reader = start_thread(clock, "reader", lambda: got.append((clock.wait_readable(ch.to_pc, None), clock.now())))
        clock.consumed(ch.to_pc, 2)
        clock.sleep(1.0)                           # the reader waits, with no deadline
        clock.close_channel(ch)
        join_threads(clock, [reader])
    assert got == [(READABLE, 1.0)]
    assert (ch.to_brick.pending, ch.to_pc.pending) == (0, 0) and ch.closed
    assert clock.channel("x") is None
    clock.wrote(ch.to_pc, 3)                       # bytes written to a closed pty are not counted
    assert ch.to_pc.pending == 0


def test_the_virtual_clock_moves_only_forward_and_only_when_told():
    clock = VirtualClock(5.0)
    clock.sleep(0.0)
    clock.sleep(-1.0)
    assert clock.now() == 5.0
    clock.sleep(0.25)
    assert clock.now() == 5.25
    clock.advance_to(4.0)
    assert clock.now() == 5.25
    clock.advance_to(7.0)
    assert clock.now() == 7.0
    d = Deadline(clock, 1.0)
    assert d.remaining() == 1.0 and not d.expired()
    clock.sleep(1.0)
    assert d.remaining() == 0.0 and d.expired()
    clock.sleep(1.0)
    assert d.remaining() == 0.0
    never = Deadline(clock, None)
    assert never.remaining() is None and not never.expired()
    past = Deadline(clock, -3.0)                   # a negative timeout is "now"
    assert past.at == clock.now() and past.expired()
    MONOTONIC.sleep(-1.0)                          # returns at once
    MONOTONIC.sleep(0.0)


def test_sleeping_zero_keeps_the_baton_and_fails_only_once_the_clock_has():
    clock = SimClock()
    with clock.participant("main"):
        t = start_thread(clock, "other", clock.sleep, (1.0,))
        clock.sleep(0)                             # returns at once, the other thread still waits
        clock.sleep(-1.0)
        assert clock.now() == 0.0 and t.is_alive()
        join_threads(clock, [t])
    clock._failed = "simulated time stood still (test)"
    with pytest.raises(SimulationStalled, match="stood still"):
        clock.sleep(0)


def test_the_real_clock_sleeps_at_least_what_it_is_asked():
    t0 = MONOTONIC.now()
    MONOTONIC.sleep(0.02)
    assert MONOTONIC.now() - t0 >= 0.02


def test_nested_participant_blocks_of_one_thread_are_one_participant():
    clock = SimClock(stall_timeout_s=2.0)          # a second participant for the thread would stall
    with clock.participant("main"):
        with clock.participant("again"):
            clock.sleep(1.0)
        assert clock.is_participant()
        clock.sleep(1.0)
    assert not clock.is_participant() and clock.now() == 2.0


def test_a_detached_participant_that_takes_a_lock_holds_it():
    clock = SimClock()
    lock = new_lock(clock)
    with clock.participant("main"):
        clock.detach(clock._participants[threading.get_ident()])
        lock.acquire()                             # no longer scheduled: takes it at once
        assert lock.held
        lock.release()
        assert not lock.held
