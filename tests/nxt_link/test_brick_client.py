"""Brick: skips stale replies, resyncs after damage, retries until the brick has gone (counted
from its last valid frame), reconnects, adapts its reply timeout, one-line errors."""
from __future__ import annotations

from collections import deque

import pytest

from nxt_link.host.brick import Brick, RetryPolicy
from nxt_link.wire import errors
from nxt_link.wire.clock import Deadline, VirtualClock

POLICY = RetryPolicy(reply_timeout_s=0.2, retries=2, quiet_s=0.01, reconnect_timeout_s=1.0,
                     min_reply_timeout_s=0.2)  # a fixed 0.2 s wait per attempt
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
        self.clock.sleep(quiet_s)  # waiting for a quiet line takes that long at least
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


def test_silence_is_a_one_line_timeout_once_the_brick_has_gone():
    b, t = brick([])
    with pytest.raises(errors.LinkTimeoutError) as info:
        b.get_battery_level()
    # give-up time (1 + retries) * reply_timeout_s = 0.6 s of silence: three 0.2 s waits
    assert str(info.value) == ("brick r9 did not answer GET_BATTERY_LEVEL for 0.6 s (3 attempts "
                               "on scripted; last: no reply within 0.2 s)")
    assert len(t.sent) == 3


def test_silence_is_counted_from_the_last_valid_frame_not_from_the_first_try():
    b, t = brick([[BATTERY]])
    assert b.get_battery_level() == 9000
    t.clock.sleep(30.0)  # idle: not silence
    with pytest.raises(errors.LinkTimeoutError, match=r"for 0.6 s \(3 attempts"):
        b.get_battery_level()
    # the brick has sent nothing valid since: the next command is not given another 0.6 s
    with pytest.raises(errors.LinkTimeoutError, match=r"\(1 attempt on"):
        b.keep_alive()
    # a valid frame ends the silence
    t.script.extend([[bytes.fromhex("02 0d 00 c0 27 09 00")]])
    assert b.keep_alive() == 600000
    assert b.last_valid_s == t.clock.now()


def test_a_brick_that_keeps_answering_is_never_given_up_however_long_it_takes():
    damaged = bytes.fromhex("02 0b 72 28 23")  # an undocumented status byte
    b, t = brick([[damaged], [BATTERY]] * 20)
    for _ in range(20):  # 20 x (a damaged reply, then a good one): 20 s, far past 0.6 s
        assert b.get_battery_level() == 9000
        t.clock.sleep(1.0)
    assert len(t.sent) == 40


def test_a_damaged_status_on_every_attempt_ends_as_a_timeout_not_as_that_status():
    # the run of the issue: MESSAGE_READ answered with status 0x72 ended the execution
    reply = bytes.fromhex("02 13 72") + bytes(61)
    events: list = []
    b, t = brick([[reply]] * 100, events)
    with pytest.raises(errors.LinkTimeoutError) as info:
        b.message_read(11)
    # a damaged reply costs what a lost one does: the budget is 0.6 s without a valid frame
    assert str(info.value).startswith("brick r9 did not answer MESSAGE_READ for 0.6 s (60 attempts")
    assert "last: damaged reply: MESSAGE_READ reply with status 0x72" in str(info.value)
    assert len(t.sent) == 60 and {e.event for e in events} == {"damaged reply"}


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


def test_status_the_command_cannot_get_is_retried_like_a_lost_reply():
    c0 = bytes.fromhex("02 0a c0")
    b, t = brick([[c0], [bytes.fromhex("02 0a 00")]])
    b.reset_motor_position(0, True)
    assert len(t.sent) == 2
    b, t = brick([[c0]] * 100)
    with pytest.raises(errors.LinkTimeoutError, match="status 0xC0, which this command cannot get"):
        b.reset_motor_position(0, True)
    # but a port the firmware does not have does get C0, and that is the answer
    b, t = brick([[c0]])
    with pytest.raises(errors.IllegalValueError):
        b.reset_motor_position(5, True)
    assert len(t.sent) == 1


OUTPUT_A = bytes.fromhex("02 06 00 00 00 00 00 00 00 00 00 00 00") + bytes(12)


