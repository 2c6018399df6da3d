"""The emulated firmware's constants and the types its parts and its programs share: the status
bytes, :class:`FirmwareParams`, and the NXC API a Python program model calls
(:class:`ProgramHost`, :class:`Program`).

Apart from :mod:`nxt_link.emulator.firmware` (which gives these names too) so that the
firmware's parts (:mod:`~nxt_link.emulator.firmware_files`,
:mod:`~nxt_link.emulator.firmware_mailboxes`) and the program models can use them without
importing the firmware itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from nxt_link.emulator.vm import DEFAULT_INSTRUCTIONS_PER_MS

# status bytes (protocol doc §1.5)
NO_ERR = 0x00
STAT_MSG_EMPTY_MAILBOX = 0x40
ERR_RC_UNKNOWN_CMD = 0xBE
ERR_RC_ILLEGAL_VAL = 0xC0
ERR_NO_PROG = 0xEC
ERR_INVALID_SIZE = 0xED
ERR_INVALID_QUEUE = 0xEE

MESSAGES_PER_QUEUE = 5
NO_OF_OUTPUTS = 3
NO_OF_INPUTS = 4

# direct opcodes the firmware has but this project does not use
_OP_PLAY_SOUND_FILE = 0x02
_OP_RESET_IN_VAL = 0x08
_OP_STOP_SOUND = 0x0C


@dataclass(frozen=True, slots=True)
class FirmwareParams:
    """Brick-level settings of the emulator.

    Attributes:
        name: brick name (GETDEVICEINFO), at most 14 characters.
        battery_mv: GETBATTERYLEVEL answer (9000: six fresh AA cells).
        sleep_minutes: sleep timer setting; KEEPALIVE answers it in ms
            (firmware default 10 min -> 600000).
        files: programs installed on the brick (STARTPROGRAM of anything else
            fails with C0, as the firmware does for a missing file).
        start_delay_ms: time between an accepted STARTPROGRAM and the program
            running (the UI starts it asynchronously; 0.1-1 s on a real brick).
        bt_address: 6-byte Bluetooth address (LEGO OUI 00:16:53).
        firmware_version: (major, minor) of the firmware, 1.31.
        protocol_version: (major, minor) of the protocol, 1.124.
        vm_instructions_per_ms: bytecode instructions a program runs per
            millisecond slice (the brick's CPU speed; an estimate). ``None``:
            every slice runs until all tasks wait (an infinitely fast brick, as
            the Python models assume).
        vm_fused: the interpreter runs straight-line code as fused blocks
            (False: one instruction at a time; the same results, slower).
        vm_skip_busy_waits: the interpreter counts the cycles of a provable
            busy-wait without running them (False: runs them; the same results,
            slower).
    """

    name: str = "NXT"
    battery_mv: int = 9000
    sleep_minutes: int = 10
    files: tuple[str, ...] = ()
    start_delay_ms: int = 200
    bt_address: bytes = bytes.fromhex("001653010203")
    firmware_version: tuple[int, int] = (1, 31)
    protocol_version: tuple[int, int] = (1, 124)
    vm_instructions_per_ms: int | None = DEFAULT_INSTRUCTIONS_PER_MS
    vm_fused: bool = True
    vm_skip_busy_waits: bool = True


class ProgramHost(Protocol):
    """What a running program may call: the NXC API subset the brick program uses."""

    def current_tick(self) -> int: ...

    def receive_remote_string(self, queue: int, clear: bool) -> tuple[int, bytes]: ...

    def send_response_string(self, queue: int, data: bytes) -> int: ...

    def motor_rotation_count(self, port: int) -> int: ...

    def on_fwd_ex(self, port: int, power: int, reset: int) -> None: ...

    def coast_ex(self, port: int, reset: int) -> None: ...

    def off_ex(self, port: int, reset: int) -> None: ...

    def set_sensor(self, port: int, sensor_type: int, sensor_mode: int) -> None: ...

    def sensor(self, port: int) -> int: ...

    def play_tone(self, frequency_hz: int, duration_ms: int) -> None: ...


class Program(Protocol):
    """A program model; a fresh instance is created at every activation."""

    def step(self, host: ProgramHost) -> None:
        """Called once per millisecond VM slice while the program runs."""
        ...




@dataclass(slots=True)
class _Tone:
    at_ms: int
    frequency_hz: int
    duration_ms: int
