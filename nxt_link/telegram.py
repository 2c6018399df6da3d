"""Pure encode/decode of the NXT direct commands this project uses, and their replies.

A *telegram* is one command or reply without the 2-byte Bluetooth length prefix
(that is :mod:`nxt_link.framing`'s job). Layout: ``type opcode params...`` for
commands, ``02 opcode status payload...`` for replies; every multi-byte field is
little-endian (``docs/nxt-protocol.md`` §1-§3).

Both directions are here because both sides of the link live in this package:
the PC client encodes commands and decodes replies, the brick emulator decodes
commands and encodes replies. Round trips ``decode(encode(x)) == x`` hold for
every command and reply (property-tested), and the encoded bytes equal what
nxt-python 3.5.1 sends for the same call (golden-byte tested).

No I/O, no clocks, no logging: functions of their inputs only.

>>> encode_command(MessageWrite(inbox=1, message=b"hello")).hex(" ")
'00 09 01 06 68 65 6c 6c 6f 00'
>>> parse_reply(bytes.fromhex("02 0b 00 28 23"))
BatteryLevelReply(status=0, millivolts=9000)
"""
from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

from nxt_link.errors import TelegramError, error_for_status

__all__ = [
    "CommandType",
    "Opcode",
    "OutputPort",
    "OutputMode",
    "RegulationMode",
    "RunState",
    "MAX_MESSAGE_PAYLOAD",
    "MAX_MESSAGE_SIZE",
    "MAILBOX_COUNT",
    "FILENAME_FIELD",
    "REPLY_LENGTH",
    "StartProgram",
    "StopProgram",
    "PlayTone",
    "SetOutputState",
    "SetInputMode",
    "GetOutputState",
    "GetInputValues",
    "MessageWrite",
    "MessageRead",
    "ResetMotorPosition",
    "GetBatteryLevel",
    "KeepAlive",
    "GetCurrentProgramName",
    "GetFirmwareVersion",
    "GetDeviceInfo",
    "Command",
    "StatusReply",
    "OutputStateReply",
    "InputValuesReply",
    "BatteryLevelReply",
    "KeepAliveReply",
    "ProgramNameReply",
    "MessageReadReply",
    "FirmwareVersionReply",
    "DeviceInfoReply",
    "Reply",
    "encode_command",
    "decode_command",
    "encode_reply",
    "parse_reply",
    "decode_reply",
    "error_reply",
    "telegram_header",
    "plausible_statuses",
    "check_reply",
]

#: Largest mailbox payload a client may send: 59-byte message including the NUL.
MAX_MESSAGE_PAYLOAD = 58
#: Largest message size field (payload + NUL), firmware MAX_MESSAGE_SIZE.
MAX_MESSAGE_SIZE = 59
#: Number of mailbox queues in the firmware (0-9 inboxes, 10-19 response boxes).
MAILBOX_COUNT = 20
#: Width of a file-name field: 19 characters + NUL.
FILENAME_FIELD = 20


class CommandType(enum.IntEnum):
    """Byte 0 of a telegram. Bit 7 set = "no reply wanted"."""

    DIRECT = 0x00
    SYSTEM = 0x01
    REPLY = 0x02
    DIRECT_NO_REPLY = 0x80
    SYSTEM_NO_REPLY = 0x81


class Opcode(enum.IntEnum):
    """Byte 1 of a telegram: the commands this project speaks."""

    START_PROGRAM = 0x00
    STOP_PROGRAM = 0x01
    PLAY_TONE = 0x03
    SET_OUTPUT_STATE = 0x04
    SET_INPUT_MODE = 0x05
    GET_OUTPUT_STATE = 0x06
    GET_INPUT_VALUES = 0x07
    MESSAGE_WRITE = 0x09
    RESET_MOTOR_POSITION = 0x0A
    GET_BATTERY_LEVEL = 0x0B
    KEEP_ALIVE = 0x0D
    GET_CURRENT_PROGRAM_NAME = 0x11
    MESSAGE_READ = 0x13
    # system commands nxt-python may send on connect (protocol doc §3)
    GET_FIRMWARE_VERSION = 0x88
    GET_DEVICE_INFO = 0x9B

    @property
    def is_system(self) -> bool:
        return bool(self.value & 0x80)


