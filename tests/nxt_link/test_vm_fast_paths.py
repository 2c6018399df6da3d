"""The emulator's shortcuts change nothing: motor, output port, input ports and screen
against straightforward reference implementations, bit for bit.

The motor and output port step once per simulated millisecond per port, so they
are written out for speed (one function, shortcuts for a motor at rest, for a
plain running port); the input module skips the ports it would leave as they
are; the screen drops only the cells a character overlaps. The
references below are the readable versions they replaced; random command
sequences must leave both in identical states (floats compared exactly), so
any divergence in the arithmetic or its order fails.
"""
from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from nxt_link.emulator.brick_io import FONT_WIDTH, LCD_LINES, LCD_WIDTH, Display
from nxt_link.emulator.input_module import InputPort, step_ports
from nxt_link.emulator.motor_model import MotorParams, MotorPhysics
from nxt_link.emulator.output_module import OutputPort

_DEG = 180.0 / math.pi


class ReferenceMotor(MotorPhysics):
    """The motor step as first written: every quantity recomputed every millisecond."""

    def step(self, duty: float, driven: bool, dt_s: float = 0.001) -> int:
        p = self.params
        w = self.speed_rad_s
        if self.blocked:
            self._finish(0.0, 0.0, dt_s)
            return self._count()
        if driven:
            duty = max(-1.0, min(1.0, duty))
            a = self._k_drive * duty * p.supply_v
            b = self._b_drive
        else:
            a = 0.0
            b = self._b_coast
        if w != 0.0:
            direction = 1.0 if w > 0 else -1.0
        elif a != 0.0:
            direction = 1.0 if a > 0 else -1.0
        else:
            direction = 0.0
        if w == 0.0:
            net = abs(a) - p.load_nm
            if direction == 0.0 or net <= p.static_nm:
                self._finish(0.0, 0.0, dt_s)
                return self._count()
        f = direction * (p.coulomb_nm + p.load_nm)
        j = p.inertia_kg_m2
        if b > 1e-12:
            w_inf = (a - f) / b
            w_new = w_inf + (w - w_inf) * math.exp(-b * dt_s / j)
        else:
            w_new = w + (a - f) * dt_s / j
        if direction != 0.0 and w_new * direction < 0.0:
            w_new = 0.0
        w_new = max(-self._w_max, min(self._w_max, w_new))
        self._finish(w, w_new, dt_s)
        return self._count()

    def _finish(self, w_old: float, w_new: float, dt_s: float) -> None:
        self.speed_rad_s = w_new
        self.motor_deg += 0.5 * (w_old + w_new) * dt_s * _DEG
        gap = self.motor_deg - self.output_deg
        b = self.params.backlash_deg
        if gap > b:
            self.output_deg = self.motor_deg - b
        elif gap < -b:
            self.output_deg = self.motor_deg + b

    def _count(self) -> int:
        angle = self.output_deg if self.params.encoder_after_backlash else self.motor_deg
        total = math.floor(angle + 0.5)
        delta = total - self._encoder_total
        self._encoder_total = total
        return delta


class ReferencePort(OutputPort):
    """The output port step as first written."""

    def step(self) -> None:
        if self.run_state == 0x00:
            if self._duty_pct > 0:
                self._duty_pct = max(0.0, self._duty_pct - 1.0)
            elif self._duty_pct < 0:
                self._duty_pct = min(0.0, self._duty_pct + 1.0)
            driven = self._duty_pct != 0.0 and bool(self.mode & 0x01)
        elif not self.mode & 0x01:
            self._duty_pct = 0.0
            driven = False
        else:
            self._duty_pct = self._commanded_duty()
            driven = True
        counts = self.motor.step(self._duty_pct / 100.0, driven)
        if counts:
            self.tacho_count += counts
            self.block_tacho_count += counts
            self.rotation_count += counts
        self._reg_counts += counts
        self._reg_ms += 1
        if self._target is not None and self.run_state == 0x20 and self.mode & 0x01:
            direction = 1 if self.power > 0 else -1
            if direction * (self.tacho_count - self._target) >= 0:
                self.run_state = 0x00
                self._duty_pct = 0.0


def motor_state(m: MotorPhysics) -> tuple:
    return (m.speed_rad_s, m.motor_deg, m.output_deg, m._encoder_total, m.blocked)


PARAMS = st.builds(MotorParams, load_nm=st.sampled_from([0.0, 0.01, 0.05]),
                   backlash_deg=st.sampled_from([0.0, 2.0, 5.5]),
                   viscous_nm_s_per_rad=st.sampled_from([0.0, 0.0022]),
                   encoder_after_backlash=st.booleans())
