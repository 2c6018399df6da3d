"""The emulator's world: what the sensors read, how the wheels move the robot."""
from __future__ import annotations

import math
import statistics

import pytest

from nxt_link import delivery_world
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, LinkParams
from nxt_link.emulator.input_module import (
    TOUCH_RAW_PRESSED,
    TOUCH_RAW_RELEASED,
    InputPort,
    SensorMode,
    SensorType,
    light_percent_to_raw,
)
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.world import Blocked, Landmark, Markers, Press, Start, Track, World, WorldSpec
from nxt_link.host.brick import Brick
from nxt_link.wire.clock import VirtualClock
from nxt_link.wire.telegram import OutputMode, RegulationMode, RunState


def spec(**kw) -> WorldSpec:
    base = dict(track=Track(((0.0, 0.0), (3000.0, 0.0))),
                landmarks=(Landmark(1, 400.0), Landmark(3, 1500.0)),
                start=Start(at_mm=100.0), noise_percent=0.0, seed=1)
    base.update(kw)
    return WorldSpec(**base)  # type: ignore[arg-type]


def brick_with(world: WorldSpec, *, program: bool = False) -> tuple[BrickEmulator, Brick]:
    emu = BrickEmulator(EmulatorConfig(world=world, link=LinkParams.instant(),
                                       program_running=program))
    return emu, Brick(MemoryTransport(emu, VirtualClock()))


def light_at(world: WorldSpec, x: float, y: float, theta: float = 0.0) -> float:
    w = World(world)
    ahead = world.robot.sensor_ahead_mm
    w.pose.x, w.pose.y, w.pose.theta = x - ahead * math.cos(theta), y - ahead * math.sin(theta), theta
    return w._light()


# -- the light sensor --------------------------------------------------------------------


def test_light_reads_line_floor_and_the_edge_between():
    s = spec()
    assert light_at(s, 200.0, 0.0) == pytest.approx(30.0)  # on the black line
    assert light_at(s, 200.0, 40.0) == pytest.approx(60.0)  # on the floor
    assert light_at(s, 200.0, 10.0) == pytest.approx(45.0)  # on the edge: half and half
    assert light_at(s, 200.0, -10.0) == pytest.approx(45.0)
    # the line ends with the track
    assert light_at(s, 3100.0, 0.0) == pytest.approx(60.0)


def test_a_landmark_is_its_number_of_bright_bars():
    s = spec()
    # landmark 3 at 1500 mm: bars 1500-1510, 1520-1530, 1540-1550
    readings = [light_at(s, 1490.0 + x, 10.0) for x in range(0, 71)]
    bars, inside = 0, False
    for v in readings:
        if v >= 75 and not inside:
            bars += 1
        inside = v >= 75 if v >= 75 or v < 70 else inside
    assert bars == 3
    assert light_at(s, 1505.0, 10.0) == pytest.approx(90.0)  # whole spot on a bar
    assert light_at(s, 1505.0, 60.0) == pytest.approx(60.0)  # beyond the bars' width


def test_light_noise_has_the_configured_spread():
    w = World(spec(noise_percent=2.0))
    values = [w._light() for _ in range(4000)]
    assert statistics.mean(values) == pytest.approx(45.0, abs=0.2)
    assert statistics.stdev(values) == pytest.approx(2.0, rel=0.1)


def test_percent_to_raw_and_back_through_the_firmware():
    for percent in (0, 12, 30, 45, 60, 90, 100):
        port = InputPort()
        port.sensor_type, port.sensor_mode = SensorType.LIGHT_ACTIVE, SensorMode.PCT_FULL_SCALE
        port.raw = light_percent_to_raw(percent)
        for _ in range(21):
            port.step()
        assert not port.invalid and port.scaled == percent


# -- GETINPUTVALUES answers from the world -------------------------------------------------


def test_get_input_values_reads_the_world():
    emu, brick = brick_with(spec())
    brick.set_input_mode(2, SensorType.LIGHT_ACTIVE, SensorMode.PCT_FULL_SCALE, reply=True)
    brick.set_input_mode(0, SensorType.SWITCH, SensorMode.BOOLEAN, reply=True)
    wait(emu, brick, 0.05)
    light = brick.get_input_values(2)
    assert light.valid and light.sensor_type == SensorType.LIGHT_ACTIVE
    assert light.scaled_value == 45  # the robot starts with its sensor on the line's edge
    assert light.raw_value == light_percent_to_raw(45)
    assert light.normalized_value == light.calibrated_value  # as the firmware copies it
    touch = brick.get_input_values(0)
    assert (touch.raw_value, touch.scaled_value) == (TOUCH_RAW_RELEASED, 0)
    assert emu.world is not None
    emu.world.press(0.5)
    wait(emu, brick, 0.05)
    touch = brick.get_input_values(0)
    assert (touch.raw_value, touch.scaled_value) == (TOUCH_RAW_PRESSED, 1)
    wait(emu, brick, 0.6)
    assert brick.get_input_values(0).scaled_value == 0


# -- motion -------------------------------------------------------------------------------------


def wait(emu: BrickEmulator, brick: Brick, seconds: float) -> None:
    brick.clock.sleep(seconds)
    emu.advance_to(brick.clock.now() * 1000.0)


def drive(brick: Brick, left: int, right: int) -> None:
    for port, power in ((1, left), (2, right)):
        brick.set_output_state(port, power, OutputMode.MOTORON | OutputMode.BRAKE,
                               RegulationMode.IDLE, 0, RunState.RUNNING, 0, reply=True)


