"""Telegram codec: golden bytes identical to nxt-python 3.5.1, round trips, status errors."""
from __future__ import annotations

import nxt.brick
import nxt.motor
import nxt.sensor
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nxt_link.wire import errors
from nxt_link.wire import telegram as tg

# (our command, hex of the telegram nxt-python 3.5.1 sends for the same call, that call)
GOLDEN = [
    (tg.StartProgram("cplus_follow.rxe"),
     "00 00 63 70 6c 75 73 5f 66 6f 6c 6c 6f 77 2e 72 78 65 00 00 00 00",
     lambda b: b.start_program("cplus_follow.rxe"), "020000"),
    (tg.StopProgram(), "00 01", lambda b: b.stop_program(), "020100"),
    (tg.PlayTone(440, 100), "80 03 b8 01 64 00", lambda b: b.play_tone(440, 100), None),
    (tg.SetOutputState(1, -75, 0x07, 1, 0, 0x20, 360), "80 04 01 b5 07 01 00 20 68 01 00 00",
     lambda b: b.set_output_state(
         nxt.motor.Port.B, -75,
         nxt.motor.Mode.ON | nxt.motor.Mode.BRAKE | nxt.motor.Mode.REGULATED,
         nxt.motor.RegulationMode.SPEED, 0, nxt.motor.RunState.RUNNING, 360), None),
    (tg.SetInputMode(2, 0x01, 0x20), "80 05 02 01 20",
     lambda b: b.set_input_mode(nxt.sensor.Port.S3, nxt.sensor.Type.SWITCH,
                                nxt.sensor.Mode.BOOL), None),
    (tg.GetOutputState(2), "00 06 02",
     lambda b: b.get_output_state(nxt.motor.Port.C), "020600" + "02" + "00" * 21),
    (tg.GetInputValues(0), "00 07 00",
     lambda b: b.get_input_values(nxt.sensor.Port.S1), "020700" + "00" * 13),
    (tg.MessageWrite(1, b"hello"), "00 09 01 06 68 65 6c 6c 6f 00",
     lambda b: b.message_write(1, b"hello"), "020900"),
    (tg.MessageRead(11, 0, True), "00 13 0b 00 01",
     lambda b: b.message_read(11, 0, True), "021300000548454c4c4f00" + "00" * 54),
    (tg.ResetMotorPosition(0, True), "00 0a 00 01",
     lambda b: b.reset_motor_position(nxt.motor.Port.A, True), "020a00"),
    (tg.ResetMotorPosition(0, False), "00 0a 00 00",
     lambda b: b.reset_motor_position(nxt.motor.Port.A, False), "020a00"),
    (tg.GetBatteryLevel(), "00 0b", lambda b: b.get_battery_level(), "020b002823"),
    (tg.KeepAlive(), "00 0d", lambda b: b.keep_alive(), "020d00c0270900"),
    (tg.GetCurrentProgramName(), "00 11",
     lambda b: b.get_current_program_name(), "021100" + "00" * 20),
]


class _RecordingSocket:
    """The smallest nxt-python socket: records what nxt-python sends."""

    bsize = 118
    type = "bluetooth"

    def __init__(self, reply: str | None) -> None:
        self.sent: list[bytes] = []
        self._reply = bytes.fromhex(reply) if reply else None

    def send(self, data: bytes) -> None:
        self.sent.append(data)

    def recv(self) -> bytes:
        assert self._reply is not None
        return self._reply

    def close(self) -> None:
        pass


@pytest.mark.parametrize("cmd, golden, _call, _reply", GOLDEN,
                         ids=[type(g[0]).__name__ for g in GOLDEN])
def test_encoding_matches_golden_bytes(cmd, golden, _call, _reply):
    assert tg.encode_command(cmd) == bytes.fromhex(golden)


@pytest.mark.parametrize("cmd, golden, call, reply", GOLDEN,
                         ids=[type(g[0]).__name__ for g in GOLDEN])
def test_golden_bytes_are_what_nxt_python_sends(cmd, golden, call, reply):
    sock = _RecordingSocket(reply)
    call(nxt.brick.Brick(sock))
    assert sock.sent == [bytes.fromhex(golden)]


def test_reply_decoding_matches_protocol_doc_examples():
    # protocol doc §9: GETOUTPUTSTATE port A idle, tacho 123, block 45, rotation 678
    raw = bytes.fromhex("02 06 00 00 00 00 00 00 00 00 00 00 00 7B 00 00 00 2D 00 00 00 A6 02 00 00")
    r = tg.decode_reply(raw, tg.Opcode.GET_OUTPUT_STATE)
    assert (r.port, r.tacho_count, r.block_tacho_count, r.rotation_count) == (0, 123, 45, 678)
    # MESSAGEREAD of "12.5": the size includes the NUL; payload strips it
    raw = bytes.fromhex("02 13 00 00 05 31 32 2E 35 00") + bytes(54)
    r = tg.decode_reply(raw, tg.Opcode.MESSAGE_READ)
    assert r.message == b"12.5\x00" and r.payload == b"12.5"


@pytest.mark.parametrize("status, cls", [
    (0x40, errors.EmptyMailboxError), (0xEC, errors.NoActiveProgramError),
    (0xC0, errors.IllegalValueError), (0xEE, errors.InvalidQueueError),
    (0xBE, errors.UnknownCommandError), (0x20, errors.PendingCommunicationError),
    (0x77, errors.UnknownStatusError)])