class OutputPort(enum.IntEnum):
    """Motor ports; ``ALL`` (0xFF) is accepted by SETOUTPUTSTATE only."""

    A = 0
    B = 1
    C = 2
    ALL = 0xFF


class OutputMode(enum.IntFlag):
    """SETOUTPUTSTATE mode bits."""

    COAST = 0x00
    MOTORON = 0x01
    BRAKE = 0x02
    REGULATED = 0x04


class RegulationMode(enum.IntEnum):
    IDLE = 0
    SPEED = 1
    SYNC = 2


class RunState(enum.IntEnum):
    IDLE = 0x00
    RAMPUP = 0x10
    RUNNING = 0x20
    RAMPDOWN = 0x40


# ---------------------------------------------------------------------------
# commands


@dataclass(frozen=True, slots=True)
class StartProgram:
    name: str
    reply: bool = True
    opcode = Opcode.START_PROGRAM


@dataclass(frozen=True, slots=True)
class StopProgram:
    reply: bool = True
    opcode = Opcode.STOP_PROGRAM


@dataclass(frozen=True, slots=True)
class PlayTone:
    frequency_hz: int
    duration_ms: int
    reply: bool = False
    opcode = Opcode.PLAY_TONE


@dataclass(frozen=True, slots=True)
class SetOutputState:
    port: int
    power: int
    mode: int
    regulation_mode: int
    turn_ratio: int
    run_state: int
    tacho_limit: int
    reply: bool = False
    opcode = Opcode.SET_OUTPUT_STATE


@dataclass(frozen=True, slots=True)
class SetInputMode:
    port: int
    sensor_type: int
    sensor_mode: int
    reply: bool = False
    opcode = Opcode.SET_INPUT_MODE


@dataclass(frozen=True, slots=True)
class GetOutputState:
    port: int
    reply: bool = True
    opcode = Opcode.GET_OUTPUT_STATE


@dataclass(frozen=True, slots=True)
class GetInputValues:
    port: int
    reply: bool = True
    opcode = Opcode.GET_INPUT_VALUES


@dataclass(frozen=True, slots=True)
class MessageWrite:
    """Write ``message`` (payload, without the NUL the encoder appends) to ``inbox``."""

    inbox: int
    message: bytes
    reply: bool = True
    opcode = Opcode.MESSAGE_WRITE


@dataclass(frozen=True, slots=True)
class MessageRead:
    remote_inbox: int
    local_inbox: int = 0
    remove: bool = True
    reply: bool = True
    opcode = Opcode.MESSAGE_READ


@dataclass(frozen=True, slots=True)
class ResetMotorPosition:
    port: int
    relative: bool
    reply: bool = True
    opcode = Opcode.RESET_MOTOR_POSITION


@dataclass(frozen=True, slots=True)
class GetBatteryLevel:
    reply: bool = True
    opcode = Opcode.GET_BATTERY_LEVEL


@dataclass(frozen=True, slots=True)
class KeepAlive:
    reply: bool = True
    opcode = Opcode.KEEP_ALIVE


@dataclass(frozen=True, slots=True)
class GetCurrentProgramName:
    reply: bool = True
    opcode = Opcode.GET_CURRENT_PROGRAM_NAME


@dataclass(frozen=True, slots=True)
class GetFirmwareVersion:
    reply: bool = True
    opcode = Opcode.GET_FIRMWARE_VERSION


@dataclass(frozen=True, slots=True)
class GetDeviceInfo:
    reply: bool = True
    opcode = Opcode.GET_DEVICE_INFO