def test_both_wheels_forward_drive_straight_by_the_wheel_angle():
    emu, brick = brick_with(spec())
    world = emu.world
    assert world is not None
    drive(brick, 50, 50)
    wait(emu, brick, 2.0)
    drive(brick, 0, 0)
    wait(emu, brick, 0.5)
    wheel_deg = emu.firmware.outputs[1].motor.output_deg
    assert wheel_deg > 500
    expected = wheel_deg * math.pi * 56.0 / 360.0
    assert world.position_mm - 100.0 == pytest.approx(expected, rel=0.01)
    assert world.pose.theta == pytest.approx(0.0, abs=1e-3)


def test_opposite_wheels_spin_on_the_spot():
    emu, brick = brick_with(spec())
    world = emu.world
    assert world is not None
    x0, y0 = world.pose.x, world.pose.y
    drive(brick, -40, 40)
    wait(emu, brick, 1.0)
    drive(brick, 0, 0)
    wait(emu, brick, 0.3)
    turned = (emu.firmware.outputs[2].motor.output_deg - emu.firmware.outputs[1].motor.output_deg)
    expected = math.radians(turned / 2.0 * 56.0 / 112.0)
    assert math.dist((x0, y0), (world.pose.x, world.pose.y)) < 1.0
    assert (world.pose.theta - expected + math.pi) % (2 * math.pi) - math.pi == pytest.approx(
        0.0, abs=1e-6)


def test_a_blocked_stretch_holds_the_wheels_while_they_push_towards_it():
    emu, brick = brick_with(spec(blocked=(Blocked(300.0, 400.0, times=2),)))
    world = emu.world
    assert world is not None
    drive(brick, 50, 50)
    wait(emu, brick, 2.0)
    assert world.position_mm == pytest.approx(300.0, abs=2.0)
    counts = [emu.firmware.outputs[p].rotation_count for p in (1, 2)]
    wait(emu, brick, 0.5)
    # the encoders stand still: the motors are stalled, as against an obstacle
    assert [emu.firmware.outputs[p].rotation_count for p in (1, 2)] == counts
    assert world.stuck_contacts() == 1
    drive(brick, -50, -50)  # backing off is possible
    wait(emu, brick, 0.5)
    assert world.position_mm < 250.0
    drive(brick, 50, 50)  # second contact, then it clears
    wait(emu, brick, 1.0)
    assert world.position_mm == pytest.approx(300.0, abs=2.0) and world.stuck_contacts() == 2
    drive(brick, 0, 0)
    wait(emu, brick, 0.1)
    drive(brick, 50, 50)
    wait(emu, brick, 1.0)
    assert world.position_mm > 450.0


def test_scheduled_presses_at_times_and_at_landmarks():
    s = spec(presses=(Press(at_s=1.5, hold_s=0.2), Press(at_landmark=1, delay_s=0.3, hold_s=0.2)),
             start=Start(at_mm=300.0))
    emu, brick = brick_with(s)
    world = emu.world
    assert world is not None
    seen = []
    for _ in range(40):  # 2 s in 50 ms steps, standing still, near landmark 1
        wait(emu, brick, 0.05)
        seen.append(world.touch_pressed)
    presses = sum(1 for a, b in zip([False] + seen, seen) if b and not a)
    assert presses == 2 and world.presses == 2


def test_a_landmark_missed_the_first_time():
    s = spec(landmarks=(Landmark(1, 400.0, misses=1),), start=Start(at_mm=100.0))
    w = World(s)
    w.pose.x, w.pose.y = 405.0 - s.robot.sensor_ahead_mm, 10.0
    first = w._light()
    w.pose.x = 200.0
    w._light()
    w.pose.x = 405.0 - s.robot.sensor_ahead_mm
    second = w._light()
    assert first == pytest.approx(s.markers.faint_percent) and second == pytest.approx(90.0)
    assert w.passes[1] == 2


@pytest.mark.parametrize("bad, message", [
    (dict(landmarks=(Landmark(1, 2995.0),)), "not on the track"),
    (dict(landmarks=(Landmark(1, 400.0), Landmark(1, 900.0))), "same number"),
    (dict(start=Start(landmark=7)), "no such landmark"),
    (dict(blocked=(Blocked(50.0, 150.0),)), "starts inside a blocked stretch"),
    (dict(presses=(Press(at_landmark=9),)), "no such landmark"),
    (dict(noise_percent=50.0), "noise_percent"),
])
def test_inconsistent_worlds_are_refused(bad, message):
    with pytest.raises(ValueError, match=message):
        spec(**bad)


def test_parts_validate_themselves():
    with pytest.raises(ValueError, match="at least two points"):
        Track(((0.0, 0.0),))
    with pytest.raises(ValueError, match="exactly one of at_s and at_landmark"):
        Press()
    with pytest.raises(ValueError, match="exactly one of at_mm and landmark"):
        Start()
    with pytest.raises(ValueError, match="from_mm < to_mm"):
        Blocked(5.0, 5.0)
    with pytest.raises(ValueError, match="1..15"):
        Landmark(16, 0.0)
    with pytest.raises(ValueError, match="positive"):
        Markers(bar_mm=0.0)


def test_the_default_delivery_world_starts_at_office_1():
    w = World(delivery_world())
    assert w.nearest_landmark() == 1 and w.spec.landmark(4).name == "office4"
