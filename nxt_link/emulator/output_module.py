"""The firmware's output module for one motor port, on top of the motor physics.

What a SETOUTPUTSTATE (or an NXC ``OnFwdEx``/``CoastEx``) changes, and what the
firmware does with it every millisecond (``docs/nxt-protocol.md`` §2.4-§2.7):

* fields reported by GETOUTPUTSTATE: power, mode, regulation mode, turn ratio,
  run state, tacho limit and the three counters TachoCount, BlockTachoCount,
  RotationCount (1 count = 1 degree; each reset by different events);
* MOTORON drives the motor with ``power`` % duty (open loop), or with the
  output of the speed regulator when REGULATED + SPEED (PID every 100 ms on
  the counts per period, 100 % = 100 counts per 100 ms; firmware default gains
  P=3, I=1, D=1). SYNC is reported as set but regulated like SPEED per motor;
* run state IDLE releases the motor: the applied duty decays by 1 %/ms, then
  it coasts; a mode without MOTORON coasts at once;
* tacho limit: the target is *added to the previous target* (the firmware's
  "error correction") until TachoCount is reset or a run-forever command
  clears it; when reached the power is cut and the motor coasts past it
  (run state IDLE, no brake) — hence the overshoot of direct-command moves;
* RAMPUP ramps the duty from 10 % to ``power`` over ``tacho_limit`` degrees
  then runs on; RAMPDOWN ramps from ``power`` to 0 over the limit then idles.

The reported run state is always one of 00/10/20/40 and the mode only uses
bits 01/02/04, which is what nxt-python can parse.
"""
from __future__ import annotations

from nxt_link.emulator.motor_model import MotorParams, MotorPhysics
from nxt_link.wire.telegram import OutputMode, RegulationMode, RunState

__all__ = ["OutputPort", "RESET_NONE", "RESET_COUNT", "RESET_BLOCK_COUNT",
           "RESET_ROTATION_COUNT", "RESET_BLOCKANDTACHO", "RESET_ALL"]

# NXC update-flag reset bits (NBCCommon.h UF_UPDATE_RESET_*)
RESET_NONE = 0x00
RESET_COUNT = 0x08
RESET_BLOCK_COUNT = 0x20
RESET_ROTATION_COUNT = 0x40
RESET_BLOCKANDTACHO = RESET_COUNT | RESET_BLOCK_COUNT
RESET_ALL = RESET_BLOCKANDTACHO | RESET_ROTATION_COUNT

# plain ints on the 1 ms path (enum flag arithmetic costs microseconds per call)
_MOTORON = int(OutputMode.MOTORON)
_REGULATED = int(OutputMode.REGULATED)
_IDLE, _RAMPUP, _RUNNING, _RAMPDOWN = (int(RunState.IDLE), int(RunState.RAMPUP),
                                       int(RunState.RUNNING), int(RunState.RAMPDOWN))
_SPEED, _SYNC = int(RegulationMode.SPEED), int(RegulationMode.SYNC)

REGULATION_PERIOD_MS = 100
_REG_P, _REG_I, _REG_D = 3, 1, 1
# % of duty per count of error: the firmware's exact scaling was not traced; 1/8
# makes the model settle in ~3 periods without oscillating (0.5 oscillates)
_REG_SCALE = 8.0
_MIN_MOVEMENT_PCT = 10


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


