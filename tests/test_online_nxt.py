"""The online loop on the emulated NXT delivery robot (the Legolog program in a line-track
world): in memory on a virtual clock for the scenarios, and once over a pseudo-terminal (the
real serial path)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from cplus.api import Domain
from cplus.robot.online.binding import load_binding
from cplus.robot.online.estimation import OnlineModel
from cplus.robot.online.loop import Observer, OnlineLoop, OnlineStatus, RunResult
from cplus.robot.online.nxt_executor import NxtExecutor
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, LinkParams
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.world import Blocked, Landmark, Press, WorldSpec, delivery_world
from nxt_link.host.behaviours import BehaviourTiming
from nxt_link.host.brick import RetryPolicy
from nxt_link.wire.clock import SimClock, VirtualClock

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery"
FAST = RetryPolicy(reply_timeout_s=0.2, retries=3, quiet_s=0.02, reconnect_timeout_s=2.0)


@pytest.fixture(scope="module")
def setup():
    d = Domain.load(str(DELIVERY / "delivery.cp"))
    b = load_binding(str(DELIVERY / "robot.toml"), d)
    return OnlineModel(d, "deliver", b.roles()), b


class MemoryRobot:
    """The emulated delivery robot behind a MemoryTransport, on one virtual clock."""

    def __init__(self, world: WorldSpec) -> None:
        self.clock = VirtualClock()
        self.emu = BrickEmulator(EmulatorConfig(name="robot", world=world, link=LinkParams.instant()))
        self.transport = MemoryTransport(self.emu, self.clock)


def run(setup, world: WorldSpec, observers=(), max_cycles=None) -> tuple[RunResult, MemoryRobot]:
    model, binding = setup
    robot = MemoryRobot(world)
    ex = NxtExecutor(model, binding, transports={"robot": robot.transport}, clock=robot.clock, policy=FAST,
                     timing=BehaviourTiming(max_silent_s=5.0))
    result = OnlineLoop(model, ex, observers=list(observers), clock=robot.clock, max_cycles=max_cycles).run()
    return result, robot


def executed(result: RunResult) -> list[str]:
    return [" ".join(a.text for a in r.executed) for r in result.records]


def world(**changes) -> WorldSpec:
    return dataclasses.replace(delivery_world(seed=3), **changes)


def test_a_plain_delivery(setup):
    result, robot = run(setup, world())
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    assert executed(result) == ["follow", "follow", "turn", "lowerTray", "raiseTray", "follow", "follow", ""]
    assert [r.sensed for r in result.records if r.sensed] and result.replans == 0
    assert [r.to_json()["sensed"].get("atLandmark") for r in result.records] == [None, 2, 3, None, None, None, 2, 1]
    assert result.records[1].raw["robot.landmark"] == 2
    # the robot is back at the mailroom: landmark 1 of the emulated track
    assert robot.emu.world.nearest_landmark() == 1


def test_a_button_press_on_the_robot_replans(setup):
    w = world(presses=(Press(at_landmark=3),))
    result, _ = run(setup, w)
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    presses = [r for r in result.records if r.events]
    assert len(presses) == 1 and presses[0].events == ["press"]
    assert presses[0].replanned.reason == "event"
    assert executed(result)[-2] == "lowerTray" and result.state.value("letter(1)") == "false"


def test_a_landmark_the_follower_misses_is_inferred(setup):
    marks = tuple(dataclasses.replace(lm, visible=lm.number != 2) for lm in delivery_world().landmarks)
    result, _ = run(setup, world(landmarks=marks))
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    r1 = result.records[1]
    assert r1.sensed and r1.to_json()["sensed"] == {"atLandmark": 3} and r1.inferred == ["missed"]
    assert r1.replanned.reason == "diverged" and r1.replanned.to_json()["fluents"] == {
        "atLandmark": {"predicted": 2, "observed": 3}}
    assert "follow" in executed(result)[1:]


def test_a_track_the_model_does_not_describe_stops_the_run(setup):
    """Landmark 2 is labelled 4 on the floor: from 1 the model allows 2 (or 3, after a miss)."""
    marks = tuple(Landmark(4 if lm.number == 2 else lm.number, lm.at_mm, lm.name) if lm.number != 4
                  else Landmark(2, lm.at_mm, lm.name) for lm in delivery_world().landmarks)
    result, _ = run(setup, world(landmarks=marks))
    assert result.status is OnlineStatus.CONTRADICTED
    assert result.unexplained == ["sensed atLandmark=4"]
    assert result.records[-1].raw["robot.landmark"] == 4


def test_a_blocked_track_fails_the_follow(setup):
    w = world(blocked=(Blocked(800.0, 900.0),))
    result, _ = run(setup, w)
    assert result.status is OnlineStatus.CONTRADICTED
    assert result.message.startswith("follow failed at cycle 0: follow on brick robot: stuck")


@pytest.mark.slow
def test_a_brick_that_goes_away_is_lost(setup):
    """The emulated brick's pseudo-terminal disappears during cycle 2 (a robot switched off):
    on simulated time, so only the modelled disconnect can lose it, never a slow machine."""
    model, binding = setup
    ex = NxtExecutor(model, binding, worlds={"robot": world()}, policy=FAST,
                     timing=BehaviourTiming(max_silent_s=2.0))

    class SwitchOff(Observer):
        def on_act(self, record) -> None:
            if record.cycle == 2:
                ex.servers["robot"].stop()
    result = OnlineLoop(model, ex, observers=[SwitchOff()], clock=ex.clock).run()
    assert result.status is OnlineStatus.ROBOT_LOST, result.message
    assert result.message.startswith("brick robot:")
    assert executed(result) == ["follow", "follow", "turn"] and result.records[-1].failure


def _over_a_pty(setup, **kw) -> tuple[RunResult, NxtExecutor]:
    model, binding = setup
    ex = NxtExecutor(model, binding, worlds={"robot": world(presses=(Press(at_landmark=3),))}, **kw)
    return OnlineLoop(model, ex, clock=ex.clock).run(), ex


@pytest.mark.slow
def test_the_emulated_robot_over_a_pty(setup):
    """The same loop through the serial path: the emulator on a pseudo-terminal, on simulated
    time; twice, with the same log (but the wall-clock decision times)."""
    result, ex = _over_a_pty(setup)
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    assert result.replans == 1 and any(r.events == ["press"] for r in result.records)
    path = ex.servers["robot"].path
    assert not Path(path).exists()              # the executor closed the link and stopped the emulator

    def records(r: RunResult) -> list[dict]:
        out = []
        for rec in r.records:
            j = rec.to_json()
            j.pop("decision_ms", None)   # the planner's wall-clock time
            out.append(j)
        return out
    again, _ = _over_a_pty(setup)
    assert records(again) == records(result) and again.seconds == result.seconds


@pytest.mark.slow
def test_the_emulated_robot_on_the_wall_clock(setup):
    """--time-scale 1: the emulator on the wall clock, in real time. Only a connection and a
    poll: faster than real time, or for a whole mission, the wall clock is what a loaded
    machine can fail (with six CPU-bound processes on two cores, a brick at four times real
    time fell behind and went silent while connecting), which is why the default is simulated
    time."""
    model, binding = setup
    ex = NxtExecutor(model, binding, worlds={"robot": world()}, time_scale=1.0)
    assert not isinstance(ex.clock, SimClock)
    ex.open()
    try:
        assert ex.servers["robot"].time_scale == 1.0 and ex.servers["robot"].clock is None
        assert ex.bricks["robot"].brick.get_battery_level() == 9000
        assert ex.poll().events == []
    finally:
        ex.close()
    assert ex.servers["robot"].error is None
