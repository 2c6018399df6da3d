"""Pure encode/decode of the NXT direct commands this project uses, and their replies.

A *telegram* is one command or reply without the 2-byte Bluetooth length prefix
(that is :mod:`nxt_link.wire.framing`'s job). Layout: ``type opcode params...`` for
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
from collections.abc import Callable
from dataclasses import dataclass, fields
from operator import attrgetter
from typing import Any, NamedTuple

from nxt_link.wire.errors import TelegramError, error_for_status

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


# Each command's and reply's fields after its header, written once for both directions:
# the encoders pack a message's fields with its layout, the decoders unpack them with the
# same layout, and the telegram lengths the decoders check are the layouts' sizes.


class _Layout(NamedTuple):
    """What follows a telegram's header (``type opcode``, or ``02 opcode status``).

    ``size`` bytes (the least, where the length varies), ``pack(message)`` their bytes, and
    ``unpack(telegram, offset)`` the fields again, in the order the message class declares
    them after the header's field (a command's ``reply`` flag, a reply's ``status``).
    """

    size: int
    pack: Callable[[Any], bytes]
    unpack: Callable[[Any, int], tuple[Any, ...]]


#: The layout of a message with no fields after its header.
_EMPTY = _Layout(0, lambda _message: b"", lambda _telegram, _offset: ())


def _fixed(cls: type, fmt: str) -> _Layout:
    """The layout of a message whose fields after the header are ``fmt``'s, in class order."""
    body = struct.Struct(fmt)
    names = [f.name for f in fields(cls) if f.name not in ("reply", "status")]
    get = attrgetter(*names)
    if len(names) == 1:  # attrgetter gives the one field alone, not in a tuple
        return _Layout(body.size, lambda message: body.pack(get(message)), body.unpack_from)
    return _Layout(body.size, lambda message: body.pack(*get(message)), body.unpack_from)


def _name_field(name: str) -> bytes:
    try:
        raw = name.encode("ascii")
    except UnicodeEncodeError:
        raise TelegramError(f"file name {name!r} is not ASCII") from None
    if len(raw) > FILENAME_FIELD - 1 or b"\0" in raw:
        raise TelegramError(f"file name {name!r} is longer than {FILENAME_FIELD - 1} characters")
    return raw.ljust(FILENAME_FIELD, b"\0")


def _text(field: bytes) -> str:
    """A NUL-padded text field as the firmware reads it: up to the first NUL."""
    return field.split(b"\0", 1)[0].decode("latin-1")


#: STARTPROGRAM's file name, and GETCURRENTPROGRAMNAME's in the reply.
_NAME = _Layout(FILENAME_FIELD, lambda message: _name_field(message.name),
                lambda telegram, at: (_text(telegram[at:at + FILENAME_FIELD]),))


def _pack_message_write(cmd: MessageWrite) -> bytes:
    if len(cmd.message) > MAX_MESSAGE_PAYLOAD:
        raise TelegramError(f"mailbox message of {len(cmd.message)} bytes exceeds {MAX_MESSAGE_PAYLOAD}")
    return struct.pack("<BB", cmd.inbox, len(cmd.message) + 1) + cmd.message + b"\0"


def _unpack_message_write(telegram: bytes, at: int) -> tuple[int, bytes]:
    """Structurally only: the data field without its last byte, whatever that byte is."""
    inbox, size = telegram[at], telegram[at + 1]
    data = telegram[at + 2:at + 2 + size]
    if len(data) < size:
        raise TelegramError(f"MESSAGE_WRITE truncated: size field {size}, {len(data)} data bytes")
    return inbox, bytes(data[:-1]) if size else b""


_COMMAND_LAYOUTS: dict[type[Command], _Layout] = {
    StartProgram: _NAME,
    StopProgram: _EMPTY,
    PlayTone: _fixed(PlayTone, "<HH"),
    SetOutputState: _fixed(SetOutputState, "<BbBBbBI"),
    SetInputMode: _fixed(SetInputMode, "<BBB"),
    GetOutputState: _fixed(GetOutputState, "<B"),
    GetInputValues: _fixed(GetInputValues, "<B"),
    MessageWrite: _Layout(2, _pack_message_write, _unpack_message_write),  # + size bytes
    MessageRead: _fixed(MessageRead, "<BB?"),
    ResetMotorPosition: _fixed(ResetMotorPosition, "<B?"),
    GetBatteryLevel: _EMPTY,
    KeepAlive: _EMPTY,
    GetCurrentProgramName: _EMPTY,
    GetFirmwareVersion: _EMPTY,
    GetDeviceInfo: _EMPTY,
}
_COMMAND_OF_OPCODE: dict[int, tuple[Opcode, Callable[..., Command], _Layout]] = {
    cls.opcode: (cls.opcode, cls, layout) for cls, layout in _COMMAND_LAYOUTS.items()}
_COMMAND_TYPES = frozenset((CommandType.DIRECT, CommandType.DIRECT_NO_REPLY,
                            CommandType.SYSTEM, CommandType.SYSTEM_NO_REPLY))


def _type_byte(cmd: Command) -> int:
    base = CommandType.SYSTEM if cmd.opcode.is_system else CommandType.DIRECT
    return base | (0 if cmd.reply else 0x80)


def encode_command(cmd: Command) -> bytes:
    """Encode a command as a telegram (no length prefix).

    Raises:
        TelegramError: a field does not fit its wire width (e.g. a 59-byte message).
    """
    layout = _COMMAND_LAYOUTS.get(type(cmd))
    if layout is None:
        raise TelegramError(f"not a command: {cmd!r}")
    try:
        return bytes((_type_byte(cmd), cmd.opcode)) + layout.pack(cmd)
    except struct.error as exc:
        raise TelegramError(f"field out of range: {exc}") from None


