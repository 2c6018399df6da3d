"""Telegram codec edges: which statuses each command can get, which replies are refused as
damaged, and the exact bytes and messages at every field's limit."""
from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nxt_link.wire import errors
from nxt_link.wire import telegram as tg

OK, EMPTY, FILE_FAILED, ILLEGAL, NO_PROGRAM, INVALID_QUEUE = 0x00, 0x40, 0xBD, 0xC0, 0xEC, 0xEE


@pytest.mark.parametrize("cmd, statuses", [
    (tg.StartProgram("a.rxe"), {OK, ILLEGAL, FILE_FAILED}),
    (tg.StopProgram(), {OK, NO_PROGRAM}),
    (tg.GetCurrentProgramName(), {OK, NO_PROGRAM}),
    (tg.GetOutputState(2), {OK}),
    (tg.GetOutputState(3), {ILLEGAL}),
    (tg.ResetMotorPosition(2, True), {OK}),
    (tg.ResetMotorPosition(3, True), {ILLEGAL}),
    (tg.SetOutputState(2, 0, 0, 0, 0, 0, 0), {OK}),
    (tg.SetOutputState(3, 0, 0, 0, 0, 0, 0), {ILLEGAL}),
    (tg.SetOutputState(0xFF, 0, 0, 0, 0, 0, 0), {OK}),
    (tg.SetOutputState(0xFE, 0, 0, 0, 0, 0, 0), {ILLEGAL}),
    (tg.GetInputValues(3), {OK}),
    (tg.GetInputValues(4), {ILLEGAL}),
    (tg.GetInputValues(5), {ILLEGAL}),
    (tg.SetInputMode(3, 0, 0), {OK}),
    (tg.SetInputMode(4, 0, 0), {ILLEGAL}),
    (tg.MessageWrite(19, bytes(58)), {OK, NO_PROGRAM}),
    (tg.MessageWrite(0, b"hi"), {OK, NO_PROGRAM}),
    (tg.MessageWrite(20, bytes(58)), {INVALID_QUEUE}),
    (tg.MessageWrite(1, bytes(59)), {ILLEGAL}),
    (tg.MessageWrite(20, bytes(59)), {ILLEGAL}),  # the size is checked before the queue
    (tg.MessageRead(19), {OK, EMPTY, NO_PROGRAM}),
    (tg.MessageRead(20), {NO_PROGRAM, INVALID_QUEUE}),
    (tg.MessageRead(21), {NO_PROGRAM, INVALID_QUEUE}),
    (tg.GetBatteryLevel(), {OK}),
    (tg.KeepAlive(), {OK}),
    (tg.PlayTone(440, 10), {OK}),
    (tg.GetFirmwareVersion(), {OK}),
], ids=repr)
def test_plausible_statuses_at_each_limit(cmd, statuses):
    assert tg.plausible_statuses(cmd) == frozenset(statuses)


def _refused(cmd, reply) -> str:
    with pytest.raises(errors.TelegramError) as info:
        tg.check_reply(cmd, reply)
    return str(info.value)


def _output_state(port=0, mode=0, regulation_mode=0, run_state=0, status=0):
    return tg.OutputStateReply(status, port, 0, mode, regulation_mode, 0, run_state, 0, 0, 0, 0)


def _input_values(port=0, status=0, raw=0):
    return tg.InputValuesReply(status, port, False, False, 0, 0, raw, 0, 0, 0)


def test_a_status_the_command_cannot_get_is_refused():
    assert _refused(tg.GetOutputState(3), _output_state(port=3)) == (
        "GET_OUTPUT_STATE reply with status 0x00, which this command cannot get")
    assert _refused(tg.StopProgram(), tg.StatusReply(tg.Opcode.STOP_PROGRAM, 0x40)) == (
        "STOP_PROGRAM reply with status 0x40, which this command cannot get")


def test_an_error_reply_must_be_zero_filled():
    tg.check_reply(tg.GetOutputState(3), _output_state(status=ILLEGAL))
    assert _refused(tg.GetOutputState(3), _output_state(port=3, status=ILLEGAL)) == (
        "GET_OUTPUT_STATE error reply 0xC0 with a payload")
    tg.check_reply(tg.GetInputValues(4), _input_values(status=ILLEGAL))
    assert "with a payload" in _refused(tg.GetInputValues(4), _input_values(status=ILLEGAL, raw=1))


