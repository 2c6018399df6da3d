"""The brick's firmware as the PC sees it: direct commands, mailboxes, programs, outputs.

:class:`Firmware` answers telegrams exactly as the NXT firmware's
``cCmdHandleRemoteCommands`` does (reply lengths fixed per opcode, zero-filled
on error, status codes and their order of checks, no reply to a no-reply
telegram, unknown opcodes answered ``BE``), keeps the 20 mailbox queues with
their real rules (5 deep, a write to a full queue drops the oldest, cleared at
program start), starts and stops the one program it has installed, and runs
that program and the three output ports every millisecond.

Programs live in the flash file system (:class:`nxt_link.emulator.vm.flash.Flash`),
filled by the system commands (OPENWRITE, WRITE, CLOSE, ... as nxt-python's
file API sends them) or at power-on. STARTPROGRAM of an ``.rxe`` in flash runs
the compiled program on the bytecode interpreter (:mod:`nxt_link.emulator.vm`); a name
that is not in flash but has a Python model (``programs``) runs the model.
Both reach the brick through the same IO maps (:mod:`nxt_link.emulator.brick_io`). A
program the firmware refuses (malformed file) or aborts (run-time error) is
logged and listed in :attr:`Firmware.program_errors`, and nothing runs.

It knows nothing about links, latency or faults (that is
:mod:`nxt_link.emulator.emulator`) and has no clock of its own: its owner calls
:meth:`Firmware.tick` once per simulated millisecond: input module, program
start/stop, the program's time slice, then the output module (which applies
what the program wrote in the same millisecond), then the environments attached
with :meth:`Firmware.attach` (a sensor world, a stalled motor: they read the
motors and set the sensors' A/D values); the owner then handles the
communication.

The system commands (:mod:`~nxt_link.emulator.firmware_files`) and the mailboxes
(:mod:`~nxt_link.emulator.firmware_mailboxes`) are base classes of :class:`Firmware` in
modules of their own; the constants and the types programs see are in
:mod:`~nxt_link.emulator.firmware_types`.  Import the public names from here.
"""
from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable, Mapping
from typing import Protocol

from nxt_link.emulator.brick_io import FirmwareIO
from nxt_link.emulator.firmware_files import _FileCommands
from nxt_link.emulator.firmware_mailboxes import _Mailboxes
from nxt_link.emulator.firmware_types import (
    _OP_PLAY_SOUND_FILE,
    _OP_RESET_IN_VAL,
    _OP_STOP_SOUND,
    ERR_NO_PROG,
    ERR_RC_ILLEGAL_VAL,
    ERR_RC_UNKNOWN_CMD,
    MESSAGES_PER_QUEUE,
    NO_ERR,
    NO_OF_INPUTS,
    NO_OF_OUTPUTS,
    FirmwareParams,
    Program,
    ProgramHost,
    _Tone,
)
from nxt_link.emulator.input_module import InputPort, step_ports
from nxt_link.emulator.motor_model import MotorParams
from nxt_link.emulator.output_module import RESET_NONE, OutputPort
from nxt_link.emulator.vm import flash as fl
from nxt_link.emulator.vm.errors import RxeError, VMError
from nxt_link.emulator.vm.iomap import InputField
from nxt_link.emulator.vm.machine import VM
from nxt_link.emulator.vm.program import VMProgram
from nxt_link.emulator.vm.rxe import load_rxe
from nxt_link.wire import telegram as tg
from nxt_link.wire.errors import TelegramError
from nxt_link.wire.telegram import Opcode, OutputMode, RegulationMode, RunState

__all__ = ["FirmwareParams", "Firmware", "Program", "ProgramHost", "InputPort", "Environment"]

log = logging.getLogger(__name__)

class Environment(Protocol):
    """Something outside the brick that moves with its motors or feeds its sensors."""

    def step(self, firmware: Firmware) -> None:
        """Called once per millisecond, after the output module moved the motors."""
        ...



