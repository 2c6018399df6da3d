"""An independent client, nxt-python 3.5.1, reads the world's sensors and drives the robot.

nxt-python talks to the emulator's pty through its device-file backend, with its own
telegram code: GETINPUTVALUES and SETINPUTMODE answered from the world are what a real
brick on that track would answer.
"""
from __future__ import annotations

import time

import nxt.locator
import nxt.motor
import nxt.sensor
import nxt.sensor.generic
import pytest

from nxt_link import delivery_world
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, LinkParams
from nxt_link.emulator.input_module import SensorMode, SensorType
from nxt_link.emulator.pty_server import PtyBrickServer

pytestmark = pytest.mark.slow   # nxt-python over a pty, in real time


def serve(program_running: bool):
    emu = BrickEmulator(EmulatorConfig(name="robot", world=delivery_world(seed=9),
                                       link=LinkParams.instant(),
                                       program_running=program_running))
    server = PtyBrickServer(emu, time_scale=1.0)
    server.start()
    brick = nxt.locator.find(backends=["devfile"], filename=server.path, config=None)
    yield brick, emu
    brick.close()
    server.stop()
    assert server.error is None


@pytest.fixture
def robot():
    """The delivery robot with its Legolog program running."""
    yield from serve(True)


@pytest.fixture
def bare_robot():
    """The robot on its track with no program: nxt-python owns the sensors and motors."""
    yield from serve(False)


def wait_for(predicate, timeout_s: float = 60.0) -> bool:
    """Poll (a bound against hanging, not a timing assertion)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return predicate()


def test_nxt_python_reads_the_light_sensor_the_program_configured(robot):
    brick, _ = robot
    # the program sets its sensors up, then the firmware's data become valid
    assert wait_for(lambda: brick.get_input_values(nxt.sensor.Port.S3)[1:5:2] == (
        True, nxt.sensor.Type.LIGHT_ACTIVE))
    port, valid, calibrated, stype, smode, raw, normalized, scaled, cal = \
        brick.get_input_values(nxt.sensor.Port.S3)
    assert (port, stype, smode) == (nxt.sensor.Port.S3, nxt.sensor.Type.LIGHT_ACTIVE,
                                    nxt.sensor.Mode.PERCENT)
    # the robot stands on the line's left edge: half line (30 %), half floor (60 %)
    assert 40 <= scaled <= 50 and cal == normalized and 500 < raw < 650


def test_nxt_python_sensor_classes_read_the_world(bare_robot):
    brick, emu = bare_robot
    light = nxt.sensor.generic.Light(brick, nxt.sensor.Port.S3)  # active, raw mode
    level = light.get_lightness()
    assert 400 <= level <= 520  # about 45 % of 1023
    touch = nxt.sensor.generic.Touch(brick, nxt.sensor.Port.S1)
    assert touch.is_pressed() is False
    emu.world.press(1.5)
    assert wait_for(touch.is_pressed)
    assert wait_for(lambda: not touch.is_pressed())
    fw = emu.firmware
    assert (fw.inputs[0].sensor_type, fw.inputs[0].sensor_mode) == (SensorType.SWITCH,
                                                                    SensorMode.BOOLEAN)


def test_nxt_python_drives_the_robot_along_the_track(bare_robot):
    brick, emu = bare_robot
    start = emu.world.position_mm
    left = nxt.motor.Motor(brick, nxt.motor.Port.B)
    right = nxt.motor.Motor(brick, nxt.motor.Port.C)
    left.run(40)
    right.run(40)
    assert wait_for(lambda: emu.world.position_mm > start + 100)
    left.brake()
    right.brake()
    tacho = left.get_tacho().rotation_count
    assert tacho > 150  # at least 100 mm on a 56 mm wheel
