"""The brick's firmware as the PC sees it: direct commands, mailboxes, programs, outputs.

:class:`Firmware` answers telegrams exactly as the NXT firmware's
``cCmdHandleRemoteCommands`` does (reply lengths fixed per opcode, zero-filled
on error, status codes and their order of checks, no reply to a no-reply
telegram, unknown opcodes answered ``BE``), keeps the 20 mailbox queues with
their real rules (5 deep, a write to a full queue drops the oldest, cleared at
program start), starts and stops the one program it has installed, and runs
that program, the four input ports and the three output ports every millisecond.
Environments attached with :meth:`Firmware.attach` (a sensor world, a stalled motor) run
after the output module each millisecond: they read the motors and set the sensors' A/D
values, which the input module turns into what GETINPUTVALUES and a program read.

It knows nothing about links, latency or faults (that is
:mod:`nxt_link.emulator`) and has no clock of its own: its owner calls
:meth:`Firmware.tick` once per simulated millisecond, in the firmware's own
order (communication, then the VM slice, then the output module).
"""
from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from nxt_link import telegram as tg
from nxt_link.errors import TelegramError
from nxt_link.input_module import NO_OF_INPUTS, InputPort
from nxt_link.motor_model import MotorParams
from nxt_link.output_module import RESET_NONE, OutputPort
from nxt_link.telegram import Opcode, OutputMode, RegulationMode, RunState

__all__ = ["FirmwareParams", "Firmware", "Program", "ProgramHost", "InputPort", "Environment"]

