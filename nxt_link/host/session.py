"""The PC side of the streaming protocol with one brick (see :mod:`~nxt_link.programs.stream_protocol`).

A :class:`BrickSession` drives one brick through the phases of an execution:

1. :meth:`~BrickSession.open` — make sure ``cplus_follow.rxe`` runs (start it
   if nothing runs), then HELLO with a fresh session id: a reply-required
   MESSAGEWRITE, so a missing program is a clear error, and a WELCOME back
   proves the link and the program both work (Algorithm 2: "check for the
   Bluetooth communication");
2. :meth:`~BrickSession.upload` — CONFIG and the SETPOINTS messages, go-back-N
   with a window of 4, no-reply writes for speed, acknowledgements read from
   the response mailbox; then a QUERY whose checksum must equal the checksum
   of what was sent (the brick holds exactly the setpoints sent, in order);
3. :meth:`~BrickSession.prepare` / :meth:`~BrickSession.wait_ready` — the brick
   moves to the first setpoint (the initial configuration) and holds it;
4. :meth:`~BrickSession.post_go` / :meth:`~BrickSession.poll_go` — the start
   signal, split so the caller can send it to all bricks back to back first and
   then look after all of them in turn (a lost GO is sent again at once, not
   after the other bricks were confirmed);
5. :meth:`~BrickSession.poll_progress` — QUERY polls report progress;
6. :meth:`~BrickSession.read_log` — LOGREAD requests (window of 4), resumable:
   rows already received are kept, a second call fetches only what is missing.

Lost frames, lost, damaged or duplicated messages and acknowledgements and link
drops are recovered here or in :class:`~nxt_link.host.brick.Brick`. A response is
*valid* when its CRC holds and it belongs to this session; the session gives up
only when the brick program has sent no valid response for
``SessionTiming.max_silent_s``, counted from the last valid one (or from the
start of the current step, when the session had been idle before it), or when
the link cannot be reopened. That becomes a one-line
:class:`~nxt_link.wire.errors.LinkError`.

The session also records what tells *when* the brick started (:attr:`start_window`):
the GO copy the brick applied bounds it, and every progress report narrows it
(``logged`` rows at a moment between the QUERY and its answer).
"""
from __future__ import annotations

import logging
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import TypeVar

from nxt_link.host.brick import Brick, running_program
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import Code, State
from nxt_link.wire import telegram as tg
from nxt_link.wire.clock import Deadline
from nxt_link.wire.errors import (
    EmptyMailboxError,
    IllegalValueError,
    LinkError,
    LinkTimeoutError,
    NoActiveProgramError,
    RequestFailedError,
    StreamError,
    TelegramError,
)

__all__ = ["ControllerSettings", "SessionTiming", "BrickSession", "PORT_NUMBERS"]

log = logging.getLogger(__name__)
_T = TypeVar("_T")

PORT_NUMBERS = {"A": 0, "B": 1, "C": 2}
WINDOW = 4  # one below the mailbox depth of 5
_QUERY_ID0 = 0x8000  # ids of unsequenced requests start here, sequenced ones below
MAX_GO_DELAY_MS = 30000  # echoed in an int16 ACK field
GO_COPIES = 3  # at 30 % loss, all three are lost once in 37 ...
GO_RESEND_S = 0.1  # ... so one more copy every 0.1 s until acknowledged


@dataclass(frozen=True, slots=True)
class ControllerSettings:
    """The brick's P-controller: ``power % = kp_num * error_deg / kp_den``.

    Defaults: gain 2 %/degree (little overshoot with the default motor model,
    about 1 degree of steady-state error), full power allowed, the initial
    configuration is reached when every motor is within 3 degrees.
    """

    kp_num: int = 2
    kp_den: int = 1
    max_power: int = 100
    tolerance_deg: int = 3

    def __post_init__(self) -> None:
        if not (1 <= self.kp_num <= 255 and 1 <= self.kp_den <= 255):
            raise ValueError("controller gain: kp_num and kp_den must be in 1..255")
        if not 1 <= self.max_power <= 100:
            raise ValueError("controller max_power must be in 1..100")
        if not 0 <= self.tolerance_deg <= 255:
            raise ValueError("controller tolerance must be in 0..255 degrees")