Command = (
    StartProgram
    | StopProgram
    | PlayTone
    | SetOutputState
    | SetInputMode
    | GetOutputState
    | GetInputValues
    | MessageWrite
    | MessageRead
    | ResetMotorPosition
    | GetBatteryLevel
    | KeepAlive
    | GetCurrentProgramName
    | GetFirmwareVersion
    | GetDeviceInfo
)


def _name_field(name: str) -> bytes:
    try:
        raw = name.encode("ascii")
    except UnicodeEncodeError:
        raise TelegramError(f"file name {name!r} is not ASCII") from None
    if len(raw) > FILENAME_FIELD - 1 or b"\0" in raw:
        raise TelegramError(f"file name {name!r} is longer than {FILENAME_FIELD - 1} characters")
    return raw.ljust(FILENAME_FIELD, b"\0")


def _type_byte(cmd: Command) -> int:
    base = CommandType.SYSTEM if cmd.opcode.is_system else CommandType.DIRECT
    return base | (0 if cmd.reply else 0x80)


def _pack(fmt: str, *values: int) -> bytes:
    try:
        return struct.pack(fmt, *values)
    except struct.error as exc:
        raise TelegramError(f"field out of range: {exc}") from None


def encode_command(cmd: Command) -> bytes:
    """Encode a command as a telegram (no length prefix).

    Raises:
        TelegramError: a field does not fit its wire width (e.g. a 59-byte message).
    """
    head = bytes((_type_byte(cmd), cmd.opcode))
    if isinstance(cmd, StartProgram):
        return head + _name_field(cmd.name)
    if isinstance(cmd, (StopProgram, GetBatteryLevel, KeepAlive, GetCurrentProgramName,
                        GetFirmwareVersion, GetDeviceInfo)):
        return head
    if isinstance(cmd, PlayTone):
        return head + _pack("<HH", cmd.frequency_hz, cmd.duration_ms)
    if isinstance(cmd, SetOutputState):
        return head + _pack("<BbBBbBI", cmd.port, cmd.power, cmd.mode, cmd.regulation_mode,
                            cmd.turn_ratio, cmd.run_state, cmd.tacho_limit)
    if isinstance(cmd, SetInputMode):
        return head + _pack("<BBB", cmd.port, cmd.sensor_type, cmd.sensor_mode)
    if isinstance(cmd, (GetOutputState, GetInputValues)):
        return head + _pack("<B", cmd.port)
    if isinstance(cmd, MessageWrite):
        if len(cmd.message) > MAX_MESSAGE_PAYLOAD:
            raise TelegramError(
                f"mailbox message of {len(cmd.message)} bytes exceeds {MAX_MESSAGE_PAYLOAD}")
        return head + _pack("<BB", cmd.inbox, len(cmd.message) + 1) + cmd.message + b"\0"
    if isinstance(cmd, MessageRead):
        return head + _pack("<BB?", cmd.remote_inbox, cmd.local_inbox, cmd.remove)
    if isinstance(cmd, ResetMotorPosition):
        return head + _pack("<B?", cmd.port, cmd.relative)
    raise TelegramError(f"not a command: {cmd!r}")


def telegram_header(telegram: bytes) -> tuple[int, int]:
    """Return ``(type byte, opcode byte)`` of a telegram.

    Raises:
        TelegramError: fewer than 2 bytes.
    """
    if len(telegram) < 2:
        raise TelegramError(f"telegram of {len(telegram)} byte(s) has no opcode")
    return telegram[0], telegram[1]


# fixed request lengths (type and opcode included); MESSAGEWRITE is 4 + size
_REQUEST_LENGTH = {
    Opcode.START_PROGRAM: 22,
    Opcode.STOP_PROGRAM: 2,
    Opcode.PLAY_TONE: 6,
    Opcode.SET_OUTPUT_STATE: 12,
    Opcode.SET_INPUT_MODE: 5,
    Opcode.GET_OUTPUT_STATE: 3,
    Opcode.GET_INPUT_VALUES: 3,
    Opcode.MESSAGE_WRITE: 4,
    Opcode.RESET_MOTOR_POSITION: 4,
    Opcode.GET_BATTERY_LEVEL: 2,
    Opcode.KEEP_ALIVE: 2,
    Opcode.GET_CURRENT_PROGRAM_NAME: 2,
    Opcode.MESSAGE_READ: 5,
    Opcode.GET_FIRMWARE_VERSION: 2,
    Opcode.GET_DEVICE_INFO: 2,
}


