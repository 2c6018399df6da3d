"""The plumbing under a :class:`~nxt_link.host.session.BrickSession`: its state, and the
exchange of requests and responses with the brick program over the mailboxes.

Posting a request, polling the response mailbox, telling a lost request from a slow one,
and the silence after which the brick counts as gone: what every step of an execution
uses.  Kept apart from the steps themselves (:mod:`~nxt_link.host.session_setup`,
:mod:`~nxt_link.host.session`) so that each reads on its own.
"""
from __future__ import annotations

import logging
import random
from collections.abc import Callable, Sequence
from functools import partial
from typing import TypeVar

from nxt_link.host.brick import Brick, running_program
from nxt_link.host.session_settings import _QUERY_ID0, PORT_NUMBERS, ControllerSettings, SessionTiming
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import State
from nxt_link.wire import telegram as tg
from nxt_link.wire.clock import Deadline
from nxt_link.wire.errors import (
    EmptyMailboxError,
    LinkTimeoutError,
    NoActiveProgramError,
    StreamError,
    TelegramError,
)

log = logging.getLogger("nxt_link.host.session")   # one logger for the whole session
_T = TypeVar("_T")


class _SessionLink:
    """A session's state and its plumbing: posting requests, polling the response mailbox,
    matching responses to requests, and counting the silence that means the brick has gone
    (see :class:`~nxt_link.host.session.BrickSession`, whose arguments ``__init__`` takes)."""

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

    def _brick_ms(self, seconds: float) -> int:
        return round(seconds * 1000.0 * self.time_scale)

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

