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
    delivery_world,
)
from nxt_link.behaviour_protocol import AckCode, State, Status
from nxt_link.brick import RetryPolicy
from nxt_link.clock import VirtualClock
from nxt_link.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.errors import LinkError
from nxt_link.memory_transport import MemoryTransport
from nxt_link.world import Blocked, Press, WorldSpec

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
    robot.clock.sleep(0.5)
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