def decode_command(telegram: bytes) -> Command:
    """Decode a command telegram (the brick's side).

    MESSAGEWRITE is decoded structurally only: the returned ``message`` is the
    data field without its last byte, whatever that byte is; the size/NUL checks
    the firmware performs are left to the receiver (they produce status ``C0``,
    not a decoding failure). Bytes beyond the command's length are ignored, as
    the firmware does.

    Raises:
        TelegramError: not a command type, unknown opcode, or too short.
    """
    ttype, op = telegram_header(telegram)
    if ttype not in (CommandType.DIRECT, CommandType.DIRECT_NO_REPLY,
                     CommandType.SYSTEM, CommandType.SYSTEM_NO_REPLY):
        raise TelegramError(f"telegram type 0x{ttype:02X} is not a command")
    try:
        opcode = Opcode(op)
    except ValueError:
        raise TelegramError(f"unknown opcode 0x{op:02X}") from None
    if opcode.is_system != bool(ttype & 0x01):
        raise TelegramError(f"opcode 0x{op:02X} sent with telegram type 0x{ttype:02X}")
    need = _REQUEST_LENGTH[opcode]
    if len(telegram) < need:
        raise TelegramError(
            f"{opcode.name} telegram truncated: {len(telegram)} of {need} bytes")
    reply = not (ttype & 0x80)
    p = telegram[2:]
    if opcode is Opcode.START_PROGRAM:
        name = p[:FILENAME_FIELD].split(b"\0", 1)[0].decode("latin-1")
        return StartProgram(name, reply)
    if opcode is Opcode.STOP_PROGRAM:
        return StopProgram(reply)
    if opcode is Opcode.PLAY_TONE:
        f, d = struct.unpack_from("<HH", p)
        return PlayTone(f, d, reply)
    if opcode is Opcode.SET_OUTPUT_STATE:
        port, power, mode, reg, turn, run, limit = struct.unpack_from("<BbBBbBI", p)
        return SetOutputState(port, power, mode, reg, turn, run, limit, reply)
    if opcode is Opcode.SET_INPUT_MODE:
        port, stype, smode = struct.unpack_from("<BBB", p)
        return SetInputMode(port, stype, smode, reply)
    if opcode is Opcode.GET_OUTPUT_STATE:
        return GetOutputState(p[0], reply)
    if opcode is Opcode.GET_INPUT_VALUES:
        return GetInputValues(p[0], reply)
    if opcode is Opcode.MESSAGE_WRITE:
        inbox, size = p[0], p[1]
        data = p[2:2 + size]
        if len(data) < size:
            raise TelegramError(
                f"MESSAGE_WRITE truncated: size field {size}, {len(data)} data bytes")
        return MessageWrite(inbox, bytes(data[:-1]) if size else b"", reply)
    if opcode is Opcode.MESSAGE_READ:
        return MessageRead(p[0], p[1], bool(p[2]), reply)
    if opcode is Opcode.RESET_MOTOR_POSITION:
        return ResetMotorPosition(p[0], bool(p[1]), reply)
    if opcode is Opcode.GET_BATTERY_LEVEL:
        return GetBatteryLevel(reply)
    if opcode is Opcode.KEEP_ALIVE:
        return KeepAlive(reply)
    if opcode is Opcode.GET_CURRENT_PROGRAM_NAME:
        return GetCurrentProgramName(reply)
    if opcode is Opcode.GET_FIRMWARE_VERSION:
        return GetFirmwareVersion(reply)
    return GetDeviceInfo(reply)