def telegram_header(telegram: bytes) -> tuple[int, int]:
    """Return ``(type byte, opcode byte)`` of a telegram.

    Raises:
        TelegramError: fewer than 2 bytes.
    """
    if len(telegram) < 2:
        raise TelegramError(f"telegram of {len(telegram)} byte(s) has no opcode")
    return telegram[0], telegram[1]


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
    if ttype not in _COMMAND_TYPES:
        raise TelegramError(f"telegram type 0x{ttype:02X} is not a command")
    known = _COMMAND_OF_OPCODE.get(op)
    if known is None:
        raise TelegramError(f"unknown opcode 0x{op:02X}")
    opcode, make, layout = known
    if opcode.is_system != bool(ttype & 0x01):
        raise TelegramError(f"opcode 0x{op:02X} sent with telegram type 0x{ttype:02X}")
    need = 2 + layout.size
    if len(telegram) < need:
        raise TelegramError(
            f"{opcode.name} telegram truncated: {len(telegram)} of {need} bytes")
    return make(*layout.unpack(telegram, 2), not ttype & 0x80)


# ---------------------------------------------------------------------------
# replies

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


#: name, Bluetooth address, a NUL, signal strengths, free flash.
_DEVICE_INFO = struct.Struct("<15s6sxBBBBI")
#: local inbox, size (the message's, NUL included), the message NUL-padded to its field.
_MESSAGE_READ = struct.Struct(f"<BB{MAX_MESSAGE_SIZE}s")


def _pack_device_info(reply: DeviceInfoReply) -> bytes:
    if len(reply.bt_address) != 6:
        raise TelegramError("Bluetooth address must be 6 bytes")
    name = reply.name.encode("ascii", "replace")[:14]  # "15s" pads it, so one NUL at least
    return _DEVICE_INFO.pack(name, reply.bt_address, *reply.signal_strengths, reply.free_flash)


def _unpack_device_info(telegram: bytes, at: int) -> tuple[str, bytes, tuple[int, ...], int]:
    name, address, *signal, flash = _DEVICE_INFO.unpack_from(telegram, at)
    return _text(name), address, tuple(signal), flash


def _pack_message_read(reply: MessageReadReply) -> bytes:
    if len(reply.message) > MAX_MESSAGE_SIZE:
        raise TelegramError(f"message of {len(reply.message)} bytes exceeds 59")
    return _MESSAGE_READ.pack(reply.local_inbox, len(reply.message), reply.message)


def _unpack_message_read(telegram: bytes, at: int) -> tuple[int, bytes]:
    local_inbox, size, data = _MESSAGE_READ.unpack_from(telegram, at)
    if size > MAX_MESSAGE_SIZE:
        raise TelegramError(f"MESSAGE_READ reply claims {size} bytes")
    return local_inbox, data[:size]


#: Each reply class's payload; an opcode without a reply class of its own gets a :class:`StatusReply`.
_REPLY_LAYOUTS: dict[type[Reply], _Layout] = {
    StatusReply: _EMPTY,
    OutputStateReply: _fixed(OutputStateReply, "<BbBBbBIiii"),
    InputValuesReply: _fixed(InputValuesReply, "<B??BBHHhh"),
    BatteryLevelReply: _fixed(BatteryLevelReply, "<H"),
    KeepAliveReply: _fixed(KeepAliveReply, "<I"),
    ProgramNameReply: _NAME,
    MessageReadReply: _Layout(_MESSAGE_READ.size, _pack_message_read, _unpack_message_read),
    FirmwareVersionReply: _fixed(FirmwareVersionReply, "<BBBB"),
    DeviceInfoReply: _Layout(_DEVICE_INFO.size, _pack_device_info, _unpack_device_info),
}
_REPLY_OF_OPCODE: dict[int, tuple[type[Reply], _Layout]] = {op: (StatusReply, _EMPTY) for op in Opcode} | {
    cls.opcode: (cls, layout) for cls, layout in _REPLY_LAYOUTS.items() if not issubclass(cls, StatusReply)}

#: Total reply length (type, opcode and status included) per opcode, also on error.
REPLY_LENGTH: dict[Opcode, int] = {Opcode(op): 3 + layout.size for op, (_, layout) in _REPLY_OF_OPCODE.items()}


def encode_reply(reply: Reply) -> bytes:
    """Encode a reply telegram (the brick's side), fixed length per opcode.

    Raises:
        TelegramError: a field does not fit.
    """
    layout = _REPLY_LAYOUTS.get(type(reply))
    if layout is None:
        raise TelegramError(f"not a reply: {reply!r}")
    head = bytes((CommandType.REPLY, int(reply.opcode), reply.status & 0xFF))
    try:
        return head + layout.pack(reply)
    except struct.error as exc:
        raise TelegramError(f"field out of range: {exc}") from None


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
    known = _REPLY_OF_OPCODE.get(op)
    if known is None:
        if len(telegram) != 3:
            raise TelegramError(f"reply to unknown opcode 0x{op:02X} has {len(telegram)} bytes")
        return StatusReply(op, status)
    cls, layout = known
    if len(telegram) != 3 + layout.size:
        raise TelegramError(
            f"{Opcode(op).name} reply has {len(telegram)} bytes, expected {3 + layout.size}")
    if not layout.size:
        return StatusReply(op, status)
    return cls(status, *layout.unpack(telegram, 3))


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
    nxt_link.wire.errors.TelegramError: GET_BATTERY_LEVEL reply with status 0x72, which this command cannot get
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
