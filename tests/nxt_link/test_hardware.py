"""A real NXT brick (``python -m pytest --run-nxt /dev/rfcomm0``); skipped without one.

The same checks the emulator passes elsewhere, against the hardware: direct commands
through our client and through nxt-python (an independent client), a motor under a tacho
limit, and a short setpoint stream through the brick program (``cplus_follow.rxe`` must
have been downloaded; see docs/nxt-link.md). Motor A turns: leave it free to move.
They also run against an emulated brick: ``cplus brick --name r1`` prints a port to give.
"""
from __future__ import annotations

import time

import pytest

from nxt_link import Brick, RetryPolicy, SerialTransport, SetpointStream, execute_streams

pytestmark = [pytest.mark.hardware, pytest.mark.slow]

BLUETOOTH = RetryPolicy(reply_timeout_s=2.0, retries=3)   # a healthy round trip is 30-60 ms


@pytest.fixture
def brick(nxt_port):
    b = Brick(SerialTransport(nxt_port), name="r1", policy=BLUETOOTH)
    yield b
    b.close()


def test_direct_commands_answer(brick):
    assert 4000 < brick.get_battery_level() < 10000      # millivolts of six AA cells / the pack
    assert brick.keep_alive() > 0                         # the sleep timer, in ms


def test_nxt_python_sees_the_same_brick(nxt_port):
    import nxt.locator
    with Brick(SerialTransport(nxt_port), name="r1", policy=BLUETOOTH) as ours:
        mv = ours.get_battery_level()
    theirs = nxt.locator.find(backends=["devfile"], filename=nxt_port, config=None)
    try:
        assert abs(theirs.get_battery_level() - mv) < 500
    finally:
        theirs.close()


def test_motor_a_stops_at_its_tacho_limit(brick):
    port, limit = 0, 360
    brick.reset_motor_position(port, relative=False)
    # power 50, MOTORON|REGULATED, speed regulation, turn ratio 0, RUNNING, tacho limit
    brick.set_output_state(port, 50, 0x01 | 0x04, 1, 0, 0x20, limit)
    last = None
    for _ in range(100):                  # poll until the motor has coasted to a stop
        time.sleep(0.1)
        state = brick.get_output_state(port)
        if state.run_state == 0 and state.tacho_count == last:
            break
        last = state.tacho_count
    else:
        pytest.fail(f"motor A did not stop: {state}")
    assert limit <= state.tacho_count < limit + 180


def test_a_setpoint_stream_is_followed(brick):
    """The brick program follows 0 -> 90 -> 0 degrees on motor A (it is started if needed)."""
    rows = tuple((round(90 * min(k, 40 - k) / 20),) for k in range(41))   # 0 -> 90 -> 0 degrees
    log = execute_streams([SetpointStream("r1", ("A",), 50, rows)], {"r1": brick})
    errors = [abs(e[0]) for e in log.brick("r1").tracking_error_deg]
    assert len(log.brick("r1").measured_deg) == len(rows)
    assert max(errors) < 45 and abs(log.brick("r1").measured_deg[-1][0]) < 15
