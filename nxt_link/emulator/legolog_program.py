"""Model of the brick program ``nxc/cplus_legolog.nxc``, run by the emulated firmware.

The Legolog event loop (Levesque and Pagnucco, Fig. 2) for a delivery robot, ported
line by line from the NXC source: same constants, same parsing and checks, same
responses, same integer control laws, same 10 ms loop. Only the LCD output is left out.
The firmware calls :meth:`LegologProgram.step` once per millisecond; the loop body runs
when the NXC ``Wait`` would have returned.

The loop, as in the paper::

    if (status == STATUS_ABORT) { stop every behaviour; answer ABORTED; status = STATUS_OK; }
    if (status == STATUS_PANIC) { beep, coast, send PANIC (every second); accept only ABORT; }
    if (status == STATUS_OK)    { handle ACT / CONT / EXOG / HELLO / ABORT messages;
                           step the running behaviour (non-blocking, so polls and aborts
                           are served while it runs); watch the touch sensor for events;
                           ask for more time, re-send it, panic when nobody answers; }

Behaviours (``behaviour_protocol.Behaviour``), on the robot of ``world.Ports``'s
defaults (touch S1, light S3, left wheel B, right wheel C, tray A):

* FOLLOW [max s]: P-controller on the left edge of the line
  (``turn = (light - 45) * 3 / 2``, base power 40); a landmark is a run of bright bars
  across the line (``light >= 75``), counted; 30 mm after the last bar the robot brakes
  and reports the count as ``landmark``. Fails STUCK (less than 10 mm in 0.5 s), LOST
  (on the floor for 150 mm) or TIMEOUT (default 30 s).
* TURN: spin left on the spot until it turned 150 degrees, then on until the sensor
  crossed the line (dark, then back at the edge): it ends on the line's left edge for
  the new direction. LOST if no line within 280 degrees.
* TRAY_UP / TRAY_DOWN: P-control of the tray motor to 90 / 0 degrees (within 3);
  STUCK after 2 s.
* WAIT_BUTTON [max s, 0 = no limit]: until the touch sensor is pressed (``touch`` 1) or
  the time is up (``touch`` 0).

Keeping the two in step is a test: ``tests/nxt_link/test_behaviour_nxc.py`` compares the
NXC ``#define`` values with this module's constants.
"""
from __future__ import annotations

import logging

from nxt_link.emulator.firmware import ProgramHost
from nxt_link.emulator.input_module import SensorMode, SensorType
from nxt_link.emulator.output_module import RESET_NONE
from nxt_link.emulator.program_bytes import MessageBytes, div
from nxt_link.programs.behaviour_protocol import (
    ACTION_MS,
    CMD_INBOX,
    CONTROL_MS,
    EVENT_SLOTS,
    MAX_ARGS,
    MAX_EVENTS_PER_MESSAGE,
    MAX_SENDS,
    PANIC_PERIOD_MS,
    PROTOCOL_VERSION,
    RESEND_MS,
    RESPONSE_QUEUE,  # noqa: F401  (the NXC program defines it: part of ROBOT_CONSTANTS)
    AckCode,
    Behaviour,
    Event,
    Kind,
    Sense,
    State,
    Status,
)

__all__ = ["LegologProgram", "MAX_BATCH", "ROBOT_CONSTANTS"]

log = logging.getLogger(__name__)

MAX_BATCH = 5  # messages handled per loop (the inbox depth)

# Legolog's three statuses (Fig. 2): OK, ABORT, PANIC
STATUS_OK = 0
STATUS_ABORT = 1
STATUS_PANIC = 2

# ports (0-based): touch S1, light S3, left wheel B, right wheel C, tray A
PORT_TOUCH = 0
PORT_LIGHT = 2
PORT_LEFT = 1
PORT_RIGHT = 2
PORT_TRAY = 0

