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
NXC ``#define`` values with the model's constants (:data:`ROBOT_CONSTANTS`).

The model is built in layers, one module each: its constants
(:mod:`~nxt_link.emulator.legolog_constants`), its state with the responses and events it
sends (:mod:`~nxt_link.emulator.legolog_state`), its behaviours
(:mod:`~nxt_link.emulator.legolog_behaviours`) and, here, the loop and the requests.
"""
from __future__ import annotations

from nxt_link.emulator.firmware import ProgramHost
from nxt_link.emulator.input_module import SensorMode, SensorType
from nxt_link.emulator.legolog_behaviours import _LegologBehaviours
from nxt_link.emulator.legolog_constants import (
    MAX_BATCH,
    MAX_SECONDS,
    PORT_LIGHT,
    PORT_TOUCH,
    ROBOT_CONSTANTS,
    SENSOR_SETTLE_MS,
    STATUS_ABORT,
    STATUS_OK,
    STATUS_PANIC,
)
from nxt_link.programs.behaviour_protocol import (
    ACTION_MS,
    CMD_INBOX,
    CONTROL_MS,
    MAX_ARGS,
    PANIC_PERIOD_MS,
    PROTOCOL_VERSION,
    AckCode,
    Behaviour,
    Kind,
)

__all__ = ["LegologProgram", "MAX_BATCH", "ROBOT_CONSTANTS"]


class LegologProgram(_LegologBehaviours):
    """State of one run of ``cplus_legolog.rxe`` (globals of the NXC program)."""

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

