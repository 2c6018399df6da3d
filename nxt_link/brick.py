"""The PC side of the direct commands: one explicit method per command.

:class:`Brick` sends a telegram through any :class:`~nxt_link.transport.Transport`
and waits for its reply against a deadline. What it does about a bad link is
the point of this module:

* a reply for another opcode (late, after an earlier timeout) is skipped;
* a timeout or a damaged reply (wrong length, not a reply) makes it drop
  whatever is in the input, wait for the line to be quiet and send again,
  up to ``retries`` more times for commands that are safe to repeat;
* a status that only a damaged request can produce (unknown opcode, illegal
  value, bad queue, ...) is retried the same way before it is raised;
* a lost link is reopened (``reconnect_timeout_s``) and the command resent.

Commands that are not safe to repeat blindly (STARTPROGRAM, STOPPROGRAM) are
sent once. Everything that goes wrong in the end is one exception of the
:mod:`nxt_link.errors` tree whose message names the brick and the command.

>>> from nxt_link.clock import VirtualClock
>>> from nxt_link.emulator import BrickEmulator, EmulatorConfig, LinkParams
>>> from nxt_link.memory_transport import MemoryTransport
>>> emu = BrickEmulator(EmulatorConfig(link=LinkParams.instant()))
>>> brick = Brick(MemoryTransport(emu, VirtualClock()))
>>> brick.get_battery_level()
9000
"""
from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass

from nxt_link import telegram as tg
from nxt_link.clock import Deadline
from nxt_link.errors import (
    BadArgumentsError,
    BadPacketError,
    IllegalValueError,
    InvalidPortError,
    InvalidQueueError,
    InvalidSizeError,
    LinkDisconnectedError,
    LinkError,
    LinkTimeoutError,
    ProtocolError,
    TelegramError,
    UnknownCommandError,
    UnknownStatusError,
)
from nxt_link.transport import Transport

__all__ = ["Brick", "RetryPolicy", "LinkEvent"]

log = logging.getLogger(__name__)

