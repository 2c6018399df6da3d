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

:class:`BrickSession` is built in layers, one module each: its settings
(:mod:`~nxt_link.host.session_settings`), its state and plumbing
(:mod:`~nxt_link.host.session_link`), steps 1-3 (:mod:`~nxt_link.host.session_setup`) and,
here, steps 4-6 and the stop.  Import the public names from this module.
"""
from __future__ import annotations

import logging
from collections.abc import Callable

from nxt_link.host.session_settings import (
    GO_COPIES,
    GO_RESEND_S,
    MAX_GO_DELAY_MS,
    PORT_NUMBERS,
    WINDOW,
    ControllerSettings,
    SessionTiming,
    _refusal,
    _state_name,
)
from nxt_link.host.session_setup import _SessionSetup
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import Code, State
from nxt_link.wire.clock import Deadline
from nxt_link.wire.errors import (
    LinkError,
    StreamError,
)

__all__ = ["ControllerSettings", "SessionTiming", "BrickSession", "PORT_NUMBERS"]

log = logging.getLogger(__name__)


class BrickSession(_SessionSetup):
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

    # -- 4. start signal --------------------------------------------------------------------------

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

