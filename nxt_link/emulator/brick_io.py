"""The emulated brick's modules as a running program reaches them (the VM's IO maps).

:class:`FirmwareIO` implements :class:`nxt_link.emulator.vm.iomap.BrickIO` on a
:class:`~nxt_link.emulator.firmware.Firmware`: output ports (power, mode, regulation,
run state, tacho limit, PID values, counters, update flags), input ports
(:class:`~nxt_link.emulator.input_module.InputPort`), the 20 mailboxes, sound, the LCD,
buttons, the sleep timer and the flash file system. The Python program models
use the same output path (:meth:`FirmwareIO.set_output`), so a model and the
compiled program drive the motors through identical code.

Output writes work as on the brick: ``SETOUT`` writes fields of the output
IO map and an ``UpdateFlags`` field; the output module applies the flagged
changes once per millisecond, after the program's time slice
(:meth:`FirmwareIO.apply_output_updates`): the ``RESET_*`` flags zero the
counters, ``UPDATE_MODE``/``UPDATE_TACHO_LIMIT`` apply the whole state (the
tacho limit is added to the previous target), ``UPDATE_SPEED`` alone changes
only the power. A field written without a flag reads back as written but does
not reach the motor.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

from nxt_link.emulator.input_module import InputPort
from nxt_link.emulator.output_module import OutputPort
from nxt_link.emulator.vm.iomap import (
    UPDATE_MODE,
    UPDATE_PID_VALUES,
    UPDATE_RESET_BLOCK_COUNT,
    UPDATE_RESET_COUNT,
    UPDATE_RESET_ROTATION_COUNT,
    UPDATE_SPEED,
    UPDATE_TACHO_LIMIT,
    InputField,
    OutputField,
)

if TYPE_CHECKING:
    from nxt_link.emulator.vm.flash import Flash

__all__ = ["FirmwareIO", "Display", "DEFAULT_PID"]

#: the output module's default regulation gains (P, I, D)
DEFAULT_PID = (96, 32, 32)
LCD_LINES = 8
LCD_WIDTH = 100
FONT_WIDTH = 6
_RESETS = UPDATE_RESET_COUNT | UPDATE_RESET_BLOCK_COUNT | UPDATE_RESET_ROTATION_COUNT
_APPLY = UPDATE_MODE | UPDATE_TACHO_LIMIT
_READ_ONLY = frozenset((OutputField.TACHO_COUNT, OutputField.BLOCK_TACHO_COUNT,
                        OutputField.ROTATION_COUNT, OutputField.ACTUAL_SPEED,
                        OutputField.OVERLOAD))
ERR_INVALID_PORT = -16
ERR_COMM_CHAN_NOT_READY = -32


class Display:
    """The LCD as 8 text lines of 100 pixel columns (``cCmdDrawString``).

    A character drawn at pixel column x covers columns x..x+5; :meth:`lines`
    renders each line with one character per 6 columns. The first drawing
    command of a program clears the screen, as on the brick."""

    def __init__(self) -> None:
        self.cells: list[dict[int, str]] = [{} for _ in range(LCD_LINES)]
        self.dirty = False

    def clear(self) -> None:
        for line in self.cells:
            line.clear()

    def text(self, x: int, y: int, text: bytes) -> None:
        line = ((63 - y) & 0xF8) // 8 if 0 <= y <= 63 else LCD_LINES
        if line >= LCD_LINES:
            return
        cells = self.cells[line]
        for ch in text:
            if x + FONT_WIDTH >= LCD_WIDTH:
                break
            for col in range(x - FONT_WIDTH + 1, x + FONT_WIDTH):  # the cells it overlaps
                cells.pop(col, None)
            cells[x] = chr(ch) if 32 <= ch < 127 else "?"
            x += FONT_WIDTH

    def lines(self) -> list[str]:
        out = []
        for cells in self.cells:
            row = [" "] * (LCD_WIDTH // FONT_WIDTH)
            for x, ch in cells.items():
                if 0 <= x // FONT_WIDTH < len(row):
                    row[x // FONT_WIDTH] = ch
            out.append("".join(row).rstrip())
        return out


@dataclass
class _OutputMap:
    """Output IO-map fields a program wrote and the module has not applied yet."""

    written: dict[int, int] = field(default_factory=dict)
    flags: int = 0
    pid: tuple[int, int, int] = DEFAULT_PID
    options: int = 0
    max_speed: int = 0
    max_acceleration: int = 0


class _SleepTimer(Protocol):
    @property
    def sleep_minutes(self) -> int: ...


class FirmwareState(Protocol):
    """What :class:`FirmwareIO` uses of the firmware
    (:class:`~nxt_link.emulator.firmware.Firmware`, which builds on this module)."""

    @property
    def outputs(self) -> list[OutputPort]: ...

    @property
    def inputs(self) -> list[InputPort]: ...

    @property
    def params(self) -> _SleepTimer: ...

    @property
    def flash(self) -> Flash: ...

    def write_mailbox(self, queue: int, message: bytes) -> int: ...

    def read_mailbox(self, queue: int, remove: bool) -> tuple[int, bytes]: ...

    def record_tone(self, frequency_hz: int, duration_ms: int, file: str | None = None) -> None: ...


class FirmwareIO:
    """The VM's view of one emulated brick (see the module docstring)."""

    def __init__(self, fw: FirmwareState, seed: int | None = None) -> None:
        self._fw = fw
        self._out = [_OutputMap() for _ in fw.outputs]
        #: some port's update flags are set: the output module has work this millisecond
        self.outputs_written = False
        self.display = Display()
        self.sound_flags = 0
        self.sound_state_value = 0
        self.semaphores = [0, 0]
        self.sleep_timeout_ms: int | None = None
        self._rng = random.Random(seed)

    def reset(self) -> None:
        """Program start and end: pending writes dropped, screen given back."""
        self._out = [_OutputMap() for _ in self._fw.outputs]
        self.outputs_written = False
        self.display = Display()
        self.semaphores = [0, 0]

    # -- outputs ------------------------------------------------------------------------

    def output_get(self, port: int, field_id: int) -> int:
        o = self._fw.outputs[port]
        m = self._out[port]
        if field_id in m.written:
            return m.written[field_id]
        if field_id == OutputField.FLAGS:
            return m.flags
        if field_id == OutputField.MODE:
            return o.mode
        if field_id == OutputField.SPEED:
            return _s8(o.power)
        if field_id == OutputField.ACTUAL_SPEED:
            return _s8(round(o.applied_duty_pct))
        if field_id == OutputField.TACHO_COUNT:
            return o.tacho_count
        if field_id == OutputField.TACHO_LIMIT:
            return o.tacho_limit & 0xFFFFFFFF
        if field_id == OutputField.RUN_STATE:
            return o.run_state
        if field_id == OutputField.TURN_RATIO:
            return _s8(o.turn_ratio)
        if field_id == OutputField.REG_MODE:
            return o.regulation_mode
        if field_id in (OutputField.REG_P, OutputField.REG_I, OutputField.REG_D):
            return m.pid[field_id - OutputField.REG_P]
        if field_id == OutputField.BLOCK_TACHO_COUNT:
            return o.block_tacho_count
        if field_id == OutputField.ROTATION_COUNT:
            return o.rotation_count
        if field_id == OutputField.OPTIONS:
            return m.options
        if field_id == OutputField.MAX_SPEED:
            return m.max_speed
        if field_id == OutputField.MAX_ACCELERATION:
            return m.max_acceleration
        return 0  # OVERLOAD: the motor model never overloads

    def output_set(self, port: int, field_id: int, value: int) -> None:
        m = self._out[port]
        if field_id == OutputField.FLAGS:
            m.flags = value
            self.outputs_written = True
        elif field_id in _READ_ONLY:
            return  # read-only fields: the module overwrites them every millisecond
        else:
            m.written[field_id] = value

    def set_output(self, port: int, power: int, mode: int, regulation_mode: int, turn_ratio: int,
                   run_state: int, tacho_limit: int, flags: int) -> None:
        """A whole ``setout`` (what NXC's ``OnFwdEx``/``CoastEx`` write), for the models."""
        m = self._out[port]
        m.written.update({OutputField.SPEED: power, OutputField.MODE: mode,
                          OutputField.REG_MODE: regulation_mode,
                          OutputField.TURN_RATIO: turn_ratio, OutputField.RUN_STATE: run_state,
                          OutputField.TACHO_LIMIT: tacho_limit})
        m.flags = flags
        self.outputs_written = True

    def apply_output_updates(self) -> None:
        """The output module's turn (``cOutputCtrl``): apply what the flags ask."""
        self.outputs_written = False
        for port, m in zip(self._fw.outputs, self._out):
            flags = m.flags
            if not flags:
                continue
            w = m.written
            if flags & _RESETS:
                port.reset_counters(flags & _RESETS)
            if flags & _APPLY:
                port.set_output_state(
                    _s8(w.get(OutputField.SPEED, port.power)), w.get(OutputField.MODE, port.mode),
                    w.get(OutputField.REG_MODE, port.regulation_mode),
                    _s8(w.get(OutputField.TURN_RATIO, port.turn_ratio)),
                    w.get(OutputField.RUN_STATE, port.run_state),
                    w.get(OutputField.TACHO_LIMIT, port.tacho_limit))
                for k in (OutputField.SPEED, OutputField.MODE, OutputField.REG_MODE,
                          OutputField.TURN_RATIO, OutputField.RUN_STATE, OutputField.TACHO_LIMIT):
                    w.pop(k, None)
            elif flags & UPDATE_SPEED:
                _set_speed(port, _s8(w.pop(OutputField.SPEED, port.power)),
                           w.pop(OutputField.RUN_STATE, port.run_state))
            if flags & UPDATE_PID_VALUES:
                m.pid = (w.pop(OutputField.REG_P, m.pid[0]), w.pop(OutputField.REG_I, m.pid[1]),
                         w.pop(OutputField.REG_D, m.pid[2]))
                m.max_speed = w.pop(OutputField.MAX_SPEED, m.max_speed)
                m.max_acceleration = w.pop(OutputField.MAX_ACCELERATION, m.max_acceleration)
            if OutputField.OPTIONS in w:
                m.options = w.pop(OutputField.OPTIONS)
            m.flags = 0

    # -- inputs -------------------------------------------------------------------------

    def input_get(self, port: int, field_id: int) -> int:
        i = self._fw.inputs[port]
        return (i.sensor_type, i.sensor_mode, i.raw, i.normalized, i.scaled,
                int(i.invalid))[field_id]

    def input_set(self, port: int, field_id: int, value: int) -> None:
        i = self._fw.inputs[port]
        if field_id == InputField.TYPE:
            i.sensor_type = value
        elif field_id == InputField.MODE:
            i.sensor_mode = value
        elif field_id == InputField.RAW:
            i.raw = value
        elif field_id == InputField.NORMALIZED:
            i.normalized = value
        elif field_id == InputField.SCALED:
            i.scaled = value
        else:
            i.invalid = bool(value)

    # -- mailboxes --------------------------------------------------------------------------

    def message_write(self, queue: int, message: bytes) -> int:
        return _s8(self._fw.write_mailbox(queue, message))

    def message_read(self, queue: int, remove: bool) -> tuple[int, bytes]:
        status, data = self._fw.read_mailbox(queue, remove)
        return _s8(status), data

    # -- sound, display, buttons, system ------------------------------------------------------

    def play_tone(self, frequency_hz: int, duration_ms: int, loop: bool, volume: int) -> None:
        self._fw.record_tone(frequency_hz, duration_ms)

    def play_file(self, name: str, loop: bool, volume: int) -> None:
        self._fw.record_tone(0, 0, name)

    def sound_state(self) -> tuple[int, int]:
        return self.sound_state_value, self.sound_flags

    def set_sound_state(self, state: int, flags: int) -> None:
        self.sound_state_value = state
        self.sound_flags |= flags

    def clear_screen_if_needed(self, options: int) -> None:
        if not self.display.dirty:
            self.display.dirty = True
            options = 1
        if options & 1:
            self.display.clear()

    def draw_text(self, x: int, y: int, text: bytes, options: int) -> None:
        self.display.text(x, y, text)

    def read_button(self, index: int, reset: bool) -> tuple[int, bool, int]:
        if index >= 4:
            return ERR_INVALID_PORT, False, 0
        return 0, False, 0  # nobody presses the emulated brick's buttons

    def keep_alive(self) -> int:
        return self._fw.params.sleep_minutes * 60000

    def set_sleep_timeout(self, ms: int) -> None:
        self.sleep_timeout_ms = ms

    def random(self) -> int:
        return self._rng.randrange(-0x8000, 0x8000)

    def bluetooth_status(self, connection: int) -> int:
        return 0 if connection == 0 else ERR_COMM_CHAN_NOT_READY

    @property
    def flash(self) -> Flash:
        return self._fw.flash


def _set_speed(port: OutputPort, power: int, run_state: int) -> None:
    port.power = power
    port.run_state = run_state


def _s8(v: int) -> int:
    v &= 0xFF
    return v - 0x100 if v & 0x80 else v