# (duty, driven, blocked, milliseconds): held long enough to start, stop and settle
SEGMENTS = st.lists(st.tuples(st.sampled_from([0.0, -0.0, 0.03, 0.08, -0.2, 0.5, -1.0, 1.5]),
                              st.booleans(), st.booleans(), st.integers(1, 150)),
                    min_size=1, max_size=8)


@settings(max_examples=60)
@given(PARAMS, SEGMENTS)
def test_the_motor_step_is_the_reference_bit_for_bit(params, segments):
    fast, ref = MotorPhysics(params), ReferenceMotor(params)
    for duty, driven, blocked, ms in segments:
        fast.blocked = ref.blocked = blocked and ms < 40
        for _ in range(ms):
            assert fast.step(duty, driven) == ref.step(duty, driven)
            assert motor_state(fast) == motor_state(ref)


# a setoutput: (power, mode, regulation mode, run state, tacho limit, reset flags, ms)
COMMANDS = st.lists(st.tuples(
    st.sampled_from([0, 7, 30, -45, 100]), st.sampled_from([0x00, 0x01, 0x03, 0x05, 0x07]),
    st.sampled_from([0, 1, 2]), st.sampled_from([0x00, 0x10, 0x20, 0x40]),
    st.sampled_from([0, 30, 360]), st.sampled_from([0, 0x08, 0x68]), st.integers(1, 300)),
    min_size=1, max_size=6)


@settings(max_examples=60)
@given(COMMANDS)
def test_the_output_port_step_is_the_reference(commands):
    fast, ref = OutputPort(0), ReferencePort(0, None)
    ref.motor = ReferenceMotor()
    for power, mode, reg, run_state, limit, reset, ms in commands:
        for port in (fast, ref):
            port.set_output_state(power, mode, reg, 0, run_state, limit, reset)
        for _ in range(ms):
            fast.step()
            ref.step()
            assert vars_of(fast) == vars_of(ref)
            assert motor_state(fast.motor) == motor_state(ref.motor)


def vars_of(port: OutputPort) -> dict:
    return {k: v for k, v in vars(port).items() if k != "motor"}


class ReferenceDisplay(Display):
    def text(self, x: int, y: int, text: bytes) -> None:
        line = ((63 - y) & 0xF8) // 8 if 0 <= y <= 63 else LCD_LINES
        if line >= LCD_LINES:
            return
        cells = self.cells[line]
        for ch in text:
            if x + FONT_WIDTH >= LCD_WIDTH:
                break
            for col in [c for c in cells if x - FONT_WIDTH < c < x + FONT_WIDTH]:
                del cells[col]
            cells[x] = chr(ch) if 32 <= ch < 127 else "?"
            x += FONT_WIDTH


@settings(max_examples=100)
@given(st.lists(st.tuples(st.integers(-10, 110), st.sampled_from([-1, 0, 7, 8, 20, 56, 63, 64]),
                          st.binary(max_size=20)), max_size=12))
def test_the_screen_draws_as_the_reference(calls):
    fast, ref = Display(), ReferenceDisplay()
    for x, y, text in calls:
        fast.text(x, y, text)
        ref.text(x, y, text)
        assert fast.cells == ref.cells and fast.lines() == ref.lines()


# (port, sensor type or None, mode or None, raw or None, invalid written or None, ms)
INPUT_EVENTS = st.lists(st.tuples(
    st.integers(0, 3), st.sampled_from([None, 0, 1, 3, 5, 7, 9, 10]),
    st.sampled_from([None, 0x00, 0x20, 0x40, 0x80, 0xA0, 0xE0]),
    st.sampled_from([None, 0, 183, 400, 700, 1023]), st.sampled_from([None, True, False]),
    st.integers(1, 60)), max_size=10)


@settings(max_examples=60)
@given(INPUT_EVENTS)
def test_the_input_module_skips_only_ports_it_would_leave_alone(events):
    fast, ref = [InputPort() for _ in range(4)], [InputPort() for _ in range(4)]
    for port, sensor, mode, raw, invalid, ms in events:
        for ports in (fast, ref):
            p = ports[port]
            if sensor is not None:
                p.sensor_type = sensor
            if mode is not None:
                p.sensor_mode = mode
            if raw is not None:
                p.raw = raw
            if invalid is not None:
                p.invalid = invalid
        for _ in range(ms):
            step_ports(fast)
            for p in ref:
                p.step()
            assert fast == ref
