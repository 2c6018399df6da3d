"""The state of one run of the Legolog brick program and what it sends: its globals, the
responses it writes (WELCOME, ACK, MORE, DONE, EVENTS, ...) and the touch-sensor events.

The first layer of :class:`~nxt_link.emulator.legolog_program.LegologProgram`, ported from
``nxc/cplus_legolog.nxc`` like the rest; split from the model's loop so that each part stays
short.
"""
from __future__ import annotations

from nxt_link.emulator.legolog_constants import DEBOUNCE_LOOPS, PORT_TOUCH, STATUS_OK, STATUS_PANIC
from nxt_link.emulator.program_bytes import MessageBytes, div
from nxt_link.programs.behaviour_protocol import (
    ACTION_MS,
    EVENT_SLOTS,
    MAX_ARGS,
    MAX_EVENTS_PER_MESSAGE,
    PROTOCOL_VERSION,
    AckCode,
    Behaviour,
    Event,
    Kind,
    Sense,
    State,
)


class _LegologState(MessageBytes):
    """The globals of one run of ``cplus_legolog.rxe``, and the responses and events it sends."""

    def __init__(self) -> None:
        super().__init__()
        self.status = STATUS_OK
        self.session = -1
        self.act_seq = 0  # last ACT started (or refused) in this session
        self.act_code: int = AckCode.OK  # the ACK it got
        self.running = 0  # behaviour running, 0: none
        self.act_t0 = 0
        self.act_args = [0] * MAX_ARGS
        self.done_ready = 0  # the DONE of act_seq can be sent again
        self.r_status = 0
        self.r_behaviour = 0
        self.r_elapsed = 0
        self.r_landmark = 0
        self.r_light = 0
        self.r_touch = 0
        self.r_tray = 0
        self.r_distance = 0
        self.more_part = 0  # MORE_TIME waiting for its CONT (0: none)
        self.parts = 0
        self.more_sends = 0
        self.more_due = 0
        self.aborts = 0
        self.abort_session = 0
        self.abort_seq = 0
        self.panic_due = 0
        self.ev_code = [0] * EVENT_SLOTS
        self.ev_first = 1  # number of the oldest event kept
        self.ev_next = 1  # number of the next event
        self.ev_lost = 0
        self.touch_state = 0
        self.touch_cnt = 0
        self.pressed = 0  # a press during WAIT_BUTTON
        # behaviour state
        self.phase = 0
        self.l0 = 0
        self.r0 = 0
        self.bars = 0
        self.in_bar = 0
        self.last_bar = 0
        self.white_from = -1
        self.win_t = 0
        self.win_d = 0
        self.limit_ms = 0
        self.target = 0
        self.started: list[tuple[int, int]] = []  # (ACT, behaviour) started: inspection only
        self._next: int | None = None

    # -- byte helpers -------------------------------------------------------------------------

    def wr_32(self, i: int, v: int) -> None:
        self.wr_16(i, v & 0xFFFF)
        self.wr_16(i + 2, div(v, 65536) & 0xFFFF)

    # -- responses ------------------------------------------------------------------------------

    def state(self) -> int:
        if self.status == STATUS_PANIC:
            return State.PANIC
        if self.running != 0:
            return State.RUNNING
        return State.IDLE

    def begin(self, kind: int, length: int, session: int, seq: int) -> None:
        self.out = bytearray(length)
        self.wr_u8(0, kind)
        self.wr_16(1, session)
        self.wr_16(3, seq)
        self.wr_u8(5, self.state())

    def send_welcome(self, code: int) -> None:
        self.begin(Kind.WELCOME, 16, self.rq_session, self.rq_seq)
        self.wr_u8(6, PROTOCOL_VERSION)
        self.wr_u8(7, code)
        self.wr_16(8, self.act_seq)
        self.wr_16(10, self.aborts)
        self.wr_16(12, ACTION_MS)
        self.send_out(14)

    def send_ack(self, code: int, behaviour: int) -> None:
        self.begin(Kind.ACK, 10, self.session, self.rq_seq)
        self.wr_u8(6, code)
        self.wr_u8(7, behaviour)
        self.send_out(8)

    def send_more(self, now: int) -> None:
        self.begin(Kind.MORE_TIME, 13, self.session, self.act_seq)
        self.wr_u8(6, self.more_part)
        self.wr_32(7, now - self.act_t0)
        self.send_out(11)

    def send_done(self) -> None:
        n = 3
        if self.r_behaviour == Behaviour.FOLLOW:
            n = 5
        self.begin(Kind.DONE, 15 + 3 * n, self.session, self.act_seq)
        self.wr_u8(6, self.r_status)
        self.wr_u8(7, self.r_behaviour)
        self.wr_32(8, self.r_elapsed)
        self.wr_u8(12, n)
        self.wr_u8(13, Sense.LIGHT)
        self.wr_16(14, self.r_light)
        self.wr_u8(16, Sense.TOUCH)
        self.wr_16(17, self.r_touch)
        self.wr_u8(19, Sense.TRAY)
        self.wr_16(20, self.r_tray)
        if n == 5:
            self.wr_u8(22, Sense.LANDMARK)
            self.wr_16(23, self.r_landmark)
            self.wr_u8(25, Sense.DISTANCE)
            self.wr_16(26, self.r_distance)
        self.send_out(13 + 3 * n)

    def send_events(self) -> None:
        n = self.ev_next - self.ev_first
        if n > MAX_EVENTS_PER_MESSAGE:
            n = MAX_EVENTS_PER_MESSAGE
        self.begin(Kind.EVENTS, 13 + 2 * n, self.session, self.rq_seq)
        self.wr_16(6, self.ev_first)
        self.wr_16(8, self.ev_lost)
        self.wr_u8(10, n)
        for i in range(n):
            self.wr_u8(11 + 2 * i, self.ev_code[(self.ev_first + i) % EVENT_SLOTS])
            self.wr_u8(12 + 2 * i, 0)  # no arguments
        self.send_out(11 + 2 * n)

    def send_none(self) -> None:
        self.begin(Kind.NONE, 12, self.session, self.rq_seq)
        self.wr_16(6, self.ev_next)
        self.wr_16(8, self.ev_lost)
        self.send_out(10)

    def send_aborted(self) -> None:
        self.begin(Kind.ABORTED, 12, self.abort_session, self.abort_seq)
        self.wr_16(6, self.aborts)
        self.wr_16(8, self.act_seq)
        self.send_out(10)

    def send_panic(self) -> None:
        self.begin(Kind.PANIC, 11, self.session, self.act_seq)
        self.wr_16(6, self.aborts)
        self.wr_u8(8, self.running)
        self.send_out(9)

    # -- events --------------------------------------------------------------------------------

    def push_event(self, code: int) -> None:
        if self.ev_next - self.ev_first >= EVENT_SLOTS:
            self.ev_lost += 1
            return
        self.ev_code[self.ev_next % EVENT_SLOTS] = code
        self.ev_next += 1

    def watch_touch(self) -> None:
        assert self._host is not None
        t = self._host.sensor(PORT_TOUCH)
        if t == self.touch_state:
            self.touch_cnt = 0
            return
        self.touch_cnt += 1
        if self.touch_cnt < DEBOUNCE_LOOPS:
            return
        self.touch_cnt = 0
        self.touch_state = t
        if t == 0:
            return
        if self.running == Behaviour.WAIT_BUTTON:
            self.pressed = 1  # the behaviour consumes the press
        else:
            self.push_event(Event.BUTTON)