def test_an_error_reply_to_message_read_echoes_the_local_inbox_only():
    cmd = tg.MessageRead(3, local_inbox=5)
    tg.check_reply(cmd, tg.MessageReadReply(EMPTY, 5, b""))
    assert _refused(cmd, tg.MessageReadReply(EMPTY, 6, b"")) == (
        "MESSAGE_READ reply for local inbox 6, asked 5")
    assert _refused(cmd, tg.MessageReadReply(EMPTY, 5, b"\0")) == (
        "MESSAGE_READ error reply 0x40 with a payload")  # a size of 1 is a payload byte
    assert _refused(cmd, tg.MessageReadReply(EMPTY, 5, b"a\0")) == (
        "MESSAGE_READ error reply 0x40 with a payload")


def test_the_echoed_port_must_be_the_one_asked():
    tg.check_reply(tg.GetOutputState(2), _output_state(port=2))
    assert _refused(tg.GetOutputState(2), _output_state(port=1)) == (
        "GET_OUTPUT_STATE reply for port 1, asked 2")
    assert _refused(tg.GetOutputState(1), _output_state(port=2)) == (
        "GET_OUTPUT_STATE reply for port 2, asked 1")
    tg.check_reply(tg.GetInputValues(3), _input_values(port=3))
    assert _refused(tg.GetInputValues(3), _input_values(port=0)) == (
        "GET_INPUT_VALUES reply for port 0, asked 3")


@pytest.mark.parametrize("field, good, bad", [
    ("mode", [0, 1, 7], [8, 0xFF]),
    ("regulation_mode", [0, 1, 2], [3]),
    ("run_state", [0x00, 0x10, 0x20, 0x40], [0x01, 0x30, 0x80]),
])
def test_output_state_modes_the_firmware_reports(field, good, bad):
    for value in good:
        tg.check_reply(tg.GetOutputState(0), _output_state(**{field: value}))
    for value in bad:
        assert _refused(tg.GetOutputState(0), _output_state(**{field: value})) == (
            "GET_OUTPUT_STATE reply with a mode the firmware does not report")


def test_a_message_read_reply_must_echo_the_inbox_and_end_in_nul():
    cmd = tg.MessageRead(11, local_inbox=2)
    tg.check_reply(cmd, tg.MessageReadReply(OK, 2, b"\0"))
    tg.check_reply(cmd, tg.MessageReadReply(OK, 2, b"12.5\0"))
    assert _refused(cmd, tg.MessageReadReply(OK, 3, b"x\0")) == "MESSAGE_READ reply for local inbox 3, asked 2"
    for message in (b"", b"x", b"\0x"):
        assert _refused(cmd, tg.MessageReadReply(OK, 2, message)) == (
            "MESSAGE_READ reply with a message that does not end in NUL")


def test_a_program_name_must_be_printable_ascii():
    cmd = tg.GetCurrentProgramName()
    for name in (" ", "~", "cplus_follow.rxe"):
        tg.check_reply(cmd, tg.ProgramNameReply(OK, name))
    for name in ("", "a\x1f", "\x7f", "\xe9"):
        assert _refused(cmd, tg.ProgramNameReply(OK, name)) == (
            f"GET_CURRENT_PROGRAM_NAME reply with the unprintable name {name!r}")


def test_system_commands_have_their_own_type_byte():
    assert tg.Opcode.GET_DEVICE_INFO.is_system and not tg.Opcode.MESSAGE_READ.is_system
    assert tg.encode_command(tg.GetFirmwareVersion()) == bytes.fromhex("01 88")
    assert tg.encode_command(tg.GetDeviceInfo(reply=False)) == bytes.fromhex("81 9b")
    assert tg.decode_command(bytes.fromhex("01 9b")) == tg.GetDeviceInfo()
    assert tg.decode_command(bytes.fromhex("81 88")) == tg.GetFirmwareVersion(reply=False)
    assert tg.encode_command(tg.KeepAlive(reply=False)) == bytes.fromhex("80 0d")
    with pytest.raises(errors.TelegramError, match="^opcode 0x88 sent with telegram type 0x00$"):
        tg.decode_command(bytes.fromhex("00 88"))
    with pytest.raises(errors.TelegramError, match="^opcode 0x0D sent with telegram type 0x81$"):
        tg.decode_command(bytes.fromhex("81 0d"))