@pytest.mark.parametrize("damaged, why", [
    (bytes.fromhex("02 06 00 01") + OUTPUT_A[4:], "for port 1, asked 0"),
    (bytes.fromhex("02 06 c0 00 05") + bytes(20), "status 0xC0"),
    (bytes.fromhex("02 06 ec") + bytes(22), "status 0xEC"),
    (OUTPUT_A[:-1], "has 24 bytes, expected 25"),
    (OUTPUT_A + b"\0", "has 26 bytes, expected 25"),
    (bytes.fromhex("02 06 00 00 00 09") + OUTPUT_A[6:], "a mode the firmware does not report"),
    (bytes.fromhex("01") + OUTPUT_A[1:], "is not a reply"),
])
def test_untrusted_replies_are_sent_again(damaged, why):
    events: list = []
    b, t = brick([[damaged], [OUTPUT_A]], events)
    assert b.get_output_state(0).rotation_count == 0
    assert len(t.sent) == 2
    assert events[0].event == "damaged reply" and why in events[0].detail


def test_mailbox_replies_must_echo_the_inbox_and_hold_a_message():
    good = bytes.fromhex("02 13 00 00 03 41 42 00") + bytes(56)
    wrong_inbox = bytes.fromhex("02 13 00 07 03 41 42 00") + bytes(56)
    no_nul = bytes.fromhex("02 13 00 00 03 41 42 43") + bytes(56)
    payload_on_error = bytes.fromhex("02 13 40 00 03 41 42 00") + bytes(56)
    events: list = []
    b, t = brick([[wrong_inbox], [no_nul], [payload_on_error], [good]], events)
    assert b.message_read(11) == b"AB"
    assert [e.detail.split(": ", 1)[1] for e in events] == [
        "MESSAGE_READ reply for local inbox 7, asked 0",
        "MESSAGE_READ reply with a message that does not end in NUL",
        "MESSAGE_READ error reply 0x40 with a payload"]


def test_a_reopen_that_fails_ends_it_at_once():
    class Unreachable(ScriptedTransport):
        def reconnect(self, deadline: Deadline) -> None:
            self.clock.advance_to(deadline.at)
            raise errors.LinkDisconnectedError("gone for good")

    t = Unreachable([errors.LinkDisconnectedError("gone")])
    b = Brick(t, name="r9", policy=POLICY)
    with pytest.raises(errors.LinkDisconnectedError, match="could not be reopened within 1 s"):
        b.get_battery_level()
    assert len(t.sent) == 1


def test_the_reply_timeout_adapts_to_the_round_trip():
    policy = RetryPolicy(reply_timeout_s=1.0, retries=3, min_reply_timeout_s=0.1)

    class Slow(ScriptedTransport):
        def recv(self, deadline: Deadline) -> bytes:
            if self.pending:
                self.clock.sleep(0.03)  # a 30 ms round trip
            return super().recv(deadline)

    t = Slow([[BATTERY]] * 5 + [[]] + [[BATTERY]])
    b = Brick(t, name="r9", policy=policy)
    assert b.reply_timeout_s == 1.0  # nothing measured yet
    for _ in range(5):
        b.get_battery_level()
    assert b.reply_timeout_s == pytest.approx(0.1)  # 30 ms round trips: the floor
    before = t.clock.now()
    b.get_battery_level()  # lost once: 0.1 s wait, then backed off
    assert t.clock.now() - before == pytest.approx(0.1 + 0.05 + 0.03)  # wait, quiet line, reply


def test_start_program_is_never_repeated_blindly():
    b, t = brick([])
    with pytest.raises(errors.LinkTimeoutError, match=r"\(1 attempt on scripted"):
        b.start_program("x.rxe")
    assert len(t.sent) == 1


def test_no_reply_commands_do_not_wait():
    b, t = brick([])
    b.play_tone(440, 100)
    b.set_output_state(0, 50, 1, 0, 0, 0x20, 0)
    assert t.sent == [bytes.fromhex("80 03 b8 01 64 00"),
                      bytes.fromhex("80 04 00 32 01 00 00 20 00 00 00 00")]
    assert t.clock.now() == 0.0