# the robot's control constants (percent, mm, degrees, ms)
LIGHT_TARGET = 45  # the line's edge: half way between line (30) and floor (60)
BAR_ON = 75  # a landmark bar (silver, 90) starts
BAR_OFF = 70  # ... and ends
LOST_LEVEL = 56  # on the floor
LOST_MM = 150
MARKER_END_MM = 30  # no bar for this long after the last one: the landmark is complete
STUCK_WINDOW_MS = 500
STUCK_MM = 10
BASE_POWER = 40
KP_NUM = 3
KP_DEN = 2
MM_NUM = 489  # mm driven per 1000 wheel degrees (56 mm wheel: 175.9 mm per turn)
MM_DEN = 1000
TURN_POWER = 35
TURN_MIN_DEG = 300  # wheel degrees of each wheel for 150 degrees of the robot (axle 112 mm)
TURN_MAX_DEG = 560  # 280 degrees of the robot
DARK = 38  # the sensor is on the line
TRAY_UP_DEG = 90
TRAY_TOL = 3
TRAY_KP = 2
TRAY_POWER = 60
TRAY_MIN_POWER = 15
TRAY_TIMEOUT_MS = 2000
FOLLOW_DEFAULT_S = 30
MAX_SECONDS = 600
DEBOUNCE_LOOPS = 2
SENSOR_SETTLE_MS = 100  # the first loop waits until the sensors' data are valid (20 ms)

#: Every constant the NXC program must #define with the same value (a test compares them).
ROBOT_CONSTANTS = {name: value for name, value in dict(globals()).items()
                   if name.isupper() and isinstance(value, int) and name != "RESET_NONE"}