@dataclass(frozen=True, slots=True)
class SessionTiming:
    """Timeouts of the streaming protocol (on the bricks' clock).

    Attributes:
        ack_timeout_s: no acknowledgement progress for this long -> resend.
        empty_after_s: the response mailbox found empty by a read sent at least
            this long after a request means that the request or its response was
            lost -> resend at once, without waiting for ``ack_timeout_s`` (the
            brick handles its inbox every 10 ms, in the order it arrived).
        poll_gap_s: pause before reading an empty response mailbox again.
        query_interval_s: QUERY period while homing and running; a GO not yet
            acknowledged is sent again this often.
        max_silent_s: no valid response for this long (counted from the last
            one) -> the brick has gone.
        homing_timeout_s: the initial configuration must be reached in time.
        program_start_timeout_s: STARTPROGRAM until the program answers.
    """

    ack_timeout_s: float = 0.6
    poll_gap_s: float = 0.01
    query_interval_s: float = 0.25
    max_silent_s: float = 10.0
    homing_timeout_s: float = 15.0
    program_start_timeout_s: float = 5.0
    empty_after_s: float = 0.05


class BrickSession:
    """One execution's conversation with one brick.

    Args:
        brick: the connected brick.
        ports: port letters, in the order of the values in each row.
        tick_ms: duration of one setpoint row.
        rows: the setpoints (already validated by the caller).
        limits_deg: per port (min, max) the brick enforces again.
        controller: P-controller settings sent in CONFIG.
        timing: protocol timeouts.
        on_event: receives (event, detail) for the execution log.
        session_id: 1..65535; random by default.
        time_scale: the brick's clock runs this many times faster than ours
            (an emulated brick with ``--time-scale``; 1 for real bricks).

    Attributes:
        phase: the last step begun: "connect", "upload", "homing", "start",
            "run", "log", "done" or "stopped".
        state: the brick program's state in its last valid response.
        logged: rows the brick had logged at its last valid response.
        start_window: (earliest, latest) start time of the brick on our clock,
            once GO was acknowledged; progress reports narrow it.
    """

    def __init__(self, brick: Brick, ports: Sequence[str], tick_ms: int,
                 rows: Sequence[Sequence[int]], limits_deg: Sequence[tuple[int, int]],
                 controller: ControllerSettings | None = None,
                 timing: SessionTiming | None = None,
                 on_event: Callable[[str, str], None] | None = None,
                 session_id: int | None = None, *, time_scale: float = 1.0) -> None:
        if not time_scale > 0:
            raise ValueError("time_scale must be > 0")
        self.brick = brick
        self.name = brick.name
        self.ports = tuple(ports)
        self.port_numbers = tuple(PORT_NUMBERS[p] for p in self.ports)
        self.tick_ms = tick_ms
        self.rows = [tuple(r) for r in rows]
        self.limits = tuple(limits_deg)
        self.controller = controller or ControllerSettings()
        self.timing = timing or SessionTiming()
        self.time_scale = time_scale
        self._on_event = on_event
        self.session = session_id or random.SystemRandom().randrange(1, 0x10000)
        self.clock = brick.clock
        self.expected_checksum = sp.setpoint_checksum(v for r in self.rows for v in r)
        self.phase = "connect"
        self._next_seq = 1
        self._next_id = _QUERY_ID0
        self._log_rows: dict[int, tuple[int, ...]] = {}
        self._last_valid: float | None = None
        self.state: int | None = None
        self.logged = 0
        self.retransmissions = 0
        self.damaged_responses = 0
        self._sent_at: dict[int, float] = {}  # unsequenced request id -> first sent
        self._last_post = 0.0
        self._empty_at: float | None = None  # when a read that found the mailbox empty was sent
        self._go_seq: int | None = None
        self._go_start_at = 0.0
        self._go_started = 0.0
        self._go_last_sent = 0.0
        self._go_copies: dict[int, float] = {}  # delay_ms -> when that GO copy was first sent
        self.start_window: tuple[float, float] | None = None
        self._go_window: tuple[float, float] | None = None

    @property
    def go_sent(self) -> bool:
        """GO was written at least once (the brick may have started)."""
        return self._go_seq is not None

    # -- plumbing -------------------------------------------------------------------

    def _event(self, event: str, detail: str = "") -> None:
        log.info("%s: %s %s", self.name, event, detail)
        if self._on_event is not None:
            self._on_event(event, detail)

    def _post(self, req: sp.Request, *, reply: bool = False) -> None:
        self.brick.message_write(sp.CMD_INBOX, sp.encode_request(req), reply=reply)
        self._last_post = self.clock.now()

    def _lost_since(self, posted: float) -> bool:
        """The mailbox was found empty by a read sent long enough after ``posted``: what was
        posted then (or its response) is lost."""
        return self._empty_at is not None and \
            self._empty_at >= posted + self.timing.empty_after_s

    def _poll(self, *, once: bool = False) -> sp.Response | None:
        """Read one valid response of this session, or None (empty box, lost, stale, damaged).

        ``once``: a single MESSAGEREAD attempt, so that a caller with something urgent to
        send (GO before the start time) gets control back after one reply timeout.
        """
        asked = self.clock.now()
        try:
            if once:
                reply = self.brick.request(tg.MessageRead(sp.RESPONSE_MAILBOX, 0, True),
                                           retry=False)
                assert isinstance(reply, tg.MessageReadReply)
                raw = reply.payload
            else:
                raw = self.brick.message_read(sp.RESPONSE_MAILBOX, 0, True)
        except EmptyMailboxError:
            self._empty_at = asked
            return None
        except LinkTimeoutError as exc:
            # the protocol recovers lost reads; only a long silence is fatal (_silent)
            if not once:  # (a single attempt's timeout is already the brick's event)
                self._event("read timeout", str(exc))
            return None
        except NoActiveProgramError:
            self._confirm_program_gone()
            return None
        try:
            resp = sp.decode_response(raw)
        except TelegramError as exc:
            self.damaged_responses += 1
            self._event("damaged response", str(exc))
            return None
        if resp.session != self.session:
            return None
        now = self.clock.now()
        self._last_valid = now
        self.state = resp.state
        if isinstance(resp, sp.Ack):
            self.logged = resp.logged
            if resp.seq in self._sent_at and resp.state in (State.RUNNING, State.DONE):
                self._narrow_start(self._sent_at[resp.seq], now, resp.logged)
        return resp

    def _confirm_program_gone(self) -> None:
        """A reply said "no program"; a damaged status byte can say so too: ask again."""
        try:
            gone = self._running_program() is None
        except LinkTimeoutError:
            return  # the silence check decides
        if gone:
            raise StreamError(f"brick {self.name}: the program {sp.PROGRAM_NAME} is no longer "
                              "running")
        self._event("damaged reply", "a 'no program' status the brick did not confirm")

    def _new_id(self) -> int:
        self._next_id = _QUERY_ID0 + ((self._next_id - _QUERY_ID0 + 1) % 0x7FFF)
        self._sent_at.pop(self._next_id, None)
        return self._next_id

    def _silent(self, since: float) -> None:
        """Give up when no valid response came for ``max_silent_s``, counted from the last
        valid response, or from ``since`` (the start of this step) when that is later."""
        if self._last_valid is not None:
            since = max(since, self._last_valid)
        if self.clock.now() - since <= self.timing.max_silent_s:
            return
        try:
            gone = self._running_program(patient=False) is None
        except LinkTimeoutError:
            gone = False
        if gone:
            raise StreamError(f"brick {self.name}: the program {sp.PROGRAM_NAME} is no longer "
                              "running")
        raise LinkTimeoutError(f"brick {self.name}: no valid answer from the brick program for "
                               f"{self.timing.max_silent_s:g} s")

    def _exchange_unsequenced(self, make: Callable[[int], sp.Request],
                              accept: Callable[[sp.Response], bool]) -> sp.Response:
        """Send an unsequenced request until a matching response arrives."""
        start = self.clock.now()
        ids: set[int] = set()  # a late answer to an earlier copy is as good
        while True:
            rid = self._new_id()
            ids.add(rid)
            self._sent_at[rid] = self.clock.now()
            self._post(make(rid))
            resp = self._await(lambda r: r.seq in ids and accept(r))
            if resp is not None:
                return resp
            self.retransmissions += 1
            self._silent(start)

    def _await(self, accept: Callable[[sp.Response], bool], *, within: float | None = None,
               once: bool = False) -> sp.Response | None:
        """Poll until a response passes ``accept``; None once the acknowledgement timeout
        (or ``within``, when shorter) runs out or the mailbox shows that the request or its
        response was lost. ``once``: each read is a single attempt (see :meth:`_poll`)."""
        wait = self.timing.ack_timeout_s if within is None else min(within, self.timing.ack_timeout_s)
        deadline = Deadline(self.clock, wait)
        posted = self._last_post
        while not deadline.expired():
            resp = self._poll(once=once)
            if resp is None:
                if self._lost_since(posted):
                    return None
                self.clock.sleep(self.timing.poll_gap_s)
            elif accept(resp):
                return resp
        return None

    # -- 1. program and handshake --------------------------------------------------------

    def ensure_program(self, replace: bool = False) -> None:
        """Make sure the brick program runs; start it when nothing runs.

        STARTPROGRAM is not repeated blindly: after a lost or untrusted answer the
        running program is asked for, and the program is started again only when
        nothing runs.
        """
        running = self._running_program()
        if running == sp.PROGRAM_NAME:
            return
        if running is not None:
            if not replace:
                raise StreamError(f"brick {self.name} is running {running!r}, not "
                                  f"{sp.PROGRAM_NAME!r}; stop it on the brick first")
            self.brick.stop_program()
            self.clock.sleep(1.0)  # as nxt-python's MotorControl helper does
        deadline = Deadline(self.clock, self.timing.program_start_timeout_s)
        missing = 0
        while True:
            try:
                self.brick.start_program(sp.PROGRAM_NAME)
                missing = 0
                self._event("program started", sp.PROGRAM_NAME)
            except (IllegalValueError, RequestFailedError):
                missing += 1  # the file is missing, or a damaged status says so: ask twice
                if missing >= 2:
                    raise StreamError(
                        f"brick {self.name} has no {sp.PROGRAM_NAME}: compile nxt_link/programs/nxc/"
                        f"cplus_follow.nxc with nbc and download it (nbc -d ...)") from None
            except LinkTimeoutError as exc:
                self._event("timeout", f"START_PROGRAM: {exc}")  # it may have started
            waited = Deadline(self.clock, 1.0)
            while not waited.expired():
                self.clock.sleep(0.1)
                if self._running_program() == sp.PROGRAM_NAME:
                    return
            if deadline.expired():
                raise StreamError(f"brick {self.name}: {sp.PROGRAM_NAME} did not start within "
                                  f"{self.timing.program_start_timeout_s:g} s")

    def _direct(self, call: Callable[[], _T]) -> _T:
        """A direct command, asked again when the brick gave up on it, until no valid frame
        came for ``max_silent_s`` (the budget of the execution, not of one command)."""
        start = self.clock.now()
        while True:
            try:
                return call()
            except LinkTimeoutError:
                valid = [t for t in (start, self._last_valid, self.brick.last_valid_s)
                         if t is not None]
                if self.clock.now() - max(valid) > self.timing.max_silent_s:
                    raise

    def _running_program(self, patient: bool = True) -> str | None:
        """The running program's name, or None (:func:`~nxt_link.host.brick.running_program`);
        ``patient``: each question is asked again while the brick gives up on it."""
        ask = self.brick.get_current_program_name
        return running_program(partial(self._direct, ask) if patient else ask, sp.PROGRAM_NAME)

    def open(self, *, start_program: bool = True, replace_program: bool = False) -> sp.Welcome:
        """Ensure the program runs, then HELLO until WELCOME. Returns the WELCOME."""
        self.phase = "connect"
        if start_program:
            self.ensure_program(replace_program)
        start = self.clock.now()
        while True:
            hello = sp.Hello(self.session, 0)
            try:
                self._post(hello, reply=True)  # reply required: a missing program is an error
            except NoActiveProgramError:
                if self._running_program() is None:
                    raise StreamError(f"brick {self.name}: no program is running (start "
                                      f"{sp.PROGRAM_NAME} on the brick)") from None
                self._event("damaged reply", "a 'no program' status the brick did not confirm")
            except LinkTimeoutError:
                self._silent(start)
                continue
            resp = self._await(lambda r: isinstance(r, sp.Welcome))
            if isinstance(resp, sp.Welcome):
                if resp.code == Code.BAD_VERSION:
                    raise StreamError(
                        f"brick {self.name}: its program speaks protocol version "
                        f"{resp.version}, this client {sp.PROTOCOL_VERSION}")
                if resp.state == State.IDLE and resp.expected_seq == 1:
                    self._event("link ok", f"session {self.session}, program protocol "
                                           f"v{resp.version}")
                    return resp
                # our random session id is the brick's current one: pick another
                self.session = self.session % 0xFFFF + 1
            self.retransmissions += 1
            self._silent(start)

    def motor_angles(self) -> tuple[int, ...]:
        """The motors' current angles (RotationCount, what the brick program controls).

        GETOUTPUTSTATE replies carry no checksum: each port is asked until two
        consecutive answers agree.
        """
        angles: list[int] = []
        for port in self.port_numbers:
            previous = None
            for _ in range(8):
                value = self._direct(partial(self.brick.get_output_state, port)).rotation_count
                if value == previous:
                    break
                previous = value
            else:
                raise StreamError(f"brick {self.name}: the angle of motor {self.ports[len(angles)]} "
                                  "changes between readings")
            angles.append(value)
        return tuple(angles)

    # -- 2. upload ------------------------------------------------------------------------

    def _messages(self) -> list[sp.Request]:
        c = self.controller
        msgs: list[sp.Request] = [sp.Config(
            self.session, 0, self.port_numbers, len(self.rows), self.tick_ms, c.kp_num, c.kp_den,
            c.max_power, c.tolerance_deg, tuple(lo for lo, _ in self.limits),
            tuple(hi for _, hi in self.limits))]
        per = sp.rows_per_setpoint_message(len(self.ports))
        for first in range(0, len(self.rows), per):
            chunk = self.rows[first:first + per]
            msgs.append(sp.Setpoints(self.session, 0, first, tuple(v for r in chunk for v in r)))
        return msgs

    def _run_sequenced(self, msgs: list[sp.Request],
                       progress: Callable[[int, int], None] | None = None) -> sp.Ack:
        """Deliver ``msgs`` in order exactly once (go-back-N); return the last ACK."""
        base = self._next_seq
        msgs = [_with_seq(m, base + i) for i, m in enumerate(msgs)]
        n = len(msgs)
        acked = 0
        next_i = 0
        last_ack: sp.Ack | None = None
        start = goback_at = self.clock.now()
        gap_armed = True  # one immediate go-back per loss; later GAPs may be stale
        while acked < n:
            while next_i < n and next_i < acked + WINDOW:
                self._post(msgs[next_i])
                next_i += 1
            resp = self._poll()
            now = self.clock.now()
            if isinstance(resp, sp.Ack) and base <= resp.seq < base + n:
                done = min(n, max(0, resp.expected_seq - base))
                if resp.code not in (Code.OK, Code.DUPLICATE, Code.GAP):
                    if resp.seq == base + done:
                        raise StreamError(_refusal(self.name, msgs[done], resp.code))
                    continue
                if done > acked:
                    acked = done
                    last_ack = resp
                    goback_at = now
                    gap_armed = True
                    if progress is not None:
                        progress(acked, n)
                if resp.code == Code.GAP and gap_armed and next_i > acked:
                    next_i = acked  # the brick missed one: go back at once
                    goback_at = now
                    gap_armed = False
                    self.retransmissions += 1
                continue
            if resp is None:
                if now - goback_at > self.timing.ack_timeout_s or (
                        next_i > acked and self._lost_since(max(goback_at, self._last_post))):
                    self._silent(start)
                    next_i = acked  # nothing acknowledged for a while: go back
                    goback_at = now
                    gap_armed = True
                    self.retransmissions += 1
                self.clock.sleep(self.timing.poll_gap_s)
        self._next_seq = base + n
        assert last_ack is not None
        return last_ack

    def upload(self, progress: Callable[[int, int], None] | None = None) -> None:
        """Send CONFIG and all setpoints; verify the brick's checksum of them.

        Args:
            progress: called with (rows acknowledged, rows total).
        """
        self.phase = "upload"
        msgs = self._messages()
        per = sp.rows_per_setpoint_message(len(self.ports))
        total = len(self.rows)

        def report(done_msgs: int, _n: int) -> None:
            if progress is not None:
                progress(min(total, max(0, (done_msgs - 1) * per)), total)

        self._run_sequenced(msgs, report)
        check = self.query()
        if check.rows_stored != total or check.checksum != self.expected_checksum:
            raise StreamError(
                f"brick {self.name} holds {check.rows_stored} rows with checksum "
                f"0x{check.checksum:04X}, sent {total} rows with checksum "
                f"0x{self.expected_checksum:04X}")
        self._event("upload verified", f"{total} rows, checksum 0x{check.checksum:04X}, "
                                       f"{self.retransmissions} retransmission(s)")

    def query(self) -> sp.Ack:
        """QUERY: the brick's state, progress, checksum and current largest error."""
        resp = self._exchange_unsequenced(lambda rid: sp.Query(self.session, rid),
                                          lambda r: isinstance(r, sp.Ack))
        assert isinstance(resp, sp.Ack)
        return resp

    # -- 3. initial configuration ------------------------------------------------------------

    def prepare(self) -> None:
        """PREPARE: the brick starts moving to the first setpoint."""
        self.phase = "homing"
        self._run_sequenced([sp.Prepare(self.session, 0)])
        self._event("homing", f"to {self.rows[0]}")

    def wait_ready(self) -> None:
        """Poll until the brick holds the initial configuration (or fail with its error)."""
        deadline = Deadline(self.clock, self.timing.homing_timeout_s)
        while True:
            ack = self.query()
            if ack.state == State.READY:
                self._event("ready", f"largest error {ack.value} deg")
                return
            if ack.state != State.HOMING:
                raise StreamError(f"brick {self.name}: unexpected state "
                                  f"{_state_name(ack.state)} while homing")
            if deadline.expired():
                raise StreamError(
                    f"brick {self.name} did not reach its initial configuration within "
                    f"{self.timing.homing_timeout_s:g} s (still {ack.value} deg off)")
            self.clock.sleep(self.timing.query_interval_s)

    # -- 4. start signal --------------------------------------------------------------------------

    def _brick_ms(self, seconds: float) -> int:
        return round(seconds * 1000.0 * self.time_scale)

    def post_go(self, start_at: float, copies: int = GO_COPIES) -> None:
        """Write GO (no reply: fast) telling the brick to start at ``start_at`` (our clock).

        Several copies go out back to back: the brick applies the first it gets and
        acknowledges the others as duplicates, so one lost copy costs nothing, while
        finding out that a lone copy was lost can take longer than the time left.
        """
        self.phase = "start"
        if self._go_seq is None:
            self._go_seq = self._next_seq
            self._go_started = self.clock.now()
        self._go_start_at = start_at
        now = self.clock.now()
        delay_ms = max(0, min(MAX_GO_DELAY_MS, self._brick_ms(start_at - now)))
        self._go_copies.setdefault(delay_ms, now)
        for _ in range(copies):
            self._post(sp.Go(self.session, self._go_seq, delay_ms))
        self._go_last_sent = now
        self._event("start sent", f"GO seq {self._go_seq}, start in {delay_ms} ms"
                    + (f" ({copies} copies)" if copies > 1 else ""))

    def poll_go(self) -> float | None:
        """One look for GO's acknowledgement; GO is sent again when it is overdue.

        Returns:
            None while unacknowledged; then the latest time (our clock) at which
            this brick can have started. The ACK echoes the delay of the copy
            the brick applied, which identifies when that copy was sent (s); the
            brick started at max(T, s) plus that copy's one-way delay, which is
            at most the time from s to the acknowledgement.
        """
        assert self._go_seq is not None, "post_go first"
        resp = self._poll(once=True)
        now = self.clock.now()
        if isinstance(resp, sp.Ack) and resp.seq == self._go_seq:
            if resp.code in (Code.OK, Code.DUPLICATE):
                self._next_seq = self._go_seq + 1
                sent = self._go_copies.get(resp.value, min(self._go_copies.values()))
                earliest = max(self._go_start_at, sent) - 0.001 / self.time_scale
                latest = max(self._go_start_at, sent) + (now - sent) + 0.001 / self.time_scale
                self._go_window = (earliest, latest)
                self.start_window = (max(earliest, self.start_window[0]),
                                     min(latest, self.start_window[1])) \
                    if self.start_window else self._go_window
                self._event("start acked", f"GO seq {self._go_seq}, applied the copy with "
                                           f"{resp.value} ms delay")
                self.phase = "run"
                return latest
            if resp.code != Code.GAP:
                raise StreamError(_refusal(self.name, sp.Go(self.session, self._go_seq),
                                           resp.code))
        if resp is None:
            # before the start time a copy goes out every GO_RESEND_S: some copy must arrive
            # in time, and copies cost nothing (the brick applies the first it gets)
            every = GO_RESEND_S if now < self._go_start_at else min(
                self.timing.ack_timeout_s, self.timing.query_interval_s)
            if now - self._go_last_sent > every or self._lost_since(self._go_last_sent):
                self._silent(self._go_started)
                self.retransmissions += 1
                self.post_go(self._go_start_at, copies=1)
            self.clock.sleep(self.timing.poll_gap_s)
        return None

    def confirm_go(self) -> float:
        """Wait for GO's acknowledgement (resending GO with the time left); see poll_go."""
        while True:
            latest = self.poll_go()
            if latest is not None:
                return latest

    def _narrow_start(self, sent: float, answered: float, logged: int) -> None:
        """A QUERY sent at ``sent`` and answered by ``answered`` found ``logged`` rows.

        The brick handled it at some p in [sent, answered]: at p, ``logged`` ticks had
        ended (p >= t0 + logged * tick) and, unless all were, tick ``logged`` had not
        ended at the brick's previous control step (p < t0 + (logged + 1) * tick + a
        loop or two). So t0 lies in (sent - (logged + 1) * tick - slack, answered -
        logged * tick].
        """
        if self._go_window is None:
            return
        tick = self.tick_ms / 1000.0 / self.time_scale
        lo, hi = self.start_window or self._go_window
        if logged >= 1:
            hi = min(hi, answered - logged * tick)
        if logged < len(self.rows):
            slack = 2 * sp.CONTROL_MS / 1000.0 / self.time_scale
            lo = max(lo, sent - (logged + 1) * tick - slack)
        if lo <= hi:
            self.start_window = (lo, hi)
        elif self.start_window != self._go_window:
            # progress reports that contradict each other (a brick clock that does not keep
            # time with ours): trust only the start signal
            self._event("start window", "progress reports disagree with the clock; "
                                        "using the start signal's bound")
            self.start_window = self._go_window

    # -- 5. run ----------------------------------------------------------------------------------------

    def poll_progress(self) -> sp.Ack:
        """One QUERY while running: ``logged`` rows so far, state DONE at the end."""
        ack = self.query()
        if ack.state not in (State.RUNNING, State.DONE):
            raise StreamError(f"brick {self.name}: state {_state_name(ack.state)} while running")
        return ack

    # -- 6. log -------------------------------------------------------------------------------------------

    @property
    def log_rows(self) -> dict[int, tuple[int, ...]]:
        """The measured rows read back so far, by row number."""
        return dict(self._log_rows)

    def read_log(self, progress: Callable[[int, int], None] | None = None,
                 rows: int | None = None) -> tuple[tuple[int, ...], ...]:
        """LOGREAD the measured rows 0 .. ``rows`` - 1 (all by default); resumable.

        Returns one row per tick. Rows already received are kept, so after an
        interruption a second call fetches only what is missing.
        """
        self.phase = "log"
        n = len(self.rows) if rows is None else max(0, min(rows, len(self.rows)))
        per = sp.rows_per_log_message(len(self.ports))
        chunks = [(f, min(per, n - f)) for f in range(0, n, per)]
        missing = [c for c in chunks if not all(r in self._log_rows for r in range(c[0], c[0] + c[1]))]
        outstanding: dict[int, float] = {}  # first_row of a requested chunk -> sent at
        ids: set[int] = set()
        start = self.clock.now()
        k = len(self.ports)
        while missing or outstanding:
            now = self.clock.now()
            while missing and len(outstanding) < WINDOW:
                first, count = missing.pop(0)
                rid = self._new_id()
                ids.add(rid)
                self._post(sp.LogRead(self.session, rid, first, count))
                outstanding[first] = now
            resp = self._poll()
            if isinstance(resp, sp.LogData) and resp.seq in ids:
                # self-describing: a late answer to an earlier request is as good
                got = len(resp.values) // k
                for i in range(got):
                    if resp.first_row + i < n:
                        self._log_rows[resp.first_row + i] = resp.values[i * k:(i + 1) * k]
                outstanding.pop(resp.first_row, None)
                missing = [c for c in missing if not all(
                    r in self._log_rows for r in range(c[0], c[0] + c[1]))]
                if progress is not None:
                    progress(sum(1 for r in self._log_rows if r < n), n)
                continue
            if isinstance(resp, sp.Ack) and resp.seq in ids and resp.code != Code.OK:
                raise StreamError(f"brick {self.name} refused LOGREAD: "
                                  f"{Code(resp.code).name.lower().replace('_', ' ')} "
                                  f"(it logged {resp.logged} of {n} rows)")
            if resp is None:
                lost = self._lost_since(self._last_post)
                for first, sent in list(outstanding.items()):
                    if lost or now - sent > self.timing.ack_timeout_s:
                        del outstanding[first]
                        missing.insert(0, next(c for c in chunks if c[0] == first))
                        self.retransmissions += 1
                self._silent(start)
                self.clock.sleep(self.timing.poll_gap_s)
        self._event("log read", f"{n} rows; {self.retransmissions} message(s) sent again and "
                                f"{self.damaged_responses} damaged response(s) in all")
        if rows is None:
            self.phase = "done"
        return tuple(self._log_rows[r] for r in range(n))

    def post_stop(self) -> None:
        """Write STOP now without waiting for anything (stopping several bricks at once)."""
        rid = self._new_id()
        self._post(sp.Stop(self.session, rid))

    def stop(self, timeout_s: float | None = None) -> bool:
        """STOP: the brick program coasts the motors (used when aborting).

        Sends STOP until the brick acknowledges it, at most ``timeout_s`` (default
        ``max_silent_s``); the acknowledgement updates :attr:`logged`. Returns whether
        the brick acknowledged; never raises a link error.

        Every wait is bounded by what is left of ``timeout_s`` and each read is a single
        attempt, so a silent brick holds the stop up by at most one reply timeout beyond
        ``timeout_s`` (a Ctrl-C must end within its limit), not by a read's retries. What
        the link itself may take (a reconnect) is not bounded here: that is the shutdown
        watchdog's case.
        """
        deadline = Deadline(self.clock, self.timing.max_silent_s if timeout_s is None
                            else timeout_s)
        ids: set[int] = set()
        try:
            while not deadline.expired():
                rid = self._new_id()
                ids.add(rid)
                self._post(sp.Stop(self.session, rid))
                resp = self._await(lambda r: isinstance(r, sp.Ack) and r.seq in ids,
                                   within=deadline.remaining(), once=True)
                if isinstance(resp, sp.Ack):
                    self.phase = "stopped"
                    self._event("stopped", f"{resp.logged} rows logged")
                    return True
        except LinkError as exc:  # the link may be the reason we are stopping
            self._event("stop failed", str(exc))
        return False


def _with_seq(req: sp.Request, seq: int) -> sp.Request:
    return replace(req, seq=seq)


def _state_name(state: int) -> str:
    try:
        return State(state).name
    except ValueError:
        return str(state)


def _refusal(brick: str, req: sp.Request, code: int) -> str:
    try:
        reason = Code(code).name.lower().replace("_", " ")
    except ValueError:
        reason = f"code {code}"
    what = req.kind.name
    if isinstance(req, sp.Setpoints):
        what = f"SETPOINTS from row {req.first_row}"
    return f"brick {brick} refused {what}: {reason}"
