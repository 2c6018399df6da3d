"""The bytes of each command and reply: their layouts, and the encoders and decoders built on them.

Each message's fields after its header are written once, as a :class:`_Layout`, for both
directions: the encoders pack a message's fields with it, the decoders unpack them with the
same layout, and the lengths the decoders check are the layouts' sizes.  Kept apart from the
message types (:mod:`nxt_link.wire.messages`) so that what a telegram says and how it is laid
out in bytes can be read one at a time; :mod:`nxt_link.wire.telegram` is the face of both.
"""
from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import fields
from operator import attrgetter
from typing import Any, NamedTuple

from nxt_link.wire.errors import TelegramError, error_for_status
from nxt_link.wire.messages import (
    FILENAME_FIELD,
    MAX_MESSAGE_PAYLOAD,
    MAX_MESSAGE_SIZE,
    BatteryLevelReply,
    Command,
    CommandType,
    DeviceInfoReply,
    FirmwareVersionReply,
    GetBatteryLevel,
    GetCurrentProgramName,
    GetDeviceInfo,
    GetFirmwareVersion,
    GetInputValues,
    GetOutputState,
    InputValuesReply,
    KeepAlive,
    KeepAliveReply,
    MessageRead,
    MessageReadReply,
    MessageWrite,
    Opcode,
    OutputStateReply,
    PlayTone,
    ProgramNameReply,
    Reply,
    ResetMotorPosition,
    SetInputMode,
    SetOutputState,
    StartProgram,
    StatusReply,
    StopProgram,
)


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