class LegologProgram(MessageBytes):
    """State of one run of ``cplus_legolog.rxe`` (globals of the NXC program)."""

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

    # -- task main() ------------------------------------------------------------------------

    def step(self, host: ProgramHost) -> None:
        """One VM millisecond: set up, then run the loop body when its Wait has elapsed."""
        self._host = host
        now = host.current_tick()
        if self._next is None:
            # unsigned long next = CurrentTick() + SENSOR_SETTLE_MS; SetSensorType/-Mode ...
            self._next = now + SENSOR_SETTLE_MS
            host.set_sensor(PORT_TOUCH, SensorType.SWITCH, SensorMode.BOOLEAN)
            host.set_sensor(PORT_LIGHT, SensorType.LIGHT_ACTIVE, SensorMode.PCT_FULL_SCALE)
        if now < self._next:
            return
        self.loop_body(now)
        self._next += CONTROL_MS
        now = host.current_tick()
        if self._next <= now:
            self._next = now

    def loop_body(self, now: int) -> None:
        if self.status == STATUS_ABORT:
            self.stop_all()
            self.status = STATUS_OK
            self.send_aborted()
        if self.status == STATUS_PANIC:
            if now >= self.panic_due:
                self.panic_action()
                self.send_panic()
                self.panic_due = now + PANIC_PERIOD_MS
            self.receive(now)  # hope for an abort
        if self.status == STATUS_OK:
            self.receive(now)
            if self.status == STATUS_OK:
                self.watch_touch()
                if self.running != 0:
                    self.step_behaviour(now)
                if self.running != 0:
                    self.more_time(now)

    def receive(self, now: int) -> None:
        assert self._host is not None
        for _ in range(MAX_BATCH):
            status, message = self._host.receive_remote_string(CMD_INBOX, True)
            if status != 0:
                break
            self.msg = message[:-1]  # StrToByteArray drops the trailing NUL
            self.handle_message(now)
            if self.status == STATUS_ABORT:
                break

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

    # -- motors --------------------------------------------------------------------------------

    def drive(self, left: int, right: int) -> None:
        assert self._host is not None
        left = max(-100, min(100, left))
        right = max(-100, min(100, right))
        self._host.on_fwd_ex(PORT_LEFT, left, RESET_NONE)
        self._host.on_fwd_ex(PORT_RIGHT, right, RESET_NONE)

    def brake(self) -> None:
        assert self._host is not None
        self._host.off_ex(PORT_LEFT, RESET_NONE)
        self._host.off_ex(PORT_RIGHT, RESET_NONE)

    def stop_all(self) -> None:
        """stopAllBehaviours(): no behaviour, every motor coasting."""
        assert self._host is not None
        self.running = 0
        self.done_ready = 0
        self.more_part = 0
        self._host.coast_ex(PORT_LEFT, RESET_NONE)
        self._host.coast_ex(PORT_RIGHT, RESET_NONE)
        self._host.coast_ex(PORT_TRAY, RESET_NONE)

    def panic_action(self) -> None:
        """panicAction(): beep, and keep every motor coasting."""
        assert self._host is not None
        self._host.coast_ex(PORT_LEFT, RESET_NONE)
        self._host.coast_ex(PORT_RIGHT, RESET_NONE)
        self._host.coast_ex(PORT_TRAY, RESET_NONE)
        self._host.play_tone(880, 100)

    # -- behaviours -----------------------------------------------------------------------------

    def wheels(self) -> tuple[int, int]:
        assert self._host is not None
        return (self._host.motor_rotation_count(PORT_LEFT) - self.l0,
                self._host.motor_rotation_count(PORT_RIGHT) - self.r0)

    def start_behaviour(self, b: int, now: int) -> None:
        assert self._host is not None
        self.started.append((self.act_seq, b))
        self.running = b
        self.act_t0 = now
        self.phase = 0
        self.l0 = self._host.motor_rotation_count(PORT_LEFT)
        self.r0 = self._host.motor_rotation_count(PORT_RIGHT)
        self.bars = 0
        self.in_bar = 0
        self.last_bar = 0
        self.white_from = -1
        self.win_t = now
        self.win_d = 0
        self.pressed = 0
        self.r_landmark = 0
        self.r_distance = 0
        self.more_part = 0
        self.parts = 0
        self.more_due = now + ACTION_MS
        self.limit_ms = 0
        if b == Behaviour.FOLLOW:
            self.limit_ms = FOLLOW_DEFAULT_S * 1000
            if self.act_args[0] > 0:
                self.limit_ms = self.act_args[0] * 1000
        elif b == Behaviour.WAIT_BUTTON:
            self.limit_ms = self.act_args[0] * 1000
            if self.touch_state == 1:
                self.pressed = 1  # held down already
        elif b == Behaviour.TRAY_UP:
            self.target = TRAY_UP_DEG
        elif b == Behaviour.TRAY_DOWN:
            self.target = 0

    def finish(self, status: int, now: int) -> None:
        assert self._host is not None
        self.r_status = status
        self.r_behaviour = self.running
        self.r_elapsed = now - self.act_t0
        self.r_light = self._host.sensor(PORT_LIGHT)
        self.r_touch = self.touch_state
        if self.running == Behaviour.WAIT_BUTTON:
            self.r_touch = self.pressed
        self.r_tray = self._host.motor_rotation_count(PORT_TRAY)
        self.running = 0
        self.more_part = 0
        self.done_ready = 1
        self.send_done()

    def stuck(self, d: int, now: int) -> bool:
        """Less than STUCK_MM driven in the last STUCK_WINDOW_MS."""
        if now - self.win_t < STUCK_WINDOW_MS:
            return False
        moved = d - self.win_d
        self.win_t = now
        self.win_d = d
        return moved < STUCK_MM

    def step_follow(self, now: int) -> None:
        assert self._host is not None
        light = self._host.sensor(PORT_LIGHT)
        wl, wr = self.wheels()
        d = div((wl + wr) * MM_NUM, 2 * MM_DEN)
        if light >= BAR_ON:
            if self.in_bar == 0:
                self.bars += 1
            self.in_bar = 1
            self.last_bar = d
        elif light < BAR_OFF:
            self.in_bar = 0
        self.r_distance = d
        if self.bars > 0 and self.in_bar == 0 and d - self.last_bar > MARKER_END_MM:
            self.brake()
            self.r_landmark = self.bars
            self.finish(Status.OK, now)
            return
        if light >= LOST_LEVEL and self.in_bar == 0:
            if self.white_from < 0:
                self.white_from = d
            if d - self.white_from > LOST_MM:
                self.brake()
                self.finish(Status.LOST, now)
                return
        else:
            self.white_from = -1
        if self.stuck(d, now):
            self.brake()
            self.finish(Status.STUCK, now)
            return
        if now - self.act_t0 >= self.limit_ms:
            self.brake()
            self.finish(Status.TIMEOUT, now)
            return
        turn = 0
        if light < BAR_OFF:
            turn = div((light - LIGHT_TARGET) * KP_NUM, KP_DEN)
        self.drive(BASE_POWER + turn, BASE_POWER - turn)

    def step_turn(self, now: int) -> None:
        assert self._host is not None
        light = self._host.sensor(PORT_LIGHT)
        wl, wr = self.wheels()
        turned = div(wr - wl, 2)
        if self.phase == 0 and turned >= TURN_MIN_DEG:
            self.phase = 1
        if self.phase == 1 and light < DARK:
            self.phase = 2
        if self.phase == 2 and light >= LIGHT_TARGET:
            self.brake()
            self.finish(Status.OK, now)
            return
        if turned >= TURN_MAX_DEG:
            self.brake()
            self.finish(Status.LOST, now)
            return
        if self.stuck(turned, now):
            self.brake()
            self.finish(Status.STUCK, now)
            return
        self.drive(-TURN_POWER, TURN_POWER)

    def step_tray(self, now: int) -> None:
        assert self._host is not None
        err = self.target - self._host.motor_rotation_count(PORT_TRAY)
        if -TRAY_TOL <= err <= TRAY_TOL:
            self._host.off_ex(PORT_TRAY, RESET_NONE)
            self.finish(Status.OK, now)
            return
        if now - self.act_t0 >= TRAY_TIMEOUT_MS:
            self._host.off_ex(PORT_TRAY, RESET_NONE)
            self.finish(Status.STUCK, now)
            return
        pwr = err * TRAY_KP
        if pwr > TRAY_POWER:
            pwr = TRAY_POWER
        if pwr < -TRAY_POWER:
            pwr = -TRAY_POWER
        if 0 < pwr < TRAY_MIN_POWER:
            pwr = TRAY_MIN_POWER
        if -TRAY_MIN_POWER < pwr < 0:
            pwr = -TRAY_MIN_POWER
        self._host.on_fwd_ex(PORT_TRAY, pwr, RESET_NONE)

    def step_wait(self, now: int) -> None:
        if self.pressed != 0:
            self.finish(Status.OK, now)
            return
        if self.limit_ms > 0 and now - self.act_t0 >= self.limit_ms:
            self.finish(Status.OK, now)

    def step_behaviour(self, now: int) -> None:
        if self.running == Behaviour.FOLLOW:
            self.step_follow(now)
        elif self.running == Behaviour.TURN:
            self.step_turn(now)
        elif self.running in (Behaviour.TRAY_UP, Behaviour.TRAY_DOWN):
            self.step_tray(now)
        elif self.running == Behaviour.WAIT_BUTTON:
            self.step_wait(now)

    def more_time(self, now: int) -> None:
        """Ask for more time every ACTION_MS; re-send unanswered; PANIC after MAX_SENDS."""
        if now < self.more_due:
            return
        if self.more_part == 0:
            self.parts += 1
            self.more_part = self.parts
            self.more_sends = 0
        if self.more_sends >= MAX_SENDS:
            self.status = STATUS_PANIC
            self.panic_due = now
            log.info("brick program: PANIC (MORE_TIME %d of ACT %d not acknowledged)",
                     self.more_part, self.act_seq)
            return
        self.more_sends += 1
        self.send_more(now)
        self.more_due = now + RESEND_MS

    # -- requests ------------------------------------------------------------------------------

    def check_args(self, b: int, nargs: int) -> int:
        if b < Behaviour.FOLLOW or b > Behaviour.WAIT_BUTTON:
            return AckCode.UNKNOWN_BEHAVIOUR
        allowed = 0
        if b == Behaviour.FOLLOW or b == Behaviour.WAIT_BUTTON:
            allowed = 1
        if nargs > allowed:
            return AckCode.BAD_ARGS
        if self.act_args[0] < 0 or self.act_args[0] > MAX_SECONDS:
            return AckCode.BAD_ARGS
        return AckCode.OK

    def handle_act(self, n: int, now: int) -> None:
        if n < 7:
            self.send_ack(AckCode.BAD_LENGTH, 0)
            return
        b = self.rd_u8(5)
        nargs = self.rd_u8(6)
        if nargs > MAX_ARGS or n != 7 + 2 * nargs:
            self.send_ack(AckCode.BAD_LENGTH, b)
            return
        s = self.rq_seq
        if s == self.act_seq and s > 0:
            code = self.act_code
            if code == AckCode.OK:
                code = AckCode.DUPLICATE
            self.send_ack(code, b)
            if self.done_ready != 0:
                self.send_done()
            return
        if s < self.act_seq:
            self.send_ack(AckCode.DUPLICATE, b)
            return
        if s > self.act_seq + 1:
            self.send_ack(AckCode.GAP, b)
            return
        if self.running != 0:
            self.send_ack(AckCode.BUSY, b)
            return
        for i in range(MAX_ARGS):
            self.act_args[i] = 0
        for i in range(nargs):
            self.act_args[i] = self.rd_s16(7 + 2 * i)
        code = self.check_args(b, nargs)
        self.act_seq = s
        self.act_code = code
        self.done_ready = 0
        if code == AckCode.OK:
            self.start_behaviour(b, now)
        self.send_ack(code, b)

    def handle_message(self, now: int) -> None:
        n = self.open_message()
        if not n:
            return
        if self.rq_kind == Kind.ABORT:
            if n == 5:
                self.abort_session = self.rq_session
                self.abort_seq = self.rq_seq
                self.aborts += 1
                self.status = STATUS_ABORT
            return
        if self.status == STATUS_PANIC:
            return  # ignoring all incoming messages but ABORT
        if self.rq_kind == Kind.HELLO:
            if n != 6 or self.rd_u8(5) != PROTOCOL_VERSION:
                self.send_welcome(AckCode.BAD_VERSION)
                return
            if self.rq_session != self.session:
                # a new session: stop, forget the ACTs and the events of the old one
                self.stop_all()
                self.session = self.rq_session
                self.act_seq = 0
                self.act_code = AckCode.OK
                self.ev_first = 1
                self.ev_next = 1
            self.send_welcome(AckCode.OK)
            return
        if self.rq_session != self.session:
            self.bad_messages += 1  # stale traffic of another session
            return
        if self.rq_kind == Kind.ACT:
            self.handle_act(n, now)
            return
        if self.rq_kind == Kind.CONT:
            if n == 6 and self.rq_seq == self.act_seq and self.running != 0 \
                    and self.more_part != 0 and self.rd_u8(5) == self.more_part:
                self.more_part = 0
                self.more_due = now + ACTION_MS
            return
        if self.rq_kind == Kind.EXOG:
            if n != 7:
                self.bad_messages += 1
                return
            upto = self.rd_u16(5)
            if upto >= self.ev_first and upto < self.ev_next:
                self.ev_first = upto + 1
            if self.ev_first < self.ev_next:
                self.send_events()
            else:
                self.send_none()
            return
        self.bad_messages += 1