def test_command_decoding_errors_name_what_is_wrong():
    def refused(hex_: str) -> str:
        with pytest.raises(errors.TelegramError) as info:
            tg.decode_command(bytes.fromhex(hex_))
        return str(info.value)
    assert refused("02 0b") == "telegram type 0x02 is not a command"
    assert refused("00") == "telegram of 1 byte(s) has no opcode"
    assert refused("00 42") == "unknown opcode 0x42"
    assert refused("80 04 01 b5 07") == "SET_OUTPUT_STATE telegram truncated: 5 of 12 bytes"
    assert refused("00 00" + "61" * 19) == "START_PROGRAM telegram truncated: 21 of 22 bytes"
    assert refused("00 09 01 06 68 65") == "MESSAGE_WRITE truncated: size field 6, 2 data bytes"
    assert refused("00 09 01") == "MESSAGE_WRITE telegram truncated: 3 of 4 bytes"
    # exactly long enough, and bytes beyond the command's length ignored
    assert tg.decode_command(bytes.fromhex("00 06 02")) == tg.GetOutputState(2)
    assert tg.decode_command(bytes.fromhex("00 06 02 ff ff")) == tg.GetOutputState(2)
    assert tg.decode_command(bytes.fromhex("00 09 04 00")) == tg.MessageWrite(4, b"")
    assert tg.decode_command(bytes.fromhex("00 09 04 01 07")) == tg.MessageWrite(4, b"")
    assert tg.decode_command(bytes.fromhex("00 09 04 02 41 07 99")) == tg.MessageWrite(4, b"A")


def test_file_names_at_their_limits():
    assert tg.encode_command(tg.StartProgram("a" * 19))[2:] == b"a" * 19 + b"\0"
    with pytest.raises(errors.TelegramError, match=r"^file name 'a\\x00b' is longer than 19 characters$"):
        tg.encode_command(tg.StartProgram("a\0b"))
    with pytest.raises(errors.TelegramError, match=r"^file name 'caf\xe9' is not ASCII$"):
        tg.encode_command(tg.StartProgram("caf\xe9"))
    # the name is read up to its first NUL, as latin-1
    raw = bytes.fromhex("00 00") + b"ab\0cd".ljust(20, b"\0")
    assert tg.decode_command(raw) == tg.StartProgram("ab")
    reply = bytes.fromhex("02 11 00") + b"\xe9t\xe9".ljust(20, b"\0")
    assert tg.parse_reply(reply) == tg.ProgramNameReply(0, "\xe9t\xe9")


def test_message_sizes_at_their_limits():
    assert tg.encode_command(tg.MessageWrite(9, bytes(58)))[:4] == bytes.fromhex("00 09 09 3b")
    assert tg.encode_command(tg.MessageWrite(9, b"")) == bytes.fromhex("00 09 09 01 00")
    with pytest.raises(errors.TelegramError, match="^mailbox message of 59 bytes exceeds 58$"):
        tg.encode_command(tg.MessageWrite(1, bytes(59)))
    assert len(tg.encode_reply(tg.MessageReadReply(0, 0, bytes(59)))) == 64
    with pytest.raises(errors.TelegramError, match="^message of 60 bytes exceeds 59$"):
        tg.encode_reply(tg.MessageReadReply(0, 0, bytes(60)))
    raw = bytearray(tg.encode_reply(tg.MessageReadReply(0, 1, b"ab\0")))
    assert raw[3:6] == bytes.fromhex("01 03 61")
    raw[4] = 59
    assert tg.parse_reply(bytes(raw)).message == b"ab" + bytes(57)
    raw[4] = 60
    with pytest.raises(errors.TelegramError, match="^MESSAGE_READ reply claims 60 bytes$"):
        tg.parse_reply(bytes(raw))