class OutputPort:
    """Firmware state of one output port plus its motor."""

    def __init__(self, index: int, motor_params: MotorParams | None = None) -> None:
        self.index = index
        self.motor = MotorPhysics(motor_params)
        self.reset_device()

    @property
    def applied_duty_pct(self) -> float:
        """The signed PWM duty (%) applied in the last millisecond (the IO map's
        ``ActualSpeed``)."""
        return self._duty_pct

    # -- commands ------------------------------------------------------------

    def reset_device(self) -> None:
        """Program start/stop: coast, clear every field and all three counters."""
        self.power = 0
        self.mode = 0
        self.regulation_mode = 0
        self.turn_ratio = 0
        self.run_state = 0
        self.tacho_limit = 0
        self.tacho_count = 0
        self.block_tacho_count = 0
        self.rotation_count = 0
        self._target: int | None = None
        self._duty_pct = 0.0
        self._ramp_from = 0
        self._reg_counts = 0
        self._reg_ms = 0
        self._reg_integral = 0.0
        self._reg_prev_err = 0.0
        self._reg_duty = 0.0

    def reset_counters(self, flags: int) -> None:
        """Apply NXC reset flags (RESET_COUNT, RESET_BLOCK_COUNT, RESET_ROTATION_COUNT)."""
        if flags & RESET_COUNT:
            self.tacho_count = 0
            self._target = None
        if flags & RESET_BLOCK_COUNT:
            self.block_tacho_count = 0
        if flags & RESET_ROTATION_COUNT:
            self.rotation_count = 0

    def set_output_state(self, power: int, mode: int, regulation_mode: int, turn_ratio: int,
                         run_state: int, tacho_limit: int, reset_flags: int = RESET_NONE) -> None:
        """What SETOUTPUTSTATE and the NXC ``setout`` calls do (never resets counters
        unless ``reset_flags`` asks, which only NXC calls do)."""
        self.reset_counters(reset_flags)
        if regulation_mode != self.regulation_mode or not mode & _REGULATED:
            self._reg_integral = 0.0
            self._reg_prev_err = 0.0
            self._reg_counts = 0
            self._reg_ms = 0
            self._reg_duty = float(power)
        self.power = power
        # plain ints: enum flag arithmetic would cost microseconds on the 1 ms path
        self.mode = int(mode) & 0x07
        self.regulation_mode = int(regulation_mode)
        self.turn_ratio = turn_ratio
        self.run_state = int(run_state)
        self.tacho_limit = tacho_limit
        if tacho_limit == 0:
            self._target = None
        elif power != 0 and run_state in (_RUNNING, _RAMPUP, _RAMPDOWN):
            base = self.tacho_count if self._target is None else self._target
            self._target = base + (tacho_limit if power > 0 else -tacho_limit)
        self._ramp_from = self.tacho_count

    # -- 1 ms update ---------------------------------------------------------

    def _regulated_duty(self) -> float:
        if self._reg_ms >= REGULATION_PERIOD_MS:
            err = float(self.power) - self._reg_counts
            self._reg_integral = _clamp(self._reg_integral + err, -100.0, 100.0)
            correction = (_REG_P * err + _REG_I * self._reg_integral
                          + _REG_D * (err - self._reg_prev_err)) / _REG_SCALE
            self._reg_duty = _clamp(self.power + correction, -100.0, 100.0)
            self._reg_prev_err = err
            self._reg_counts = 0
            self._reg_ms = 0
        return self._reg_duty

    def _commanded_duty(self) -> float:
        regulated = (self.mode & _REGULATED
                     and self.regulation_mode in (_SPEED, _SYNC))
        duty = self._regulated_duty() if regulated else float(self.power)
        if self.run_state in (_RAMPUP, _RAMPDOWN) and self.tacho_limit > 0:
            progress = min(1.0, abs(self.tacho_count - self._ramp_from) / self.tacho_limit)
            sign = 1.0 if self.power >= 0 else -1.0
            if self.run_state == _RAMPUP:
                floor = min(_MIN_MOVEMENT_PCT, abs(duty))
                duty = sign * max(floor, abs(duty) * progress)
                if progress >= 1.0:
                    self.run_state = _RUNNING
                    self._target = None
            else:
                duty = duty * (1.0 - progress)
                if progress >= 1.0:
                    self.run_state = _IDLE
                    self._duty_pct = 0.0
                    self._target = None
        return duty

    def step(self) -> None:
        """Advance the port by 1 ms: drive the motor, count, apply the tacho limit."""
        run_state = self.run_state
        mode = self.mode
        if run_state == _IDLE:
            # released: the applied duty decays by 1 %/ms, then the motor coasts
            duty = self._duty_pct
            if duty > 0:
                self._duty_pct = duty = max(0.0, duty - 1.0)
            elif duty < 0:
                self._duty_pct = duty = min(0.0, duty + 1.0)
            driven = duty != 0.0 and bool(mode & _MOTORON)
        elif not mode & _MOTORON:
            self._duty_pct = duty = 0.0
            driven = False
        else:
            if run_state == _RUNNING and not mode & _REGULATED:
                duty = float(self.power)  # _commanded_duty's plain case
            else:
                duty = self._commanded_duty()
            self._duty_pct = duty
            driven = True
        counts = self.motor.step(duty / 100.0, driven)
        if counts:
            self.tacho_count += counts
            self.block_tacho_count += counts
            self.rotation_count += counts
            self._reg_counts += counts
        self._reg_ms += 1
        target = self._target
        if (target is not None and self.run_state == _RUNNING
                and self.mode & _MOTORON):
            direction = 1 if self.power > 0 else -1
            if direction * (self.tacho_count - target) >= 0:
                # limit reached: power cut, the motor coasts past the target
                self.run_state = _IDLE
                self._duty_pct = 0.0