# statuses a correct request cannot get: seen only when the request or the reply
# was damaged (an undocumented status byte is a damaged reply)
_DAMAGE_STATUSES = (UnknownCommandError, BadPacketError, IllegalValueError, InvalidQueueError,
                    InvalidPortError, InvalidSizeError, BadArgumentsError, UnknownStatusError)


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How hard :class:`Brick` tries.

    Attributes:
        reply_timeout_s: wait this long for each reply (RWTH toolbox uses 2 s
            on Bluetooth; a healthy round trip is 30-60 ms).
        retries: extra attempts after a timeout or damaged reply.
        quiet_s: after damage, drop input until the line is quiet this long.
        reconnect_timeout_s: keep reopening a lost link for this long; 0 = never.
    """

    reply_timeout_s: float = 1.0
    retries: int = 3
    quiet_s: float = 0.05
    reconnect_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        if self.reply_timeout_s <= 0 or self.retries < 0 or self.quiet_s < 0 \
                or self.reconnect_timeout_s < 0:
            raise ValueError("retry policy values must be positive")


@dataclass(frozen=True, slots=True)
class LinkEvent:
    """Something worth a line in the execution log (timeouts, reconnects, ...)."""

    t_s: float
    brick: str
    event: str
    detail: str = ""


class Brick:
    """A connection to one NXT brick (real or emulated).

    Args:
        transport: the link.
        name: used in messages and events (e.g. the robot name "r1").
        policy: timeouts and retries.
        on_event: called with a :class:`LinkEvent` for every retry, damaged
            frame, reconnect (also settable later as the ``on_event`` attribute);
            events are logged at INFO in any case.
    """

    def __init__(self, transport: Transport, *, name: str | None = None,
                 policy: RetryPolicy | None = None,
                 on_event: Callable[[LinkEvent], None] | None = None) -> None:
        self.transport = transport
        self.name = name or transport.name
        self.policy = policy or RetryPolicy()
        self.on_event = on_event
        self._lock = threading.Lock()
        self.clock = transport.clock

    def close(self) -> None:
        self.transport.close()

    def __enter__(self) -> Brick:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- machinery ----------------------------------------------------------------

    def _event(self, event: str, detail: str = "") -> None:
        ev = LinkEvent(self.clock.now(), self.name, event, detail)
        log.info("%s: %s %s", self.name, event, detail)
        if self.on_event is not None:
            self.on_event(ev)

    def reconnect(self) -> None:
        """Reopen the link now (raises LinkDisconnectedError if it stays down)."""
        if self.policy.reconnect_timeout_s <= 0:
            raise LinkDisconnectedError(f"brick {self.name}: link lost ({self.transport.name})")
        try:
            self.transport.reconnect(Deadline(self.clock, self.policy.reconnect_timeout_s))
        except LinkDisconnectedError:
            raise LinkDisconnectedError(
                f"brick {self.name}: link lost and {self.transport.name} could not be reopened"
                f" within {self.policy.reconnect_timeout_s:g} s") from None
        self._event("reconnected", self.transport.name)

    def _await_reply(self, opcode: int) -> tg.Reply:
        deadline = Deadline(self.clock, self.policy.reply_timeout_s)
        while True:
            telegram = self.transport.recv(deadline)
            reply = tg.parse_reply(telegram)  # TelegramError: damaged
            if reply.opcode != opcode:
                self._event("stale reply", f"opcode 0x{int(reply.opcode):02X} skipped")
                continue
            return reply

    def request(self, cmd: tg.Command, *, retry: bool = True) -> tg.Reply | None:
        """Send ``cmd``; return its (successful) reply, or None for a no-reply command.

        Raises:
            ProtocolError: the brick answered with a non-zero status.
            LinkTimeoutError: no usable reply after all attempts.
            LinkDisconnectedError: the link is down and could not be reopened.
        """
        op_name = cmd.opcode.name
        attempts = 1 + (self.policy.retries if retry else 0)
        data = tg.encode_command(cmd)
        last: LinkError | None = None
        with self._lock:
            for attempt in range(attempts):
                try:
                    self.transport.send(data)
                    if not cmd.reply:
                        return None
                    reply = self._await_reply(cmd.opcode)
                    if reply.status:
                        raise _status_error(reply.status, cmd.opcode)
                    return reply
                except LinkDisconnectedError as exc:
                    self._event("link lost", str(exc))
                    last = exc
                    self.reconnect()
                except LinkTimeoutError as exc:
                    last = exc
                    self._event("timeout", f"{op_name} attempt {attempt + 1}/{attempts}")
                    self._resync()
                except TelegramError as exc:
                    last = exc
                    self._event("damaged reply", f"{op_name}: {exc}")
                    self._resync()
                except _DAMAGE_STATUSES as exc:
                    if attempt + 1 >= attempts:
                        raise _named(exc, self.name, op_name) from None
                    last = exc
                    self._event("suspicious status", f"{op_name}: {exc}")
                    self._resync()
                except ProtocolError as exc:
                    raise _named(exc, self.name, op_name) from None
        if isinstance(last, LinkTimeoutError) or isinstance(last, TelegramError) or last is None:
            raise LinkTimeoutError(
                f"brick {self.name} did not answer {op_name} within "
                f"{self.policy.reply_timeout_s:g} s ({attempts} attempt"
                f"{'s' if attempts > 1 else ''}) on {self.transport.name}")
        raise _named(last, self.name, op_name)

    def _resync(self) -> None:
        try:
            self.transport.discard_input(self.policy.quiet_s)
        except LinkDisconnectedError:
            self.reconnect()

    # -- one method per command -----------------------------------------------------

    def start_program(self, name: str) -> None:
        """STARTPROGRAM (not retried). Raises IllegalValueError if the file is missing."""
        self.request(tg.StartProgram(name), retry=False)

    def stop_program(self) -> None:
        """STOPPROGRAM (not retried). Raises NoActiveProgramError if nothing runs."""
        self.request(tg.StopProgram(), retry=False)

    def play_tone(self, frequency_hz: int, duration_ms: int) -> None:
        """PLAYTONE, no reply (as nxt-python sends it)."""
        self.request(tg.PlayTone(frequency_hz, duration_ms))

    def set_output_state(self, port: int, power: int, mode: int, regulation_mode: int,
                         turn_ratio: int, run_state: int, tacho_limit: int,
                         *, reply: bool = False) -> None:
        """SETOUTPUTSTATE; no reply by default (as nxt-python sends it)."""
        self.request(tg.SetOutputState(port, power, mode, regulation_mode, turn_ratio,
                                       run_state, tacho_limit, reply))

    def set_input_mode(self, port: int, sensor_type: int, sensor_mode: int,
                       *, reply: bool = False) -> None:
        """SETINPUTMODE; no reply by default."""
        self.request(tg.SetInputMode(port, sensor_type, sensor_mode, reply))

    def get_output_state(self, port: int) -> tg.OutputStateReply:
        reply = self.request(tg.GetOutputState(port))
        assert isinstance(reply, tg.OutputStateReply)
        return reply

    def get_input_values(self, port: int) -> tg.InputValuesReply:
        reply = self.request(tg.GetInputValues(port))
        assert isinstance(reply, tg.InputValuesReply)
        return reply

    def message_write(self, inbox: int, message: bytes, *, reply: bool = True) -> None:
        """MESSAGEWRITE of ``message`` (<= 58 bytes; the NUL is appended).

        With ``reply=False`` a missing program or a bad inbox goes unnoticed.
        """
        self.request(tg.MessageWrite(inbox, message, reply))

    def message_read(self, remote_inbox: int, local_inbox: int = 0,
                     remove: bool = True) -> bytes:
        """MESSAGEREAD; returns the message without its trailing NUL.

        Raises:
            EmptyMailboxError: the queue is empty.
            NoActiveProgramError: no program runs.
        """
        reply = self.request(tg.MessageRead(remote_inbox, local_inbox, remove))
        assert isinstance(reply, tg.MessageReadReply)
        return reply.payload

    def reset_motor_position(self, port: int, relative: bool) -> None:
        """RESETMOTORPOSITION: relative=True zeroes BlockTachoCount, False RotationCount."""
        self.request(tg.ResetMotorPosition(port, relative))

    def get_battery_level(self) -> int:
        """GETBATTERYLEVEL in millivolts."""
        reply = self.request(tg.GetBatteryLevel())
        assert isinstance(reply, tg.BatteryLevelReply)
        return reply.millivolts

    def keep_alive(self) -> int:
        """KEEPALIVE; returns the sleep limit in ms."""
        reply = self.request(tg.KeepAlive())
        assert isinstance(reply, tg.KeepAliveReply)
        return reply.sleep_limit_ms

    def get_current_program_name(self) -> str:
        """GETCURRENTPROGRAMNAME. Raises NoActiveProgramError if nothing runs."""
        reply = self.request(tg.GetCurrentProgramName())
        assert isinstance(reply, tg.ProgramNameReply)
        return reply.name


def _status_error(status: int, opcode: int) -> ProtocolError:
    from nxt_link.errors import error_for_status

    return error_for_status(status, opcode)


def _named(exc: LinkError, brick: str, op_name: str) -> LinkError:
    """Same exception type, message prefixed with the brick and command."""
    text = f"brick {brick}: {op_name} failed: {exc}"
    if isinstance(exc, ProtocolError):
        new = type(exc).__new__(type(exc))
        new.opcode = exc.opcode
        Exception.__init__(new, text)
        return new
    return type(exc)(text)