log = logging.getLogger(__name__)

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
    """

    name: str = "NXT"
    battery_mv: int = 9000
    sleep_minutes: int = 10
    files: tuple[str, ...] = ()
    start_delay_ms: int = 200
    bt_address: bytes = bytes.fromhex("001653010203")
    firmware_version: tuple[int, int] = (1, 31)
    protocol_version: tuple[int, int] = (1, 124)


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

    def sensor_valid(self, port: int) -> bool: ...

    def play_tone(self, frequency_hz: int, duration_ms: int) -> None: ...


class Program(Protocol):
    """A program model; a fresh instance is created at every activation."""

    def step(self, host: ProgramHost) -> None:
        """Called once per millisecond VM slice while the program runs."""
        ...


class Environment(Protocol):
    """Something outside the brick that moves with its motors or feeds its sensors."""

    def step(self, firmware: Firmware) -> None:
        """Called once per millisecond, after the output module moved the motors."""
        ...


@dataclass(slots=True)
class _Tone:
    at_ms: int
    frequency_hz: int
    duration_ms: int


class Firmware:
    """Direct-command handler, mailboxes, program lifecycle and outputs of one brick.

    Args:
        params: brick-level settings.
        motor_params: one :class:`MotorParams` for all three ports, or a tuple
            of three (ports A, B, C).
        programs: installed program models by file name; each value builds a
            fresh program instance.
    """

    def __init__(self, params: FirmwareParams | None = None,
                 motor_params: MotorParams | tuple[MotorParams, ...] | None = None,
                 programs: dict[str, Callable[[], Program]] | None = None) -> None:
        self.params = params or FirmwareParams()
        if isinstance(motor_params, tuple):
            per_port = motor_params
        else:
            per_port = (motor_params or MotorParams(),) * NO_OF_OUTPUTS
        if len(per_port) != NO_OF_OUTPUTS:
            raise ValueError("motor_params needs one entry per output port (3)")
        self.outputs = [OutputPort(i, per_port[i]) for i in range(NO_OF_OUTPUTS)]
        self.inputs = [InputPort() for _ in range(NO_OF_INPUTS)]
        self.programs = dict(programs or {})
        self.files = set(self.params.files) | set(self.programs)
        self.mailboxes: list[deque[bytes]] = [deque(maxlen=MESSAGES_PER_QUEUE)
                                              for _ in range(tg.MAILBOX_COUNT)]
        self.now_ms = 0
        self.program: Program | None = None
        self.program_name: str | None = None
        self._pending_start: tuple[str, int] | None = None
        self._pending_stop = False
        self.tones: list[_Tone] = []
        self.environments: list[Environment] = []
        self.host = _Host(self)

    def attach(self, environment: Environment) -> None:
        """Run ``environment`` every millisecond from now on (after the outputs)."""
        self.environments.append(environment)

    # -- program lifecycle ----------------------------------------------------

    @property
    def program_running(self) -> bool:
        return self.program is not None

    def start_program_now(self, name: str) -> None:
        """Activate ``name`` immediately (used at power-on with a running program)."""
        self._activate(name)

    def _activate(self, name: str) -> None:
        if self.program is not None:
            self._deactivate()
        for out in self.outputs:
            out.reset_device()
        for box in self.mailboxes:
            box.clear()
        factory = self.programs.get(name)
        if factory is None:
            # a file without a model: it "runs" but does nothing
            self.program = _IdleProgram()
        else:
            self.program = factory()
        self.program_name = name
        log.info("program %s started at %d ms", name, self.now_ms)

    def _deactivate(self) -> None:
        log.info("program %s stopped at %d ms", self.program_name, self.now_ms)
        self.program = None
        self.program_name = None
        for out in self.outputs:
            out.reset_device()

    # -- the millisecond --------------------------------------------------------

    def tick(self) -> None:
        """Advance one millisecond: program start/stop, VM slice, output module."""
        self.now_ms += 1
        if self._pending_stop:
            self._pending_stop = False
            if self.program is not None:
                self._deactivate()
        if self._pending_start is not None and self.now_ms >= self._pending_start[1]:
            name = self._pending_start[0]
            self._pending_start = None
            self._activate(name)
        for inp in self.inputs:
            inp.step()
        if self.program is not None:
            self.program.step(self.host)
        for out in self.outputs:
            out.step()
        for env in self.environments:
            env.step(self)

    # -- direct commands ----------------------------------------------------------

    def handle(self, telegram: bytes) -> bytes | None:
        """Process one telegram; return the reply telegram, or None (no reply).

        Malformed telegrams that the firmware could not even parse (shorter than
        their opcode needs) are dropped without a reply and logged.
        """
        if len(telegram) < 2:
            log.warning("dropping %d-byte telegram", len(telegram))
            return None
        ttype, op = telegram[0], telegram[1]
        if ttype == tg.CommandType.REPLY:
            self._incoming_reply(telegram)
            return None
        if ttype not in (0x00, 0x01, 0x80, 0x81):
            log.debug("ignoring telegram type 0x%02X", ttype)
            return None
        want_reply = not ttype & 0x80
        if ttype & 0x01:
            return self._system(telegram, want_reply)
        if op in (_OP_PLAY_SOUND_FILE, _OP_RESET_IN_VAL, _OP_STOP_SOUND):
            return self._unused_direct(telegram, want_reply)
        try:
            opcode = Opcode(op)
        except ValueError:
            opcode = None
        if opcode is None or opcode.is_system:
            return tg.error_reply(op, ERR_RC_UNKNOWN_CMD) if want_reply else None
        if opcode is Opcode.MESSAGE_WRITE:
            return self._message_write(telegram, want_reply)
        try:
            cmd = tg.decode_command(telegram)
        except TelegramError as exc:
            log.warning("dropping malformed telegram %s: %s", telegram.hex(), exc)
            return None
        reply = self._direct(cmd)
        return reply if want_reply else None

    def _direct(self, cmd: tg.Command) -> bytes:
        op = int(cmd.opcode)
        if isinstance(cmd, tg.StartProgram):
            if cmd.name not in self.files:
                return tg.error_reply(op, ERR_RC_ILLEGAL_VAL)
            self._pending_start = (cmd.name, self.now_ms + self.params.start_delay_ms)
            return tg.encode_reply(tg.StatusReply(op, NO_ERR))
        if isinstance(cmd, tg.StopProgram):
            if self.program is None:
                return tg.error_reply(op, ERR_NO_PROG)
            self._pending_stop = True
            return tg.encode_reply(tg.StatusReply(op, NO_ERR))
        if isinstance(cmd, tg.PlayTone):
            self.tones.append(_Tone(self.now_ms, cmd.frequency_hz, cmd.duration_ms))
            return tg.encode_reply(tg.StatusReply(op, NO_ERR))
        if isinstance(cmd, tg.SetOutputState):
            if cmd.port >= NO_OF_OUTPUTS and cmd.port != 0xFF:
                return tg.error_reply(op, ERR_RC_ILLEGAL_VAL)
            ports = self.outputs if cmd.port == 0xFF else [self.outputs[cmd.port]]
            for out in ports:
                out.set_output_state(cmd.power, cmd.mode, cmd.regulation_mode, cmd.turn_ratio,
                                     cmd.run_state, cmd.tacho_limit)
            return tg.encode_reply(tg.StatusReply(op, NO_ERR))
        if isinstance(cmd, tg.SetInputMode):
            if cmd.port >= NO_OF_INPUTS:
                return tg.error_reply(op, ERR_RC_ILLEGAL_VAL)
            self.inputs[cmd.port].set_type_and_mode(cmd.sensor_type, cmd.sensor_mode)
            return tg.encode_reply(tg.StatusReply(op, NO_ERR))
        if isinstance(cmd, tg.GetOutputState):
            if cmd.port >= NO_OF_OUTPUTS:
                return tg.error_reply(op, ERR_RC_ILLEGAL_VAL)
            o = self.outputs[cmd.port]
            return tg.encode_reply(tg.OutputStateReply(
                NO_ERR, cmd.port, _s8(o.power), o.mode & 0x07, _regmode(o.regulation_mode),
                _s8(o.turn_ratio), _runstate(o.run_state), o.tacho_limit & 0xFFFFFFFF,
                _s32(o.tacho_count), _s32(o.block_tacho_count), _s32(o.rotation_count)))
        if isinstance(cmd, tg.GetInputValues):
            if cmd.port >= NO_OF_INPUTS:
                return tg.error_reply(op, ERR_RC_ILLEGAL_VAL)
            i = self.inputs[cmd.port]
            # the firmware copies the normalized value into the calibrated field
            return tg.encode_reply(tg.InputValuesReply(
                NO_ERR, cmd.port, i.valid, False, i.sensor_type, i.sensor_mode,
                i.raw, i.normalized, _s16(i.scaled), i.normalized))
        if isinstance(cmd, tg.MessageRead):
            return self._message_read(cmd)
        if isinstance(cmd, tg.ResetMotorPosition):
            if cmd.port >= NO_OF_OUTPUTS:
                return tg.error_reply(op, ERR_RC_ILLEGAL_VAL)
            out = self.outputs[cmd.port]
            if cmd.relative:
                out.block_tacho_count = 0
            else:
                out.rotation_count = 0
            return tg.encode_reply(tg.StatusReply(op, NO_ERR))
        if isinstance(cmd, tg.GetBatteryLevel):
            return tg.encode_reply(tg.BatteryLevelReply(NO_ERR, self.params.battery_mv))
        if isinstance(cmd, tg.KeepAlive):
            return tg.encode_reply(tg.KeepAliveReply(NO_ERR, self.params.sleep_minutes * 60000))
        if isinstance(cmd, tg.GetCurrentProgramName):
            if self.program is None:
                return tg.error_reply(op, ERR_NO_PROG)
            return tg.encode_reply(tg.ProgramNameReply(NO_ERR, self.program_name or ""))
        return tg.error_reply(op, ERR_RC_UNKNOWN_CMD)  # pragma: no cover - all handled

    def _unused_direct(self, telegram: bytes, want_reply: bool) -> bytes | None:
        op = telegram[1]
        status = NO_ERR
        if op == _OP_PLAY_SOUND_FILE:
            status = ERR_RC_ILLEGAL_VAL  # no sound files on the emulated brick
        elif op == _OP_RESET_IN_VAL:
            if len(telegram) < 3:
                return None
            if telegram[2] >= NO_OF_INPUTS:
                status = ERR_RC_ILLEGAL_VAL
            else:
                self.inputs[telegram[2]].reset_scaled()
        return bytes((tg.CommandType.REPLY, op, status)) if want_reply else None

    def _system(self, telegram: bytes, want_reply: bool) -> bytes | None:
        if not want_reply:
            return None
        op = telegram[1]
        if op == Opcode.GET_FIRMWARE_VERSION:
            (fmaj, fmin), (pmaj, pmin) = self.params.firmware_version, self.params.protocol_version
            return tg.encode_reply(tg.FirmwareVersionReply(NO_ERR, pmin, pmaj, fmin, fmaj))
        if op == Opcode.GET_DEVICE_INFO:
            return tg.encode_reply(tg.DeviceInfoReply(
                NO_ERR, self.params.name, self.params.bt_address, (0, 0, 0, 0), 65536))
        # other system commands (file I/O, ...) are not modelled
        return bytes((tg.CommandType.REPLY, op, ERR_RC_UNKNOWN_CMD))

    # -- mailboxes ------------------------------------------------------------------

    def _message_write(self, telegram: bytes, want_reply: bool) -> bytes | None:
        op = Opcode.MESSAGE_WRITE
        if len(telegram) < 4:
            log.warning("dropping truncated MESSAGEWRITE %s", telegram.hex())
            return None
        inbox, size = telegram[2], telegram[3]
        data = telegram[4:4 + size]
        if size == 0 or size > tg.MAX_MESSAGE_SIZE or len(data) < size or data[size - 1] != 0:
            status = ERR_RC_ILLEGAL_VAL
        else:
            status = self.write_mailbox(inbox, bytes(data))
        if not want_reply:
            return None
        return tg.encode_reply(tg.StatusReply(op, status))

    def write_mailbox(self, queue: int, message: bytes) -> int:
        """Firmware ``cCmdMessageWrite``: the order of its checks, drop-oldest when full."""
        if queue >= tg.MAILBOX_COUNT:
            return ERR_INVALID_QUEUE
        if self.program is None:
            return ERR_NO_PROG
        if len(message) > tg.MAX_MESSAGE_SIZE:
            return ERR_INVALID_SIZE
        box = self.mailboxes[queue]
        if len(box) == MESSAGES_PER_QUEUE:
            log.debug("mailbox %d full: oldest message dropped", queue)
        box.append(message)  # deque(maxlen=5) drops the oldest, like the firmware
        return NO_ERR

    def read_mailbox(self, queue: int, remove: bool) -> tuple[int, bytes]:
        """Firmware ``cCmdMessageGetSize`` + ``cCmdMessageRead``."""
        if self.program is None:
            return ERR_NO_PROG, b""
        if queue >= tg.MAILBOX_COUNT:
            return ERR_INVALID_QUEUE, b""
        box = self.mailboxes[queue]
        if not box:
            return STAT_MSG_EMPTY_MAILBOX, b""
        return NO_ERR, (box.popleft() if remove else box[0])

    def _message_read(self, cmd: tg.MessageRead) -> bytes:
        status, message = self.read_mailbox(cmd.remote_inbox, cmd.remove)
        if status != NO_ERR:
            return tg.error_reply(Opcode.MESSAGE_READ, status, cmd.local_inbox)
        return tg.encode_reply(tg.MessageReadReply(NO_ERR, cmd.local_inbox, message))

    def _incoming_reply(self, telegram: bytes) -> None:
        """A MESSAGEREAD reply sent *to* the brick is stored in the mailbox it names."""
        if len(telegram) < 5 or telegram[1] != Opcode.MESSAGE_READ:
            return
        status, queue, size = telegram[2], telegram[3], telegram[4]
        data = telegram[5:5 + size]
        if (status & 0x80) == 0 and 0 < size <= tg.MAX_MESSAGE_SIZE and len(data) == size \
                and data[-1] == 0:
            self.write_mailbox(queue, bytes(data))


class _IdleProgram:
    def step(self, host: ProgramHost) -> None:
        return None


class _Host:
    """The NXC API a program model calls, bound to one firmware."""

    def __init__(self, fw: Firmware) -> None:
        self._fw = fw

    def current_tick(self) -> int:
        return self._fw.now_ms

    def receive_remote_string(self, queue: int, clear: bool) -> tuple[int, bytes]:
        """NXC ``ReceiveRemoteString``: (status, message bytes including the NUL)."""
        return self._fw.read_mailbox(queue, clear)

    def send_response_string(self, queue: int, data: bytes) -> int:
        """NXC ``SendResponseString(q, s)``: enqueue ``data`` + NUL into mailbox q+10."""
        return self._fw.write_mailbox(queue + 10, data + b"\0")

    def motor_rotation_count(self, port: int) -> int:
        return self._fw.outputs[port].rotation_count

    def on_fwd_ex(self, port: int, power: int, reset: int) -> None:
        """NXC ``OnFwdEx``: MOTORON|BRAKE, regulation idle, running, no limit."""
        self._fw.outputs[port].set_output_state(
            power, OutputMode.MOTORON | OutputMode.BRAKE, RegulationMode.IDLE, 0,
            RunState.RUNNING, 0, reset)

    def coast_ex(self, port: int, reset: int = RESET_NONE) -> None:
        """NXC ``CoastEx``: mode BRAKE without MOTORON, run state idle."""
        self._fw.outputs[port].set_output_state(
            0, OutputMode.BRAKE, RegulationMode.IDLE, 0, RunState.IDLE, 0, reset)

    def off_ex(self, port: int, reset: int = RESET_NONE) -> None:
        """NXC ``OffEx``: MOTORON|BRAKE at power 0, running (the short-circuit brake)."""
        self.on_fwd_ex(port, 0, reset)

    def set_sensor(self, port: int, sensor_type: int, sensor_mode: int) -> None:
        """NXC ``SetSensorType`` + ``SetSensorMode`` (``SetSensorLight``, ``SetSensorTouch``)."""
        self._fw.inputs[port].set_type_and_mode(sensor_type, sensor_mode)

    def sensor(self, port: int) -> int:
        """NXC ``Sensor(port)``: the scaled value."""
        return self._fw.inputs[port].scaled

    def sensor_valid(self, port: int) -> bool:
        """NXC ``SensorInvalid(port)`` negated (``ResetSensor`` waits for it)."""
        return self._fw.inputs[port].valid

    def play_tone(self, frequency_hz: int, duration_ms: int) -> None:
        """NXC ``PlayTone``."""
        self._fw.tones.append(_Tone(self._fw.now_ms, frequency_hz, duration_ms))


def _s8(v: int) -> int:
    return max(-128, min(127, v))


def _s16(v: int) -> int:
    return max(-32768, min(32767, v))


def _s32(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v & 0x80000000 else v


def _regmode(v: int) -> int:
    return v if v in (0, 1, 2) else 0


def _runstate(v: int) -> int:
    return v if v in (0x00, 0x10, 0x20, 0x40) else 0

