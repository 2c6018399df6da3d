"""The PC side of the direct commands: one explicit method per command.

:class:`Brick` sends a telegram through any :class:`~nxt_link.wire.transport.Transport`
and waits for its reply against a deadline. What it does about a bad link is
the point of this module. Direct-command replies carry no checksum, so a reply
is used only when it can be trusted: the right length for its opcode, a status
the firmware can give to this very command, echoed fields equal to the request
(:func:`~nxt_link.wire.telegram.check_reply`). Then:

* a reply for another opcode (late, after an earlier timeout) is skipped;
* a lost reply (timeout), a damaged one (wrong length, not a reply, an
  unknown or implausible status, a wrong echo) or a lost link are all handled
  alike: drop whatever is in the input, wait for the line to be quiet (or
  reopen the link) and send again;
* the command is sent again until the brick has sent **no valid frame** for
  :attr:`RetryPolicy.give_up_s` — counted from its last valid frame (or from
  the moment the command was first sent, when the link had been idle), not
  from the first try —, or until a reopen of the link fails. Only then does
  it raise one :class:`~nxt_link.wire.errors.LinkTimeoutError`.

Each attempt waits for an adaptive reply timeout: the smoothed round-trip
time plus four times its variation (Jacobson's estimator, as TCP does), at
least ``min_reply_timeout_s`` and at most ``reply_timeout_s``, doubled after
each timeout up to four times the estimate. On a link with a 30 ms round trip a lost frame then costs about
0.1 s instead of a whole second. Unlike TCP (Karn's rule) the reply to a
command sent again is timed from the last copy: the input was drained until
quiet before that copy, so the reply is almost always its own, and a sample
that is too short only costs one more copy.

Commands that are not safe to repeat blindly (STARTPROGRAM, STOPPROGRAM) are
sent once. Everything that goes wrong in the end is one exception of the
:mod:`nxt_link.wire.errors` tree whose message names the brick and the command; a
status that is plausible for the command (no program, empty mailbox, missing
file) is raised at once as its :class:`~nxt_link.wire.errors.ProtocolError`.

>>> from nxt_link.wire.clock import VirtualClock
>>> from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, LinkParams
>>> from nxt_link.emulator.memory_transport import MemoryTransport
>>> emu = BrickEmulator(EmulatorConfig(link=LinkParams.instant()))
>>> brick = Brick(MemoryTransport(emu, VirtualClock()))
>>> brick.get_battery_level()
9000
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from nxt_link.wire import telegram as tg
from nxt_link.wire.clock import Deadline, new_lock
from nxt_link.wire.errors import (
    LinkDisconnectedError,
    LinkTimeoutError,
    NoActiveProgramError,
    ProtocolError,
    TelegramError,
    error_for_status,
)
from nxt_link.wire.transport import Transport

__all__ = ["Brick", "RetryPolicy", "LinkEvent", "running_program"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class RetryPolicy:
    """How hard :class:`Brick` tries.

    Attributes:
        reply_timeout_s: the longest wait for one reply (RWTH toolbox uses 2 s
            on Bluetooth; a healthy round trip is 30-60 ms); also the first
            wait, before any round trip was measured.
        retries: sets the give-up time, ``(1 + retries) * reply_timeout_s``.
        quiet_s: after damage, drop input until the line is quiet this long.
        reconnect_timeout_s: keep reopening a lost link for this long; 0 = never.
        min_reply_timeout_s: the shortest wait for one reply.
    """

    reply_timeout_s: float = 1.0
    retries: int = 3
    quiet_s: float = 0.05
    reconnect_timeout_s: float = 10.0
    min_reply_timeout_s: float = 0.1

    def __post_init__(self) -> None:
        if self.reply_timeout_s <= 0 or self.retries < 0 or self.quiet_s < 0 \
                or self.reconnect_timeout_s < 0 or self.min_reply_timeout_s <= 0:
            raise ValueError("retry policy values must be positive")

    @property
    def give_up_s(self) -> float:
        """No valid frame from the brick for this long: it has gone (4 s by default)."""
        return (1 + self.retries) * self.reply_timeout_s


@dataclass(frozen=True, slots=True)
class LinkEvent:
    """Something worth a line in the execution log (timeouts, reconnects, ...)."""

    t_s: float
    brick: str
    event: str
    detail: str = ""


class _ReplyTimer:
    """Adaptive reply timeout: Jacobson's round-trip estimator with bounded backoff.

    After a timeout the wait doubles, up to four times the estimate (and never beyond
    ``reply_timeout_s``): enough for a reply that is late rather than lost, without waiting
    seconds for one that will never come on a link that loses frames.
    """

    BACKOFF_LIMIT = 4.0

    def __init__(self, policy: RetryPolicy) -> None:
        self.policy = policy
        self.srtt: float | None = None
        self.rttvar = 0.0
        self.estimate_s = policy.reply_timeout_s
        self.timeout_s = policy.reply_timeout_s

    def _clamp(self, value: float) -> float:
        return max(self.policy.min_reply_timeout_s, min(self.policy.reply_timeout_s, value))

    def sample(self, rtt: float) -> None:
        if self.srtt is None:
            self.srtt, self.rttvar = rtt, rtt / 2
        else:
            self.rttvar = 0.75 * self.rttvar + 0.25 * abs(self.srtt - rtt)
            self.srtt = 0.875 * self.srtt + 0.125 * rtt
        self.estimate_s = self.timeout_s = self._clamp(self.srtt + 4 * self.rttvar)

    def backoff(self) -> None:
        limit = self._clamp(self.BACKOFF_LIMIT * self.estimate_s)
        self.timeout_s = min(limit, 2 * self.timeout_s)


class Brick:
    """A connection to one NXT brick (real or emulated).

    Args:
        transport: the link.
        name: used in messages and events (e.g. the robot name "r1").
        policy: timeouts and retries.
        on_event: called with a :class:`LinkEvent` for every retry, damaged
            frame, reconnect (also settable later as the ``on_event`` attribute);
            events are logged at INFO in any case.

    Attributes:
        last_valid_s: when the last trusted reply arrived (the transport's
            clock), None before the first.
        stats: counts of reply-required ``requests`` and their ``attempts``
            (the difference: commands sent again), ``timeouts``, ``damaged`` and
            ``stale`` replies, ``reconnects``.
    """

    def __init__(self, transport: Transport, *, name: str | None = None,
                 policy: RetryPolicy | None = None,
                 on_event: Callable[[LinkEvent], None] | None = None) -> None:
        self.transport = transport
        self.name = name or transport.name
        self.policy = policy or RetryPolicy()
        self.on_event = on_event
        self.clock = transport.clock
        # one request at a time; on a simulated clock its waiters wait on the clock
        self._lock = new_lock(self.clock)
        self._timer = _ReplyTimer(self.policy)
        self.last_valid_s: float | None = None
        self._asking_since: float | None = None  # first send after the last valid frame
        self.stats = {"requests": 0, "attempts": 0, "timeouts": 0, "damaged": 0, "stale": 0,
                      "reconnects": 0}

    def close(self) -> None:
        self.transport.close()

    def __enter__(self) -> Brick:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- machinery ----------------------------------------------------------------

    @property
    def reply_timeout_s(self) -> float:
        """The current wait for one reply (adapted to the measured round trips)."""
        return self._timer.timeout_s

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
        self.stats["reconnects"] += 1
        self._event("reconnected", self.transport.name)

    def _await_reply(self, cmd: tg.Command, deadline: Deadline) -> tg.Reply:
        """The next trusted reply to ``cmd``; skips replies of other opcodes.

        Raises:
            LinkTimeoutError: nothing usable before the deadline.
            TelegramError: a damaged or untrusted reply arrived.
        """
        while True:
            telegram = self.transport.recv(deadline)
            reply = tg.parse_reply(telegram)  # TelegramError: damaged
            if reply.opcode != cmd.opcode:
                self.stats["stale"] += 1
                self._event("stale reply", f"opcode 0x{int(reply.opcode):02X} skipped")
                continue
            tg.check_reply(cmd, reply)
            return reply

    def _gone(self) -> bool:
        since = self._asking_since
        return since is not None and self.clock.now() - since >= self.policy.give_up_s

    def request(self, cmd: tg.Command, *, retry: bool = True) -> tg.Reply | None:
        """Send ``cmd``; return its (successful) reply, or None for a no-reply command.

        Raises:
            ProtocolError: the brick answered with a non-zero status this command can get.
            LinkTimeoutError: no trusted reply before the brick went silent for
                ``policy.give_up_s`` (or after the one attempt, ``retry=False``).
            LinkDisconnectedError: the link is down and could not be reopened.
        """
        op_name = cmd.opcode.name
        data = tg.encode_command(cmd)
        with self._lock:
            if not cmd.reply:
                try:
                    self.transport.send(data)
                except LinkDisconnectedError as exc:
                    self._event("link lost", str(exc))
                    self.reconnect()
                    self.transport.send(data)
                return None
            self.stats["requests"] += 1
            now = self.clock.now()
            if self._asking_since is None:
                self._asking_since = now
            attempts = 0
            problem = ""
            while True:
                attempts += 1
                self.stats["attempts"] += 1
                timeout = self._timer.timeout_s
                sent_at = self.clock.now()
                try:
                    self.transport.send(data)
                    reply = self._await_reply(cmd, Deadline(self.clock, timeout))
                except LinkDisconnectedError as exc:
                    self._event("link lost", str(exc))
                    problem = "link lost"
                    self.reconnect()  # a reopen that fails ends it here
                except LinkTimeoutError:
                    self.stats["timeouts"] += 1
                    problem = f"no reply within {timeout:.2g} s"
                    self._event("timeout", f"{op_name} attempt {attempts}: {problem}")
                    self._timer.backoff()
                    self._resync()
                except TelegramError as exc:
                    self.stats["damaged"] += 1
                    problem = f"damaged reply: {exc}"
                    self._event("damaged reply", f"{op_name}: {exc}")
                    self._resync()
                else:
                    now = self.clock.now()
                    self._timer.sample(now - sent_at)
                    self.last_valid_s = now
                    self._asking_since = None
                    if reply.status:
                        raise _named(error_for_status(reply.status, cmd.opcode), self.name,
                                     op_name)
                    return reply
                if not retry or self._gone():
                    break
        since = self._asking_since if self._asking_since is not None else sent_at
        silent = self.clock.now() - since
        raise LinkTimeoutError(
            f"brick {self.name} did not answer {op_name} "
            + (f"for {silent:.1f} s " if retry else "")
            + f"({attempts} attempt{'s' if attempts > 1 else ''} on {self.transport.name}; "
            f"last: {problem})")

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


def running_program(ask: Callable[[], str], expected: str) -> str | None:
    """The running program's name (``ask()``: GETCURRENTPROGRAMNAME), None when nothing runs.

    A direct-command reply has no checksum and a damaged name must not be trusted, so the
    name is asked until it is ``expected`` or two answers agree; after five, the last one.
    """
    answers: list[str | None] = []
    for _ in range(5):
        try:
            name: str | None = ask()
        except NoActiveProgramError:
            name = None
        if name == expected or name in answers:
            return name
        answers.append(name)
    return answers[-1]


def _named(exc: ProtocolError, brick: str, op_name: str) -> ProtocolError:
    """Same exception type, message prefixed with the brick and command."""
    new = type(exc).__new__(type(exc))
    new.opcode = exc.opcode
    Exception.__init__(new, f"brick {brick}: {op_name} failed: {exc}")
    return new
