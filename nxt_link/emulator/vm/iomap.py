"""What a running program sees of the brick: the I/O the VM reads and writes.

The firmware's VM reaches the other modules through their IO maps; this module
names the fields the bytecode addresses and defines :class:`BrickIO`, the
interface the interpreter calls. :class:`nxt_link.emulator.firmware.Firmware` implements
it on the emulated brick (mailboxes, output ports with their motors, input
ports a sensor world fills, LCD, sound, buttons, flash files); a test can
implement it with anything.

Field numbers are the bytecode's: ``SETOUT``/``GETOUT`` address output fields
0-17 of ports 0-2, ``SETIN``/``GETIN`` input fields 0-5 of ports 0-3 (the
firmware's ``IO_OUT_*``/``IO_IN_*``, and NBC's ``UpdateFlags``, ``Power``, ...).
"""
from __future__ import annotations

from typing import Protocol

__all__ = ["BrickIO", "OutputField", "InputField", "OUTPUT_FIELD_TYPES", "INPUT_FIELD_TYPES",
           "NO_OF_OUTPUTS", "NO_OF_INPUTS", "UPDATE_MODE", "UPDATE_SPEED", "UPDATE_TACHO_LIMIT",
           "UPDATE_RESET_COUNT", "UPDATE_PID_VALUES", "UPDATE_RESET_BLOCK_COUNT",
           "UPDATE_RESET_ROTATION_COUNT", "PENDING_UPDATES"]

NO_OF_OUTPUTS = 3
NO_OF_INPUTS = 4

# output module update flags (c_output.iom)
UPDATE_MODE = 0x01
UPDATE_SPEED = 0x02
UPDATE_TACHO_LIMIT = 0x04
UPDATE_RESET_COUNT = 0x08
UPDATE_PID_VALUES = 0x10
UPDATE_RESET_BLOCK_COUNT = 0x20
UPDATE_RESET_ROTATION_COUNT = 0x40
PENDING_UPDATES = 0x80


class OutputField:
    """Output port fields, in bytecode order."""

    FLAGS = 0
    MODE = 1
    SPEED = 2  # "Power"
    ACTUAL_SPEED = 3
    TACHO_COUNT = 4
    TACHO_LIMIT = 5
    RUN_STATE = 6
    TURN_RATIO = 7
    REG_MODE = 8
    OVERLOAD = 9
    REG_P = 10
    REG_I = 11
    REG_D = 12
    BLOCK_TACHO_COUNT = 13
    ROTATION_COUNT = 14
    OPTIONS = 15
    MAX_SPEED = 16
    MAX_ACCELERATION = 17
    COUNT = 18


class InputField:
    """Input port fields, in bytecode order."""

    TYPE = 0
    MODE = 1
    RAW = 2  # ADRaw
    NORMALIZED = 3  # SensorRaw
    SCALED = 4  # SensorValue
    INVALID = 5
    COUNT = 6


# storage type codes of the fields (TC_UBYTE=1, SBYTE=2, UWORD=3, SWORD=4, ULONG=5, SLONG=6)
OUTPUT_FIELD_TYPES = (1, 1, 2, 2, 6, 5, 1, 2, 1, 1, 1, 1, 1, 6, 6, 1, 2, 2)
INPUT_FIELD_TYPES = (1, 1, 3, 3, 4, 1)


class BrickIO(Protocol):
    """Everything the interpreter asks of the brick around it."""

    def output_get(self, port: int, field: int) -> int: ...

    def output_set(self, port: int, field: int, value: int) -> None: ...

    def input_get(self, port: int, field: int) -> int: ...

    def input_set(self, port: int, field: int, value: int) -> None: ...

    def message_write(self, queue: int, message: bytes) -> int:
        """``cCmdMessageWrite``: a status byte (signed)."""
        ...

    def message_read(self, queue: int, remove: bool) -> tuple[int, bytes]:
        """``cCmdMessageRead``: status and message (NUL included)."""
        ...

    def play_tone(self, frequency_hz: int, duration_ms: int, loop: bool, volume: int) -> None: ...

    def play_file(self, name: str, loop: bool, volume: int) -> None: ...

    def sound_state(self) -> tuple[int, int]:
        """(state, flags) of the sound module."""
        ...

    def set_sound_state(self, state: int, flags: int) -> None: ...

    def draw_text(self, x: int, y: int, text: bytes, options: int) -> None: ...

    def clear_screen_if_needed(self, options: int) -> None: ...

    def read_button(self, index: int, reset: bool) -> tuple[int, bool, int]:
        """(status, pressed, release count) of button ``index``."""
        ...

    def keep_alive(self) -> int:
        """Reset the sleep timer; return the sleep timeout in ms."""
        ...

    def random(self) -> int:
        """A signed 16-bit random number (the firmware's ``rand()``)."""
        ...

    @property
    def flash(self) -> object:
        """The flash file system (:class:`nxt_link.emulator.vm.flash.Flash`)."""
        ...
