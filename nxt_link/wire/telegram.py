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

This module is the face of three: :mod:`nxt_link.wire.messages` (what each command and
reply says), :mod:`nxt_link.wire.codec` (their bytes) and :mod:`nxt_link.wire.reply_checks`
(whether a reply can be the answer to its command).  Import the names from here.

>>> encode_command(MessageWrite(inbox=1, message=b"hello")).hex(" ")
'00 09 01 06 68 65 6c 6c 6f 00'
>>> parse_reply(bytes.fromhex("02 0b 00 28 23"))
BatteryLevelReply(status=0, millivolts=9000)
"""
from __future__ import annotations

from nxt_link.wire.codec import (
    REPLY_LENGTH,
    decode_command,
    decode_reply,
    encode_command,
    encode_reply,
    error_reply,
    parse_reply,
    telegram_header,
)
from nxt_link.wire.messages import (
    FILENAME_FIELD,
    MAILBOX_COUNT,
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
    OutputMode,
    OutputPort,
    OutputStateReply,
    PlayTone,
    ProgramNameReply,
    RegulationMode,
    Reply,
    ResetMotorPosition,
    RunState,
    SetInputMode,
    SetOutputState,
    StartProgram,
    StatusReply,
    StopProgram,
)
from nxt_link.wire.reply_checks import check_reply, plausible_statuses

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

