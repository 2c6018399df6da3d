"""What the NXT direct commands and their replies say: the opcodes and port enums, the limits
of a message, and one frozen dataclass per command and per reply.

Plain data, no bytes: :mod:`nxt_link.wire.codec` lays these out on the wire and
:mod:`nxt_link.wire.reply_checks` judges a reply against its command; the three are one
module's worth of names, given together by the face :mod:`nxt_link.wire.telegram`.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass

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