def test_status_bytes_raise_their_exception(status, cls):
    raw = tg.error_reply(tg.Opcode.MESSAGE_READ, status, local_inbox=3)
    assert len(raw) == 64 and raw[3] == 3  # fixed length, local inbox echoed
    with pytest.raises(cls) as info:
        tg.decode_reply(raw, tg.Opcode.MESSAGE_READ)
    assert isinstance(info.value, errors.ProtocolError)
    assert info.value.status == status
    assert "\n" not in str(info.value)


def test_error_replies_have_the_fixed_length_of_their_opcode():
    for op, length in tg.REPLY_LENGTH.items():
        raw = tg.error_reply(op, 0xC0)
        assert len(raw) == length and raw[:3] == bytes((2, op, 0xC0))
        assert not any(raw[4:])
    assert tg.error_reply(0x42, 0xBE) == bytes.fromhex("02 42 be")


@pytest.mark.parametrize("raw, message", [
    ("02", "no opcode"),
    ("00 0b", "not a reply"),
    ("02 0b 00 28", "expected 5"),
    ("02 13 00 00 05 31", "expected 64"),
])
def test_damaged_replies_are_telegram_errors(raw, message):
    with pytest.raises(errors.TelegramError, match=message):
        tg.parse_reply(bytes.fromhex(raw))


def test_reply_to_another_opcode_is_refused():
    with pytest.raises(errors.TelegramError, match="waiting for 0x0B"):
        tg.decode_reply(bytes.fromhex("02 0d 00 c0 27 09 00"), tg.Opcode.GET_BATTERY_LEVEL)


def test_encoder_refuses_what_does_not_fit():
    with pytest.raises(errors.TelegramError, match="exceeds 58"):
        tg.encode_command(tg.MessageWrite(1, bytes(59)))
    with pytest.raises(errors.TelegramError, match="longer than 19"):
        tg.encode_command(tg.StartProgram("a" * 20))
    with pytest.raises(errors.TelegramError, match="out of range"):
        tg.encode_command(tg.SetOutputState(0, 200, 1, 0, 0, 0x20, 0))


def test_decoder_refuses_truncated_commands():
    with pytest.raises(errors.TelegramError, match="truncated"):
        tg.decode_command(bytes.fromhex("80 04 01 b5 07"))
    with pytest.raises(errors.TelegramError, match="truncated"):
        tg.decode_command(bytes.fromhex("00 09 01 06 68 65"))
    with pytest.raises(errors.TelegramError, match="unknown opcode"):
        tg.decode_command(bytes.fromhex("00 42"))


# -- round trips ---------------------------------------------------------------------

u8 = st.integers(0, 255)
s8 = st.integers(-128, 127)
name = st.text(alphabet="abcdefghijklmnopqrstuvwxyz._0123456789", min_size=1, max_size=19)
flag = st.booleans()

commands = st.one_of(
    st.builds(tg.StartProgram, name, flag),
    st.builds(tg.StopProgram, flag),
    st.builds(tg.PlayTone, st.integers(0, 0xFFFF), st.integers(0, 0xFFFF), flag),
    st.builds(tg.SetOutputState, u8, s8, u8, u8, s8, u8, st.integers(0, 2**32 - 1), flag),
    st.builds(tg.SetInputMode, u8, u8, u8, flag),
    st.builds(tg.GetOutputState, u8, flag),
    st.builds(tg.GetInputValues, u8, flag),
    st.builds(tg.MessageWrite, u8, st.binary(max_size=58), flag),
    st.builds(tg.MessageRead, u8, u8, flag, flag),
    st.builds(tg.ResetMotorPosition, u8, flag, flag),
    st.builds(tg.GetBatteryLevel, flag),
    st.builds(tg.KeepAlive, flag),
    st.builds(tg.GetCurrentProgramName, flag),
)

s32 = st.integers(-2**31, 2**31 - 1)
replies = st.one_of(
    st.builds(tg.StatusReply, st.sampled_from([0, 1, 3, 4, 5, 9, 10]), u8),
    st.builds(tg.OutputStateReply, u8, u8, s8, u8, u8, s8, u8, st.integers(0, 2**32 - 1),
              s32, s32, s32),
    st.builds(tg.InputValuesReply, u8, u8, flag, flag, u8, u8, st.integers(0, 0xFFFF),
              st.integers(0, 0xFFFF), st.integers(-32768, 32767), st.integers(-32768, 32767)),
    st.builds(tg.BatteryLevelReply, u8, st.integers(0, 0xFFFF)),
    st.builds(tg.KeepAliveReply, u8, st.integers(0, 2**32 - 1)),
    st.builds(tg.ProgramNameReply, u8, name),
    st.builds(tg.MessageReadReply, u8, u8, st.binary(max_size=59)),
)


@given(commands)
def test_command_round_trip(cmd):
    assert tg.decode_command(tg.encode_command(cmd)) == cmd


@given(replies)
def test_reply_round_trip(reply):
    raw = tg.encode_reply(reply)
    assert len(raw) == tg.REPLY_LENGTH[tg.Opcode(int(reply.opcode))]
    assert tg.parse_reply(raw) == reply


@given(st.binary(max_size=70))
def test_arbitrary_bytes_never_raise_anything_but_telegram_error(raw):
    for fn in (tg.parse_reply, tg.decode_command):
        try:
            fn(raw)
        except errors.TelegramError:
            pass
