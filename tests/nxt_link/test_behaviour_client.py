"""The behaviour client against the emulated delivery robot (in memory, virtual clock)."""
from __future__ import annotations

import pytest

from nxt_link import (
    Behaviour,
    BehaviourClient,
    BehaviourFailed,
    BehaviourRefused,
    BehaviourTiming,
    Brick,
    BrickEvent,
    BrickLostError,
    BrickPanicError,
    delivery_world,
)
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.world import Blocked, Press, WorldSpec
from nxt_link.host.brick import RetryPolicy
from nxt_link.programs import behaviour_protocol as bp
from nxt_link.programs.behaviour_protocol import AckCode, State, Status
from nxt_link.wire.clock import VirtualClock
from nxt_link.wire.errors import LinkError

FAST = RetryPolicy(reply_timeout_s=0.2, retries=3, quiet_s=0.02, reconnect_timeout_s=2.0)


class Robot:
    """An emulated delivery robot and a connected client, on one virtual clock."""

    def __init__(self, world: WorldSpec | None = None, *, faults: FaultParams | None = None,
                 link: LinkParams | None = None, timing: BehaviourTiming | None = None) -> None:
        self.clock = VirtualClock()
        self.emu = BrickEmulator(EmulatorConfig(
            name="robot", world=world or delivery_world(seed=1),
            link=link or LinkParams.instant(), faults=faults or FaultParams()))
        self.events: list[tuple[str, str]] = []
        self.client = BehaviourClient(Brick(MemoryTransport(self.emu, self.clock), name="robot",
                                            policy=FAST),
                                      timing=timing, on_event=lambda e, d: self.events.append((e, d)))

    def wait(self, seconds: float) -> None:
        """Let simulated time pass with no traffic (the emulator runs only when asked)."""
        self.clock.sleep(seconds)
        self.emu.advance_to(self.clock.now() * 1000.0)

    @property
    def world(self):
        assert self.emu.world is not None
        return self.emu.world

    @property
    def program(self):
        p = self.emu.legolog
        assert p is not None
        return p


@pytest.fixture
def robot() -> Robot:
    r = Robot()
    r.client.connect()
    return r


def test_connect_opens_a_session(robot):
    assert robot.client.connected
    assert robot.program.session == robot.client.session
    assert robot.client.brick_state == State.IDLE


def test_follow_the_line_to_the_next_landmark_and_back(robot):
    assert robot.world.nearest_landmark() == 1
    r = robot.client.act(Behaviour.FOLLOW)
    assert r.status == Status.OK and r.sensing["landmark"] == 2
    assert robot.world.nearest_landmark() == 2
    # about a metre at about 180 mm/s: the brick asks for more time once on the way
    assert 900 <= r.sensing["distance"] <= 1100 and r.more_time >= 1 and r.seconds > 3
    robot.client.act(Behaviour.TURN)
    r = robot.client.act(Behaviour.FOLLOW)
    assert r.sensing["landmark"] == 1 and robot.world.nearest_landmark() == 1


def test_tray_goes_up_and_down(robot):
    up = robot.client.act(Behaviour.TRAY_UP)
    assert abs(up.sensing["tray"] - 90) <= 3
    down = robot.client.act(Behaviour.TRAY_DOWN)
    assert abs(down.sensing["tray"]) <= 3


def test_a_press_is_an_event_exactly_once(robot):
    assert robot.client.poll_events() == []
    robot.world.press(0.3)
    robot.wait(0.5)
    assert robot.client.poll_events() == [BrickEvent("button")]
    assert robot.client.poll_events() == []


def test_wait_for_the_button_consumes_the_press():
    world = delivery_world(seed=4)
    r = Robot(WorldSpec(track=world.track, landmarks=world.landmarks, start=world.start,
                        presses=(Press(at_s=2.0),), seed=4))
    r.client.connect()
    result = r.client.act(Behaviour.WAIT_BUTTON)
    assert result.sensing["touch"] == 1 and 1.9 <= r.clock.now() <= 2.2
    assert r.client.poll_events() == []  # the behaviour took the press: no event


def test_wait_with_a_time_limit_senses_no_press(robot):
    r = robot.client.act(Behaviour.WAIT_BUTTON, (2,))
    assert r.status == Status.OK and r.sensing["touch"] == 0 and 1.9 <= r.seconds <= 2.1


def test_unknown_behaviour_and_bad_arguments_are_refused(robot):
    with pytest.raises(BehaviourRefused, match="unknown behaviour") as exc:
        robot.client.act(9)
    assert exc.value.code == AckCode.UNKNOWN_BEHAVIOUR
    with pytest.raises(BehaviourRefused, match="bad args"):
        robot.client.act(Behaviour.TURN, (1,))
    # the robot still works
    assert robot.client.act(Behaviour.TRAY_UP).status == Status.OK


def test_a_blocked_stretch_makes_follow_fail_stuck():
    world = delivery_world(seed=2)
    spec = WorldSpec(track=world.track, landmarks=world.landmarks, start=world.start,
                     blocked=(Blocked(800.0, 900.0),), seed=2)
    r = Robot(spec)
    r.client.connect()
    with pytest.raises(BehaviourFailed, match="stuck") as exc:
        r.client.act(Behaviour.FOLLOW)
    assert exc.value.result.status == Status.STUCK and exc.value.result.sensing["landmark"] == 0
    assert 700 <= r.world.position_mm <= 800
    # it can still turn round and go back to landmark 1
    r.client.act(Behaviour.TURN)
    assert r.client.act(Behaviour.FOLLOW).sensing["landmark"] == 1