def message_write_fields(telegram: bytes) -> tuple[int, int, bytes]:
    """Raw ``(inbox, size, data[size])`` of a MESSAGEWRITE telegram, for the firmware checks."""
    if len(telegram) < 4:
        raise TelegramError("MESSAGE_WRITE truncated")
    inbox, size = telegram[2], telegram[3]
    data = bytes(telegram[4:4 + size])
    if len(data) < size:
        raise TelegramError(
            f"MESSAGE_WRITE truncated: size field {size}, {len(data)} data bytes")
    return inbox, size, data


# ---------------------------------------------------------------------------
# replies

#: Total reply length (type, opcode and status included) per opcode, also on error.
REPLY_LENGTH: dict[Opcode, int] = {
    Opcode.START_PROGRAM: 3,
    Opcode.STOP_PROGRAM: 3,
    Opcode.PLAY_TONE: 3,
    Opcode.SET_OUTPUT_STATE: 3,
    Opcode.SET_INPUT_MODE: 3,
    Opcode.GET_OUTPUT_STATE: 25,
    Opcode.GET_INPUT_VALUES: 16,
    Opcode.MESSAGE_WRITE: 3,
    Opcode.RESET_MOTOR_POSITION: 3,
    Opcode.GET_BATTERY_LEVEL: 5,
    Opcode.KEEP_ALIVE: 7,
    Opcode.GET_CURRENT_PROGRAM_NAME: 23,
    Opcode.MESSAGE_READ: 64,
    Opcode.GET_FIRMWARE_VERSION: 7,
    Opcode.GET_DEVICE_INFO: 33,
}


@dataclass(frozen=True, slots=True)
class StatusReply:
    """A reply with no payload (the 3-byte ones), or any reply to an unknown opcode."""

    opcode: int
    status: int = 0


@dataclass(frozen=True, slots=True)
class OutputStateReply:
    status: int
    port: int
    power: int
    mode: int
    regulation_mode: int
    turn_ratio: int
    run_state: int
    tacho_limit: int
    tacho_count: int
    block_tacho_count: int
    rotation_count: int
    opcode = Opcode.GET_OUTPUT_STATE


@dataclass(frozen=True, slots=True)
class InputValuesReply:
    status: int
    port: int
    valid: bool
    calibrated: bool
    sensor_type: int
    sensor_mode: int
    raw_value: int
    normalized_value: int
    scaled_value: int
    calibrated_value: int
    opcode = Opcode.GET_INPUT_VALUES


@dataclass(frozen=True, slots=True)
class BatteryLevelReply:
    status: int
    millivolts: int
    opcode = Opcode.GET_BATTERY_LEVEL


@dataclass(frozen=True, slots=True)
class KeepAliveReply:
    status: int
    sleep_limit_ms: int
    opcode = Opcode.KEEP_ALIVE


@dataclass(frozen=True, slots=True)
class ProgramNameReply:
    status: int
    name: str
    opcode = Opcode.GET_CURRENT_PROGRAM_NAME


@dataclass(frozen=True, slots=True)
class MessageReadReply:
    """``message`` holds the ``size`` bytes of the mailbox message, trailing NUL included."""

    status: int
    local_inbox: int
    message: bytes
    opcode = Opcode.MESSAGE_READ

    @property
    def payload(self) -> bytes:
        """The message without its trailing NUL (what the sender wrote)."""
        return self.message[:-1] if self.message.endswith(b"\0") else self.message


@dataclass(frozen=True, slots=True)
class FirmwareVersionReply:
    status: int
    protocol_minor: int
    protocol_major: int
    firmware_minor: int
    firmware_major: int
    opcode = Opcode.GET_FIRMWARE_VERSION


@dataclass(frozen=True, slots=True)
class DeviceInfoReply:
    status: int
    name: str
    bt_address: bytes
    signal_strengths: tuple[int, int, int, int]
    free_flash: int
    opcode = Opcode.GET_DEVICE_INFO