class Firmware(_FileCommands, _Mailboxes):
    """Direct-command handler, mailboxes, program lifecycle and outputs of one brick.

    Args:
        params: brick-level settings.
        motor_params: one :class:`MotorParams` for all three ports, or a tuple
            of three (ports A, B, C).
        programs: Python program models by file name, run when STARTPROGRAM
            names a file that is not in flash; each value builds a fresh instance.
        flash_files: files in flash at power-on (name -> contents), e.g.
            compiled ``.rxe`` programs.
    """

    def __init__(self, params: FirmwareParams | None = None,
                 motor_params: MotorParams | tuple[MotorParams, ...] | None = None,
                 programs: dict[str, Callable[[], Program]] | None = None,
                 flash_files: Mapping[str, bytes] | None = None) -> None:
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
        self.flash = fl.Flash()
        for name, data in (flash_files or {}).items():
            self.flash.install(name, data)
        #: program names without contents in flash that STARTPROGRAM accepts (models,
        #: declared files); files in flash are accepted too
        self.files = set(self.params.files) | set(self.programs)
        self.mailboxes: list[deque[bytes]] = [deque(maxlen=MESSAGES_PER_QUEUE)
                                              for _ in range(tg.MAILBOX_COUNT)]
        self.now_ms = 0
        self.program: Program | None = None
        self.program_name: str | None = None
        self._pending_start: tuple[str, int] | None = None
        self._pending_stop = False
        self.tones: list[_Tone] = []
        self.program_errors: list[str] = []
        self.io = FirmwareIO(self)
        self.environments: list[Environment] = []
        self.host = _Host(self)
        self._program_handle: int | None = None
        #: the running program's interpreter (None: a Python model or nothing runs)
        self._vm: VM | None = None

    def attach(self, environment: Environment) -> None:
        """Run ``environment`` every millisecond from now on (after the outputs)."""
        self.environments.append(environment)

    def record_tone(self, frequency_hz: int, duration_ms: int, file: str | None = None) -> None:
        self.tones.append(_Tone(self.now_ms, frequency_hz, duration_ms))

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
        self._reset_devices()
        for box in self.mailboxes:
            box.clear()
        data = self.flash.read_all(name)
        program: Program
        if data is not None:
            try:
                exe = load_rxe(data, name)
                program = VMProgram(exe, self.io, start_tick=self.now_ms,
                                    instructions_per_ms=self.params.vm_instructions_per_ms,
                                    fused=self.params.vm_fused,
                                    skip_busy_waits=self.params.vm_skip_busy_waits)
            except RxeError as exc:
                self._program_failed(f"cannot run {exc}")
                return
            except VMError as exc:
                self._program_failed(f"cannot run {name}: {exc}")
                return
            self._program_handle = self.flash.hold(name)
            self._vm = program.vm
        elif name in self.programs:
            program = self.programs[name]()
            log.info("%s: no compiled %s in flash: running its Python model",
                     self.params.name, name)
        else:
            # a declared file without contents or model: it "runs" but does nothing
            program = _IdleProgram()
        self.program = program
        self.program_name = name
        log.info("program %s started at %d ms", name, self.now_ms)

    def _reset_devices(self) -> None:
        """``cCmdResetDevices``: motors coast with cleared fields and counters,
        sensors back to none/raw, pending IO-map writes dropped."""
        for out in self.outputs:
            out.reset_device()
        for inp in self.inputs:
            inp.reset()
        self.io.reset()

    def _deactivate(self) -> None:
        log.info("program %s stopped at %d ms", self.program_name, self.now_ms)
        self.program = None
        self._vm = None
        self.program_name = None
        if self._program_handle is not None:
            self.flash.close(self._program_handle)
            self._program_handle = None
        self._reset_devices()

    def _program_failed(self, message: str) -> None:
        log.error("%s: %s", self.params.name, message)
        self.program_errors.append(message)

    # -- the millisecond --------------------------------------------------------

    def tick(self) -> None:
        """Advance one millisecond: inputs, program start/stop, program slice, outputs."""
        self.now_ms = now = self.now_ms + 1
        step_ports(self.inputs)
        if self._pending_stop:
            self._pending_stop = False
            if self.program is not None:
                self._deactivate()
        if self._pending_start is not None and now >= self._pending_start[1]:
            name = self._pending_start[0]
            self._pending_start = None
            self._activate(name)
        program = self.program
        if program is not None:
            vm = self._vm
            try:
                if vm is not None:
                    running = vm.run_slice(now)
                else:
                    program.step(self.host)
                    running = True
            except VMError as exc:
                self._program_failed(f"program {self.program_name} aborted: {exc}")
                self._deactivate()
            else:
                if not running:
                    log.info("program %s ended", self.program_name)
                    self._deactivate()
        io = self.io
        if io.outputs_written:
            io.apply_output_updates()
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
            if cmd.name not in self.files and self.flash.find(cmd.name) is None:
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
            inp = self.inputs[cmd.port]
            inp.sensor_type, inp.sensor_mode, inp.invalid = cmd.sensor_type, cmd.sensor_mode, True
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
            return tg.encode_reply(tg.InputValuesReply(
                NO_ERR, cmd.port, not i.invalid, False, i.sensor_type, i.sensor_mode,
                i.raw, i.normalized, i.scaled, i.normalized))
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
                self.inputs[telegram[2]].scaled = 0
        return bytes((tg.CommandType.REPLY, op, status)) if want_reply else None





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
        self._fw.io.set_output(port, power, OutputMode.MOTORON | OutputMode.BRAKE,
                               RegulationMode.IDLE, 0, RunState.RUNNING, 0, _ONFWD_FLAGS | reset)

    def coast_ex(self, port: int, reset: int = RESET_NONE) -> None:
        """NXC ``CoastEx``: mode BRAKE without MOTORON, run state idle."""
        self._fw.io.set_output(port, 0, OutputMode.BRAKE, RegulationMode.IDLE, 0, RunState.IDLE,
                               0, _ONFWD_FLAGS | reset)

    def off_ex(self, port: int, reset: int = RESET_NONE) -> None:
        """NXC ``OffEx``: MOTORON|BRAKE at power 0, running (the short-circuit brake)."""
        self.on_fwd_ex(port, 0, reset)

    def set_sensor(self, port: int, sensor_type: int, sensor_mode: int) -> None:
        """NXC ``SetSensorType`` + ``SetSensorMode`` (the data are invalid for 20 ms after a
        type change)."""
        io = self._fw.io
        io.input_set(port, InputField.TYPE, sensor_type)
        io.input_set(port, InputField.MODE, sensor_mode)

    def sensor(self, port: int) -> int:
        """NXC ``Sensor(port)``: the scaled value."""
        return self._fw.inputs[port].scaled

    def play_tone(self, frequency_hz: int, duration_ms: int) -> None:
        """NXC ``PlayTone``."""
        self._fw.record_tone(frequency_hz, duration_ms)


#: UpdateFlags NXC's OnFwdEx and CoastEx write: mode, speed, tacho limit, PID values
_ONFWD_FLAGS = 0x17


def _s8(v: int) -> int:
    return max(-128, min(127, v))


def _s32(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v & 0x80000000 else v


def _regmode(v: int) -> int:
    return v if v in (0, 1, 2) else 0


def _runstate(v: int) -> int:
    return v if v in (0x00, 0x10, 0x20, 0x40) else 0