def test_a_scheduled_press_at_a_landmark():
    world = delivery_world(seed=3)
    spec = WorldSpec(track=world.track, landmarks=world.landmarks, start=world.start,
                     presses=(Press(at_landmark=2, delay_s=1.0),), seed=3)
    r = Robot(spec)
    r.client.connect()
    r.client.act(Behaviour.FOLLOW)
    assert r.client.poll_events() == []
    r.clock.sleep(2.0)
    assert r.client.poll_events() == [BrickEvent("button")]


def test_a_silent_brick_is_lost():
    r = Robot(timing=BehaviourTiming(max_silent_s=3.0))
    r.client.connect()
    r.emu.firmware._pending_stop = True  # the program stops: the brick answers EC
    with pytest.raises(BrickLostError, match="no longer running|not running"):
        r.client.act(Behaviour.TRAY_UP)


def test_errors_are_link_errors():
    assert issubclass(BehaviourFailed, LinkError) and issubclass(BrickLostError, LinkError)


MISSION = [(Behaviour.FOLLOW, ()), (Behaviour.TRAY_UP, ()), (Behaviour.TURN, ()),
           (Behaviour.FOLLOW, ()), (Behaviour.TRAY_DOWN, ()), (Behaviour.WAIT_BUTTON, (1,))]


def run_mission(r: Robot) -> None:
    """The mission, then three presses polled twice: every action and event exactly once."""
    r.client.connect()
    results = [r.client.act(b, a) for b, a in MISSION]
    # none lost, none run twice, in order
    assert r.program.started == [(i + 1, b) for i, (b, _) in enumerate(MISSION)]
    assert [x.seq for x in results] == list(range(1, len(MISSION) + 1))
    assert results[0].sensing["landmark"] == 2 and results[3].sensing["landmark"] == 1
    assert abs(results[1].sensing["tray"] - 90) <= 3 and abs(results[4].sensing["tray"]) <= 3
    assert r.world.nearest_landmark() == 1
    for _ in range(3):
        r.world.press(0.2)
        r.wait(0.4)
    got = r.client.poll_events() + r.client.poll_events()
    assert [e.number for e in got] == [1, 2, 3] and {e.name for e in got} == {"button"}


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_under_drops_and_corruption_every_action_runs_exactly_once(seed):
    r = Robot(faults=FaultParams(drop=0.15, corrupt=0.1, seed=seed))
    run_mission(r)
    stats = r.emu.stats
    assert stats.dropped_in + stats.dropped_out > 10 and stats.corrupted_in + stats.corrupted_out > 5
    assert r.client.retransmissions > 0


def test_with_answers_later_than_the_resend_timeout_every_action_runs_exactly_once():
    r = Robot(faults=FaultParams(delay_ms=700.0, seed=3))
    r.client.brick.policy = RetryPolicy(reply_timeout_s=2.0, retries=3, quiet_s=0.02)
    run_mission(r)
    assert r.client.retransmissions > 0  # copies were sent, and the brick ignored them


def test_with_the_bluetooth_latency_model():
    run_mission(Robot(link=LinkParams(stall_probability=0.0)))


def test_a_pc_too_busy_to_answer_more_time_finds_the_brick_in_panic():
    spec = delivery_world(seed=6)
    r = Robot(spec)
    r.client.connect()

    def busy(elapsed_s: float) -> None:
        r.clock.sleep(15.0)  # e.g. a long re-plan in the caller's callback

    with pytest.raises(BrickPanicError, match="PANIC") as exc:
        r.client.act(Behaviour.WAIT_BUTTON, on_more_time=busy)
    assert isinstance(exc.value, BrickLostError)
    assert r.client.brick_state == State.PANIC and r.program.status == 2
    with pytest.raises(BrickPanicError):
        r.client.poll_events()
    r.client.abort()
    assert r.program.status == 0 and r.client.brick_state == State.IDLE
    # the stale PANIC copies still queued are recognised and skipped
    r.clock.sleep(1.0)
    assert r.client.poll_events() == []
    assert r.client.act(Behaviour.TRAY_UP).status == Status.OK


def test_connect_clears_a_panic_left_by_an_earlier_pc():
    r = Robot()
    r.client.connect()
    # the earlier PC sent an ACT and died
    r.client._post(bp.Act(r.client.session, 1, Behaviour.WAIT_BUTTON))
    r.wait(20.0)
    assert r.program.status == 2
    fresh = BehaviourClient(r.client.brick, on_event=lambda e, d: r.events.append((e, d)))
    w = fresh.connect()
    assert w.state == State.IDLE and w.aborts == 1 and ("clearing panic", "left by an earlier "
                                                        "session") in r.events
    assert fresh.act(Behaviour.TRAY_UP).seq == 1


def test_close_aborts_an_interrupted_action():
    r = Robot(timing=BehaviourTiming(max_silent_s=2.0))
    r.client.connect()
    r.client._post(bp.Act(r.client.session, 1, Behaviour.FOLLOW))
    r.client._in_progress = 1
    r.clock.sleep(0.5)
    r.client.close()
    assert r.program.running == 0 and not r.client.connected