Reply = (
    StatusReply
    | OutputStateReply
    | InputValuesReply
    | BatteryLevelReply
    | KeepAliveReply
    | ProgramNameReply
    | MessageReadReply
    | FirmwareVersionReply
    | DeviceInfoReply
)


def encode_reply(reply: Reply) -> bytes:
    """Encode a reply telegram (the brick's side), fixed length per opcode.

    Raises:
        TelegramError: a field does not fit.
    """
    op = int(reply.opcode)
    head = bytes((CommandType.REPLY, op, reply.status & 0xFF))
    if isinstance(reply, StatusReply):
        return head
    if isinstance(reply, OutputStateReply):
        return head + _pack("<BbBBbBIiii", reply.port, reply.power, reply.mode,
                            reply.regulation_mode, reply.turn_ratio, reply.run_state,
                            reply.tacho_limit, reply.tacho_count, reply.block_tacho_count,
                            reply.rotation_count)
    if isinstance(reply, InputValuesReply):
        return head + _pack("<B??BBHHhh", reply.port, reply.valid, reply.calibrated,
                            reply.sensor_type, reply.sensor_mode, reply.raw_value,
                            reply.normalized_value, reply.scaled_value, reply.calibrated_value)
    if isinstance(reply, BatteryLevelReply):
        return head + _pack("<H", reply.millivolts)
    if isinstance(reply, KeepAliveReply):
        return head + _pack("<I", reply.sleep_limit_ms)
    if isinstance(reply, ProgramNameReply):
        return head + _name_field(reply.name)
    if isinstance(reply, MessageReadReply):
        if len(reply.message) > MAX_MESSAGE_SIZE:
            raise TelegramError(f"message of {len(reply.message)} bytes exceeds 59")
        return (head + _pack("<BB", reply.local_inbox, len(reply.message))
                + reply.message.ljust(MAX_MESSAGE_SIZE, b"\0"))
    if isinstance(reply, FirmwareVersionReply):
        return head + _pack("<BBBB", reply.protocol_minor, reply.protocol_major,
                            reply.firmware_minor, reply.firmware_major)
    if isinstance(reply, DeviceInfoReply):
        name = reply.name.encode("ascii", "replace")[:14].ljust(15, b"\0")
        if len(reply.bt_address) != 6:
            raise TelegramError("Bluetooth address must be 6 bytes")
        return (head + name + reply.bt_address + b"\0"
                + _pack("<BBBBI", *reply.signal_strengths, reply.free_flash))
    raise TelegramError(f"not a reply: {reply!r}")


def error_reply(opcode: int, status: int, local_inbox: int = 0) -> bytes:
    """The reply the firmware sends when ``opcode`` fails with ``status``.

    Same length as a successful reply, payload zero-filled; MESSAGEREAD still
    echoes the local inbox byte (firmware ``cCmdHandleRemoteCommands``). An
    opcode the firmware does not know gets the bare 3-byte reply.
    """
    try:
        length = REPLY_LENGTH[Opcode(opcode)]
    except ValueError:
        length = 3
    body = bytearray(length)
    body[0:3] = bytes((CommandType.REPLY, opcode & 0xFF, status & 0xFF))
    if opcode == Opcode.MESSAGE_READ:
        body[3] = local_inbox & 0xFF
    return bytes(body)


