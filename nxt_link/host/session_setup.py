"""Steps 1 to 3 of an execution with one brick: the program and the handshake, the upload of
the setpoints, and the move to the initial configuration.

Everything before the start signal; :class:`~nxt_link.host.session.BrickSession` adds the
start signal, the run, the log and the stop.  Split from it along the protocol's phases
(the module docstring of :mod:`nxt_link.host.session` lists them) to keep each part short.
"""
from __future__ import annotations

from collections.abc import Callable
from functools import partial

from nxt_link.host.session_link import _SessionLink
from nxt_link.host.session_settings import WINDOW, _refusal, _state_name, _with_seq
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import Code, State
from nxt_link.wire.clock import Deadline
from nxt_link.wire.errors import (
    IllegalValueError,
    LinkTimeoutError,
    NoActiveProgramError,
    RequestFailedError,
    StreamError,
)


class _SessionSetup(_SessionLink):
    """Steps 1 to 3 of an execution: the program and the handshake, the upload of the
    setpoints, and the move to the initial configuration."""

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
