"""Physics of one LEGO 9842 NXT servo motor, stepped in 1 ms ticks like the firmware.

Model (``docs/nxt-protocol.md`` §6.2, all quantities at the output shaft):

* drive: ``u = duty * supply_v``; winding current ``i = (u - Kb*w) / R`` while
  the H-bridge drives (MOTORON, with or without BRAKE: the PWM off-phase is
  approximated by the same linear law, so duty 0 with the motor on is the
  short-circuit brake); no current at all when coasting;
* dynamics: ``J dw/dt = Kt*i - B*w - Tc*sign(w) - T_load``; at rest the motor
  stays put while the net drive torque is below the static friction ``Ts``;
  integrated exactly over each tick for the linear part (stable for any J);
* speed limit: ``|w|`` is clamped to ``max_speed_deg_s``;
* backlash: the output (joint) angle follows the motor angle only once the
  free play of ``+-backlash_deg`` is taken up;
* encoder: 1 count per degree of the motor angle (or of the output angle when
  ``encoder_after_backlash``), whole degrees crossed are added to the
  counters each tick and the fraction carried, so no count is lost;
* ``blocked``: something outside holds the output (a jammed joint, a robot pushing
  against an obstacle): the motor stands still whatever it is driven with, until the
  flag is cleared (set by an environment, see ``Firmware.attach``).

Defaults and their sources are listed in :class:`MotorParams` and
``docs/nxt-link.md``; the inertia and the friction torques are calibration
guesses (no trustworthy published figure), chosen for a 20-50 ms spin-up and
a motor that does not start below about 7 % power.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["MotorParams", "MotorPhysics"]

_DEG = 180.0 / math.pi


@dataclass(frozen=True, slots=True)
class MotorParams:
    """Parameters of the motor model (SI units at the output shaft).

    Attributes:
        supply_v: battery voltage seen by the H-bridge at 100 % duty (9 V:
            six fresh AA cells).
        resistance_ohm: winding resistance R = 6.69 ohm (Watanabe, NXTway-GS).
        kb_v_s_per_rad: back-EMF constant 0.468 V s/rad (Watanabe).
        kt_nm_per_a: torque constant 0.317 N m/A (Watanabe).
        viscous_nm_s_per_rad: viscous friction B = 0.0022 N m s/rad (NXTway-GS).
        coulomb_nm: running (Coulomb) friction; 0.012 N m gives ~165 rpm no-load
            at 9 V, close to Hurbain's 170 rpm (calibration).
        static_nm: breakaway friction; 0.030 N m = 7 % of the 9 V stall torque
            (calibration; the firmware itself assumes >= 10 % is needed).
        inertia_kg_m2: rotor + gears + arm inertia. 6e-4 kg m^2 gives a ~27 ms
            mechanical time constant (assumption: the published 1e-5 is the bare
            rotor and gives 0.4 ms, far faster than a loaded arm).
        backlash_deg: half-width of the gear play (Schoeler: about +-2 degrees).
        max_speed_deg_s: hard speed limit (170 rpm = 1020 deg/s, Hurbain).
        load_nm: constant load torque opposing motion at the output.
        encoder_after_backlash: encoder reads the output angle instead of the
            motor angle (where the encoder sits relative to the play is not
            confirmed; default: before the play, so a P-controller on the
            counts cannot see it).
    """

    supply_v: float = 9.0
    resistance_ohm: float = 6.69
    kb_v_s_per_rad: float = 0.468
    kt_nm_per_a: float = 0.317
    viscous_nm_s_per_rad: float = 0.0022
    coulomb_nm: float = 0.012
    static_nm: float = 0.030
    inertia_kg_m2: float = 6e-4
    backlash_deg: float = 2.0
    max_speed_deg_s: float = 1020.0
    load_nm: float = 0.0
    encoder_after_backlash: bool = False

    def __post_init__(self) -> None:
        for name in ("supply_v", "resistance_ohm", "kb_v_s_per_rad", "kt_nm_per_a",
                     "inertia_kg_m2", "max_speed_deg_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"motor parameter {name} must be > 0")
        for name in ("viscous_nm_s_per_rad", "coulomb_nm", "static_nm", "backlash_deg",
                     "load_nm"):
            if getattr(self, name) < 0:
                raise ValueError(f"motor parameter {name} must be >= 0")


class MotorPhysics:
    """State of one motor: angles, speed and the encoder's integer count."""

    def __init__(self, params: MotorParams | None = None) -> None:
        self.params = params or MotorParams()
        self.motor_deg = 0.0  # angle of the motor's output shaft (before the play)
        self.output_deg = 0.0  # angle of the driven joint (after the play)
        self.speed_rad_s = 0.0
        self.blocked = False
        self._encoder_total = 0  # integer counts delivered so far
        p = self.params
        self._k_drive = p.kt_nm_per_a / p.resistance_ohm  # N m per volt
        self._b_drive = p.kt_nm_per_a * p.kb_v_s_per_rad / p.resistance_ohm + p.viscous_nm_s_per_rad
        self._b_coast = p.viscous_nm_s_per_rad
        self._w_max = p.max_speed_deg_s / _DEG

    @property
    def speed_deg_s(self) -> float:
        return self.speed_rad_s * _DEG

    def step(self, duty: float, driven: bool, dt_s: float = 0.001) -> int:
        """Advance by ``dt_s``; return the encoder counts crossed (signed).

        Args:
            duty: -1..1, applied PWM duty (ignored when not ``driven``).
            driven: the H-bridge drives the winding (MOTORON); False = coast.

        Runs three times per simulated millisecond, so it is written out in one
        function, with a shortcut for a motor at rest that nothing drives (its
        angles, play and encoder count were settled by the previous step).
        """
        w = self.speed_rad_s
        if w == 0.0 and (not driven or duty == 0.0) or self.blocked:
            self.speed_rad_s = 0.0
            return 0
        p = self.params
        if driven:
            if not -1.0 <= duty <= 1.0:
                duty = max(-1.0, min(1.0, duty))
            a = self._k_drive * duty * p.supply_v
            b = self._b_drive
        else:
            a = 0.0
            b = self._b_coast
        # the load opposes motion (or the drive, at rest)
        if w != 0.0:
            direction = 1.0 if w > 0 else -1.0
        elif a != 0.0:
            direction = 1.0 if a > 0 else -1.0
        else:
            direction = 0.0
        w_new = 0.0
        if w != 0.0 or (direction != 0.0 and abs(a) - p.load_nm > p.static_nm):
            f = direction * (p.coulomb_nm + p.load_nm)
            j = p.inertia_kg_m2
            if b > 1e-12:
                w_inf = (a - f) / b
                w_new = w_inf + (w - w_inf) * math.exp(-b * dt_s / j)
            else:
                w_new = w + (a - f) * dt_s / j
            if direction != 0.0 and w_new * direction < 0.0:
                w_new = 0.0  # friction stops the motor; it does not reverse it
            w_max = self._w_max
            if not -w_max <= w_new <= w_max:
                w_new = max(-w_max, min(w_max, w_new))
        else:
            w = 0.0  # at rest, held by static friction
        # the angles (trapezoidal), the play, then the encoder
        self.speed_rad_s = w_new
        self.motor_deg = motor = self.motor_deg + 0.5 * (w + w_new) * dt_s * _DEG
        out = self.output_deg
        gap = motor - out
        play = p.backlash_deg
        if gap > play:
            self.output_deg = out = motor - play
        elif gap < -play:
            self.output_deg = out = motor + play
        total = math.floor((out if p.encoder_after_backlash else motor) + 0.5)
        delta = total - self._encoder_total
        self._encoder_total = total
        return delta