def parse_reply(telegram: bytes) -> Reply:
    """Decode any reply telegram without judging its status.

    Raises:
        TelegramError: not a reply, or not the fixed length of its opcode
            (truncated or padded: a damaged frame).
    """
    ttype, op = telegram_header(telegram)
    if ttype != CommandType.REPLY:
        raise TelegramError(f"telegram type 0x{ttype:02X} is not a reply")
    if len(telegram) < 3:
        raise TelegramError("reply without status byte")
    status = telegram[2]
    try:
        opcode = Opcode(op)
    except ValueError:
        if len(telegram) != 3:
            raise TelegramError(f"reply to unknown opcode 0x{op:02X} has {len(telegram)} bytes") from None
        return StatusReply(op, status)
    want = REPLY_LENGTH[opcode]
    if len(telegram) != want:
        raise TelegramError(
            f"{opcode.name} reply has {len(telegram)} bytes, expected {want}")
    p = telegram[3:]
    if want == 3:
        return StatusReply(op, status)
    if opcode is Opcode.GET_OUTPUT_STATE:
        return OutputStateReply(status, *struct.unpack("<BbBBbBIiii", p))
    if opcode is Opcode.GET_INPUT_VALUES:
        return InputValuesReply(status, *struct.unpack("<B??BBHHhh", p))
    if opcode is Opcode.GET_BATTERY_LEVEL:
        return BatteryLevelReply(status, struct.unpack("<H", p)[0])
    if opcode is Opcode.KEEP_ALIVE:
        return KeepAliveReply(status, struct.unpack("<I", p)[0])
    if opcode is Opcode.GET_CURRENT_PROGRAM_NAME:
        return ProgramNameReply(status, p.split(b"\0", 1)[0].decode("latin-1"))
    if opcode is Opcode.MESSAGE_READ:
        local_inbox, size = p[0], p[1]
        if size > MAX_MESSAGE_SIZE:
            raise TelegramError(f"MESSAGE_READ reply claims {size} bytes")
        return MessageReadReply(status, local_inbox, bytes(p[2:2 + size]))
    if opcode is Opcode.GET_FIRMWARE_VERSION:
        return FirmwareVersionReply(status, *struct.unpack("<BBBB", p))
    name = p[:15].split(b"\0", 1)[0].decode("latin-1")
    address = bytes(p[15:21])
    s0, s1, s2, s3, flash = struct.unpack("<BBBBI", p[22:30])
    return DeviceInfoReply(status, name, address, (s0, s1, s2, s3), flash)


def decode_reply(telegram: bytes, opcode: int) -> Reply:
    """Decode the reply to ``opcode`` and raise its status as an exception.

    Raises:
        TelegramError: not a well-formed reply to ``opcode``.
        ProtocolError: (a subclass per status) the status byte is not zero.
    """
    reply = parse_reply(telegram)
    if reply.opcode != opcode:
        raise TelegramError(
            f"reply to opcode 0x{int(reply.opcode):02X} while waiting for 0x{opcode:02X}")
    if reply.status:
        raise error_for_status(reply.status, opcode)
    return reply


# ---------------------------------------------------------------------------
# is this reply the firmware's answer to that command?

_OK = 0x00
_EMPTY_MAILBOX = 0x40
_FILE_FAILED = 0xBD
_ILLEGAL_VALUE = 0xC0
_NO_PROGRAM = 0xEC
_INVALID_QUEUE = 0xEE
_OUTPUTS, _INPUTS = 3, 4


def plausible_statuses(cmd: Command) -> frozenset[int]:
    """The status bytes the firmware can answer to ``cmd`` exactly as it was sent.

    From the firmware's checks (protocol doc §1.5, §2): a port out of range gets ``C0``, a
    queue out of range ``EE``, a mailbox command without a running program ``EC``, a read
    of an empty queue ``40``, STARTPROGRAM of a missing file ``C0`` (``BD`` on some
    firmware versions). Any other status to that command can only come from damage on the
    way (the replies carry no checksum), so the client treats it like a lost reply.

    >>> sorted(plausible_statuses(MessageRead(11)))
    [0, 64, 236]
    >>> sorted(plausible_statuses(GetOutputState(7)))
    [192]
    """
    if isinstance(cmd, StartProgram):
        return frozenset((_OK, _ILLEGAL_VALUE, _FILE_FAILED))
    if isinstance(cmd, (StopProgram, GetCurrentProgramName)):
        return frozenset((_OK, _NO_PROGRAM))
    if isinstance(cmd, (GetOutputState, ResetMotorPosition)):
        return frozenset((_OK,) if cmd.port < _OUTPUTS else (_ILLEGAL_VALUE,))
    if isinstance(cmd, SetOutputState):
        return frozenset((_OK,) if cmd.port < _OUTPUTS or cmd.port == OutputPort.ALL
                         else (_ILLEGAL_VALUE,))
    if isinstance(cmd, (GetInputValues, SetInputMode)):
        return frozenset((_OK,) if cmd.port < _INPUTS else (_ILLEGAL_VALUE,))
    if isinstance(cmd, MessageWrite):
        if len(cmd.message) > MAX_MESSAGE_PAYLOAD:
            return frozenset((_ILLEGAL_VALUE,))
        if cmd.inbox >= MAILBOX_COUNT:
            return frozenset((_INVALID_QUEUE,))
        return frozenset((_OK, _NO_PROGRAM))
    if isinstance(cmd, MessageRead):
        if cmd.remote_inbox >= MAILBOX_COUNT:
            return frozenset((_NO_PROGRAM, _INVALID_QUEUE))  # the program is checked first
        return frozenset((_OK, _EMPTY_MAILBOX, _NO_PROGRAM))
    return frozenset((_OK,))