def test_payload_strips_one_trailing_nul_only():
    assert tg.MessageReadReply(0, 0, b"ab\0").payload == b"ab"
    assert tg.MessageReadReply(0, 0, b"ab\0\0").payload == b"ab\0"
    assert tg.MessageReadReply(0, 0, b"ab").payload == b"ab"
    assert tg.MessageReadReply(0, 0, b"").payload == b""


def test_reply_parsing_errors_name_what_is_wrong():
    def refused(hex_: str) -> str:
        with pytest.raises(errors.TelegramError) as info:
            tg.parse_reply(bytes.fromhex(hex_))
        return str(info.value)
    assert refused("02 0b") == "reply without status byte"
    assert refused("00 0b 00") == "telegram type 0x00 is not a reply"
    assert refused("02 42 00 00") == "reply to unknown opcode 0x42 has 4 bytes"
    assert refused("02 0b 00 28") == "GET_BATTERY_LEVEL reply has 4 bytes, expected 5"
    assert refused("02 0b 00 28 23 00") == "GET_BATTERY_LEVEL reply has 6 bytes, expected 5"
    assert refused("02 09 00 00") == "MESSAGE_WRITE reply has 4 bytes, expected 3"
    assert tg.parse_reply(bytes.fromhex("02 42 be")) == tg.StatusReply(0x42, 0xBE)
    assert tg.parse_reply(bytes.fromhex("02 09 ec")) == tg.StatusReply(tg.Opcode.MESSAGE_WRITE, 0xEC)


def test_decode_reply_raises_the_status_for_its_opcode():
    with pytest.raises(errors.TelegramError, match="^reply to opcode 0x0D while waiting for 0x0B$"):
        tg.decode_reply(bytes.fromhex("02 0d 00 c0 27 09 00"), tg.Opcode.GET_BATTERY_LEVEL)
    with pytest.raises(errors.IllegalValueError) as info:
        tg.decode_reply(tg.error_reply(tg.Opcode.GET_OUTPUT_STATE, 0xC0), tg.Opcode.GET_OUTPUT_STATE)
    assert info.value.status == 0xC0
    assert tg.decode_reply(bytes.fromhex("02 0b 00 28 23"), 0x0B) == tg.BatteryLevelReply(0, 9000)


def test_error_replies_byte_for_byte():
    assert tg.error_reply(tg.Opcode.MESSAGE_READ, 0x140, local_inbox=0x105) == (
        bytes.fromhex("02 13 40 05") + bytes(60))
    assert tg.error_reply(tg.Opcode.GET_BATTERY_LEVEL, 0xC0, local_inbox=7) == bytes.fromhex("02 0b c0 00 00")
    assert tg.error_reply(0x142, 0xBE) == bytes.fromhex("02 42 be")
    assert tg.REPLY_LENGTH[tg.Opcode.GET_DEVICE_INFO] == 33
    assert tg.REPLY_LENGTH[tg.Opcode.GET_FIRMWARE_VERSION] == 7
    assert tg.REPLY_LENGTH[tg.Opcode.MESSAGE_WRITE] == 3
    assert tg.encode_reply(tg.StatusReply(tg.Opcode.MESSAGE_WRITE, 0x1EC)) == bytes.fromhex("02 09 ec")


def test_device_info_and_firmware_version_bytes():
    info = tg.DeviceInfoReply(0, "NXT", bytes.fromhex("00 16 53 01 02 03"), (1, 2, 3, 4), 0x1234)
    raw = tg.encode_reply(info)
    assert raw == (bytes.fromhex("02 9b 00") + b"NXT".ljust(15, b"\0") + bytes.fromhex("00 16 53 01 02 03")
                   + bytes.fromhex("00 01 02 03 04 34 12 00 00"))
    assert tg.parse_reply(raw) == info
    long = tg.encode_reply(tg.DeviceInfoReply(0, "x" * 20, bytes(6), (0, 0, 0, 0), 0))
    assert long[3:18] == b"x" * 14 + b"\0"
    with pytest.raises(errors.TelegramError, match="^Bluetooth address must be 6 bytes$"):
        tg.encode_reply(tg.DeviceInfoReply(0, "NXT", bytes(5), (0, 0, 0, 0), 0))
    with pytest.raises(errors.TelegramError, match="^field out of range"):
        tg.encode_reply(tg.BatteryLevelReply(0, 0x10000))
    assert tg.encode_reply(tg.FirmwareVersionReply(0, 124, 1, 28, 1)) == bytes.fromhex("02 88 00 7c 01 1c 01")
    with pytest.raises(errors.TelegramError, match="^not a reply: "):
        tg.encode_reply(tg.GetBatteryLevel())  # type: ignore[arg-type]
    with pytest.raises(errors.TelegramError, match="^not a command: "):
        tg.encode_command(tg.BatteryLevelReply(0, 1))  # type: ignore[arg-type]


