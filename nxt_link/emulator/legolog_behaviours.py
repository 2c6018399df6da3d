"""The behaviours of the Legolog brick program: the motors, FOLLOW, TURN, TRAY_UP/TRAY_DOWN and
WAIT_BUTTON, their failures, and the requests for more time while one runs.

The second layer of :class:`~nxt_link.emulator.legolog_program.LegologProgram` (the module
docstring there says what each behaviour does); the control laws are the NXC program's, in
integers, line by line.
"""
from __future__ import annotations

import logging

from nxt_link.emulator.legolog_constants import (
    BAR_OFF,
    BAR_ON,
    BASE_POWER,
    DARK,
    FOLLOW_DEFAULT_S,
    KP_DEN,
    KP_NUM,
    LIGHT_TARGET,
    LOST_LEVEL,
    LOST_MM,
    MARKER_END_MM,
    MM_DEN,
    MM_NUM,
    PORT_LEFT,
    PORT_LIGHT,
    PORT_RIGHT,
    PORT_TRAY,
    STATUS_PANIC,
    STUCK_MM,
    STUCK_WINDOW_MS,
    TRAY_KP,
    TRAY_MIN_POWER,
    TRAY_POWER,
    TRAY_TIMEOUT_MS,
    TRAY_TOL,
    TRAY_UP_DEG,
    TURN_MAX_DEG,
    TURN_MIN_DEG,
    TURN_POWER,
)
from nxt_link.emulator.legolog_state import _LegologState
from nxt_link.emulator.output_module import RESET_NONE
from nxt_link.emulator.program_bytes import div
from nxt_link.programs.behaviour_protocol import (
    ACTION_MS,
    MAX_SENDS,
    RESEND_MS,
    Behaviour,
    Status,
)

log = logging.getLogger("nxt_link.emulator.legolog_program")   # the model's one logger


class _LegologBehaviours(_LegologState):
    """The motors and the behaviours of ``cplus_legolog.rxe``."""

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