def check_reply(cmd: Command, reply: Reply) -> None:
    """Refuse a well-formed reply of ``cmd``'s opcode that cannot be the answer to ``cmd``.

    A reply is untrusted when its status is not one the firmware can give to this very
    command (:func:`plausible_statuses`), when an error reply carries a payload (the
    firmware zero-fills it), or when a field the firmware echoes differs from the request
    (the port of GETOUTPUTSTATE/GETINPUTVALUES, MESSAGEREAD's local inbox), or when a
    field holds a value the firmware never sends (a mailbox message without its NUL, a
    program name that is not printable ASCII, an output mode outside the firmware's).

    Raises:
        TelegramError: the reply was damaged on the way (or answers another request).

    >>> check_reply(GetBatteryLevel(), parse_reply(bytes.fromhex("02 0b 72 00 00")))
    Traceback (most recent call last):
    ...
    nxt_link.errors.TelegramError: GET_BATTERY_LEVEL reply with status 0x72, which this command cannot get
    """
    name = cmd.opcode.name
    if reply.status not in plausible_statuses(cmd):
        raise TelegramError(f"{name} reply with status 0x{reply.status:02X}, which this "
                            "command cannot get")
    if reply.status:
        body = encode_reply(reply)[3:]
        if isinstance(reply, MessageReadReply):
            body = body[1:]  # the local inbox is echoed on error too
        if any(body):
            raise TelegramError(f"{name} error reply 0x{reply.status:02X} with a payload")
        if isinstance(reply, MessageReadReply) and isinstance(cmd, MessageRead) \
                and reply.local_inbox != cmd.local_inbox:
            raise TelegramError(f"{name} reply for local inbox {reply.local_inbox}, asked "
                                f"{cmd.local_inbox}")
        return
    if isinstance(reply, (OutputStateReply, InputValuesReply)) \
            and isinstance(cmd, (GetOutputState, GetInputValues)) and reply.port != cmd.port:
        raise TelegramError(f"{name} reply for port {reply.port}, asked {cmd.port}")
    if isinstance(reply, OutputStateReply) and (
            reply.mode > 0x07 or reply.regulation_mode > RegulationMode.SYNC
            or reply.run_state not in (0x00, 0x10, 0x20, 0x40)):
        raise TelegramError(f"{name} reply with a mode the firmware does not report")
    if isinstance(reply, MessageReadReply) and isinstance(cmd, MessageRead):
        if reply.local_inbox != cmd.local_inbox:
            raise TelegramError(f"{name} reply for local inbox {reply.local_inbox}, asked "
                                f"{cmd.local_inbox}")
        if not reply.message or reply.message[-1] != 0:
            raise TelegramError(f"{name} reply with a message that does not end in NUL")
    if isinstance(reply, ProgramNameReply) and (
            not reply.name or not all(0x20 <= ord(c) < 0x7F for c in reply.name)):
        raise TelegramError(f"{name} reply with the unprintable name {reply.name!r}")
