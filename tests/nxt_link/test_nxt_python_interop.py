"""An independent client: nxt-python 3.5.1 (device-file backend) drives the emulator's pty.

nxt-python is a declared test dependency; if it is missing this module fails
to import, which fails the run (nothing is skipped).
"""
from __future__ import annotations

import time

import nxt.error
import nxt.locator
import nxt.motor
import pytest

from nxt_link.programs.stream_protocol import PROGRAM_NAME

pytestmark = pytest.mark.slow   # nxt-python over a pty, in real time


@pytest.fixture
def nxt_brick(pty_server):
    server = pty_server("r1", time_scale=1.0)
    brick = nxt.locator.find(backends=["devfile"], filename=server.path, config=None)
    yield brick, server.emulator
    brick.close()


def test_battery_keepalive_program_name(nxt_brick):
    brick, _ = nxt_brick
    assert brick.get_battery_level() == 9000
    assert brick.keep_alive() == 600000
    assert brick.get_current_program_name() == PROGRAM_NAME


def test_tone_is_played_without_a_reply(nxt_brick):
    brick, emu = nxt_brick
    brick.play_tone(440, 250)
    # a stray reply would be read as the answer to the next command and break it
    assert brick.get_battery_level() == 9000
    assert [(t.frequency_hz, t.duration_ms) for t in emu.firmware.tones] == [(440, 250)]


def test_message_write_and_read(nxt_brick):
    brick, _ = nxt_brick
    brick.message_write(5, b"hello")  # inbox 5: the brick program does not read it
    brick.message_write(5, b"world")
    assert brick.message_read(5, 2, False) == (2, b"hello\x00")  # peek
    assert brick.message_read(5, 0, True) == (0, b"hello\x00")
    assert brick.message_read(5, 0, True) == (0, b"world\x00")
    with pytest.raises(nxt.error.EmptyMailboxError):
        brick.message_read(5, 0, True)


def running_program(brick) -> str | None:
    try:
        return brick.get_current_program_name()
    except nxt.error.NoActiveProgramError:
        return None


def wait_for(predicate, timeout_s: float = 60.0) -> None:
    """Poll (no timed assertion: only a generous upper bound against hanging)."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "condition never became true"
        time.sleep(0.02)


def test_no_program_errors_as_nxt_python_expects(nxt_brick):
    brick, _ = nxt_brick
    brick.stop_program()
    wait_for(lambda: running_program(brick) is None)
    with pytest.raises(nxt.error.NoActiveProgramError):
        brick.get_current_program_name()
    with pytest.raises(nxt.error.NoActiveProgramError):
        brick.message_write(1, b"x")
    with pytest.raises(nxt.error.NoActiveProgramError):
        brick.stop_program()
    brick.start_program(PROGRAM_NAME)
    wait_for(lambda: running_program(brick) == PROGRAM_NAME)  # the UI starts it after 200 ms
    with pytest.raises(nxt.error.DirectProtocolError):
        brick.start_program("missing.rxe")


def test_motor_turns_360_degrees_under_a_tacho_limit(nxt_brick):
    brick, _ = nxt_brick
    port = nxt.motor.Port.A
    brick.reset_motor_position(port, False)
    brick.reset_motor_position(port, True)
    state = brick.get_output_state(port)
    assert state[7:] == (0, 0, 0)
    brick.set_output_state(port, 75, nxt.motor.Mode.ON | nxt.motor.Mode.REGULATED,
                           nxt.motor.RegulationMode.SPEED, 0, nxt.motor.RunState.RUNNING, 360)
    deadline = time.monotonic() + 60.0   # a guard against hanging, not a measure
    last = None
    while time.monotonic() < deadline:
        time.sleep(0.1)
        state = brick.get_output_state(port)
        if state[5] == nxt.motor.RunState.IDLE and state[7:] == last:
            break  # limit reached and the motor has coasted to a stop
        last = state[7:]
    else:
        pytest.fail(f"motor did not stop: {state}")
    _, power, mode, regmode, _, run_state, limit, tacho, block, rotation = state
    assert (power, limit, run_state) == (75, 360, nxt.motor.RunState.IDLE)
    assert mode == nxt.motor.Mode.ON | nxt.motor.Mode.REGULATED
    assert regmode == nxt.motor.RegulationMode.SPEED
    assert 360 <= tacho <= 520  # power cut at 360, then it coasts on
    assert tacho == block == rotation
    brick.reset_motor_position(port, False)
    assert brick.get_output_state(port)[7:] == (tacho, tacho, 0)
