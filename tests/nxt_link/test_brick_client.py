"""Brick: skips stale replies, resyncs after damage, retries, reconnects, one-line errors."""
from __future__ import annotations

from collections import deque

import pytest

from nxt_link import errors
from nxt_link.brick import Brick, RetryPolicy
from nxt_link.clock import Deadline, VirtualClock

POLICY = RetryPolicy(reply_timeout_s=0.2, retries=2, quiet_s=0.01, reconnect_timeout_s=1.0)
BATTERY = bytes.fromhex("02 0b 00 28 23")


class ScriptedTransport:
    """Replies from a script: one list of telegrams (or an exception) per send."""

    def __init__(self, script: list) -> None:
        self.name = "scripted"
        self.clock = VirtualClock()
        self.script = deque(script)
        self.sent: list[bytes] = []
        self.pending: deque = deque()
        self.reconnects = 0
        self.discards = 0

    def send(self, telegram: bytes) -> None:
        self.sent.append(telegram)
        step = self.script.popleft() if self.script else []
        if isinstance(step, Exception):
            raise step
        self.pending.extend(step)

    def recv(self, deadline: Deadline) -> bytes:
        if self.pending:
            return self.pending.popleft()
        self.clock.advance_to(deadline.at)
        raise errors.LinkTimeoutError("scripted: nothing")

    def discard_input(self, quiet_s: float) -> int:
        self.discards += 1
        self.pending.clear()
        return 0

    def reconnect(self, deadline: Deadline) -> None:
        self.reconnects += 1

    def close(self) -> None:
        pass


def brick(script: list, events: list | None = None) -> tuple[Brick, ScriptedTransport]:
    t = ScriptedTransport(script)
    return Brick(t, name="r9", policy=POLICY, on_event=(events.append if events is not None
                                                           else None)), t


def test_stale_reply_of_another_opcode_is_skipped():
    events: list = []
    b, t = brick([[bytes.fromhex("02 0d 00 c0 27 09 00"), BATTERY]], events)
    assert b.get_battery_level() == 9000
    assert len(t.sent) == 1
    assert [e.event for e in events] == ["stale reply"]


def test_damaged_reply_is_discarded_and_the_command_resent():
    events: list = []
    b, t = brick([[bytes.fromhex("02 0b 00 28")], [BATTERY]], events)
    assert b.get_battery_level() == 9000
    assert len(t.sent) == 2 and t.discards == 1
    assert events[0].event == "damaged reply" and "expected 5" in events[0].detail


def test_silence_is_a_one_line_timeout_after_all_attempts():
    b, t = brick([])
    with pytest.raises(errors.LinkTimeoutError) as info:
        b.get_battery_level()
    assert str(info.value) == ("brick r9 did not answer GET_BATTERY_LEVEL within 0.2 s "
                               "(3 attempts) on scripted")
    assert len(t.sent) == 3


def test_lost_link_is_reopened_and_the_command_resent():
    events: list = []
    b, t = brick([errors.LinkDisconnectedError("gone"), [BATTERY]], events)
    assert b.get_battery_level() == 9000
    assert t.reconnects == 1
    assert [e.event for e in events] == ["link lost", "reconnected"]


def test_semantic_status_is_raised_at_once_with_the_brick_name():
    b, t = brick([[bytes.fromhex("02 11 ec") + bytes(20)]])
    with pytest.raises(errors.NoActiveProgramError) as info:
        b.get_current_program_name()
    assert len(t.sent) == 1
    assert str(info.value).startswith("brick r9: GET_CURRENT_PROGRAM_NAME failed: brick status "
                                      "0xEC: no program is running")


def test_status_only_a_damaged_request_can_cause_is_retried():
    c0 = bytes.fromhex("02 0a c0")
    b, t = brick([[c0], [bytes.fromhex("02 0a 00")]])
    b.reset_motor_position(0, True)
    assert len(t.sent) == 2
    b, t = brick([[c0], [c0], [c0]])
    with pytest.raises(errors.IllegalValueError):
        b.reset_motor_position(0, True)
    assert len(t.sent) == 3


def test_start_program_is_never_repeated_blindly():
    b, t = brick([])
    with pytest.raises(errors.LinkTimeoutError, match=r"\(1 attempt\)"):
        b.start_program("x.rxe")
    assert len(t.sent) == 1


def test_no_reply_commands_do_not_wait():
    b, t = brick([])
    b.play_tone(440, 100)
    b.set_output_state(0, 50, 1, 0, 0, 0x20, 0)
    assert t.sent == [bytes.fromhex("80 03 b8 01 64 00"),
                      bytes.fromhex("80 04 00 32 01 00 00 20 00 00 00 00")]
    assert t.clock.now() == 0.0