u8 = st.integers(0, 255)


@given(u8, st.text(alphabet="ABCxyz0 ", max_size=14), st.binary(min_size=6, max_size=6),
       st.tuples(u8, u8, u8, u8), st.integers(0, 2**32 - 1))
def test_device_info_round_trip(status, name, address, signal, flash):
    reply = tg.DeviceInfoReply(status, name.rstrip(" ") or "", address, signal, flash)
    assert tg.parse_reply(tg.encode_reply(reply)) == reply


@given(u8, st.tuples(u8, u8, u8, u8))
def test_firmware_version_round_trip(status, version):
    reply = tg.FirmwareVersionReply(status, *version)
    assert tg.parse_reply(tg.encode_reply(reply)) == reply


def test_the_wire_values_of_ports_modes_and_states():
    assert [(p.name, p.value) for p in tg.OutputPort] == [("A", 0), ("B", 1), ("C", 2), ("ALL", 0xFF)]
    assert (tg.OutputMode.COAST, tg.OutputMode.MOTORON, tg.OutputMode.BRAKE, tg.OutputMode.REGULATED) == (0, 1, 2, 4)
    assert [r.value for r in tg.RegulationMode] == [0, 1, 2]
    assert [(s.name, s.value) for s in tg.RunState] == [
        ("IDLE", 0x00), ("RAMPUP", 0x10), ("RUNNING", 0x20), ("RAMPDOWN", 0x40)]
    assert [t.value for t in tg.CommandType] == [0x00, 0x01, 0x02, 0x80, 0x81]
    assert {o.name: o.value for o in tg.Opcode} == {
        "START_PROGRAM": 0x00, "STOP_PROGRAM": 0x01, "PLAY_TONE": 0x03, "SET_OUTPUT_STATE": 0x04,
        "SET_INPUT_MODE": 0x05, "GET_OUTPUT_STATE": 0x06, "GET_INPUT_VALUES": 0x07, "MESSAGE_WRITE": 0x09,
        "RESET_MOTOR_POSITION": 0x0A, "GET_BATTERY_LEVEL": 0x0B, "KEEP_ALIVE": 0x0D,
        "GET_CURRENT_PROGRAM_NAME": 0x11, "MESSAGE_READ": 0x13, "GET_FIRMWARE_VERSION": 0x88,
        "GET_DEVICE_INFO": 0x9B}
    assert (tg.MAX_MESSAGE_PAYLOAD, tg.MAX_MESSAGE_SIZE, tg.MAILBOX_COUNT, tg.FILENAME_FIELD) == (58, 59, 20, 20)


@pytest.mark.parametrize("cls", [getattr(tg, n) for n in tg.__all__ if dataclasses.is_dataclass(getattr(tg, n))],
                         ids=lambda c: c.__name__)
def test_messages_are_values(cls):
    """Frozen (hashable, usable as keys and in sets) and without a per-instance dict."""
    assert cls.__dataclass_params__.frozen
    assert "__slots__" in vars(cls)


def test_defaults_are_the_ones_the_client_sends():
    assert tg.encode_command(tg.MessageRead(11)) == bytes.fromhex("00 13 0b 00 01")
    assert tg.encode_command(tg.StartProgram("a")).startswith(bytes.fromhex("00 00 61 00"))
    assert tg.encode_command(tg.PlayTone(440, 100))[0] == 0x80
    assert tg.encode_command(tg.SetInputMode(0, 1, 0x20))[0] == 0x80
    assert tg.encode_command(tg.GetOutputState(0))[0] == 0x00
    assert tg.error_reply(tg.Opcode.MESSAGE_READ, 0x40)[3] == 0
