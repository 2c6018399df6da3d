"""Motor physics: speed, friction, backlash, encoder counting."""
from __future__ import annotations

import math

import pytest

from nxt_link.emulator.motor_model import MotorParams, MotorPhysics


def spin(duty: float, ms: int, params: MotorParams | None = None) -> tuple[MotorPhysics, int]:
    m = MotorPhysics(params)
    counts = 0
    for _ in range(ms):
        counts += m.step(duty, True)
    return m, counts


def test_no_load_speed_at_full_power_is_about_170_rpm():
    m, _ = spin(1.0, 1000)
    assert 150 <= m.speed_deg_s / 6.0 <= 175  # rpm (Hurbain: ~170 rpm at 9 V)


def test_speed_is_roughly_linear_in_power():
    half, _ = spin(0.5, 1000)
    full, _ = spin(1.0, 1000)
    assert 0.4 < half.speed_deg_s / full.speed_deg_s < 0.55


def test_static_friction_holds_below_about_seven_percent():
    _, counts = spin(0.06, 1000)
    assert counts == 0
    _, counts = spin(0.10, 1000)
    assert counts > 20


def test_lower_battery_is_slower():
    weak, _ = spin(1.0, 1000, MotorParams(supply_v=7.2))
    full, _ = spin(1.0, 1000)
    assert weak.speed_deg_s < 0.85 * full.speed_deg_s


def test_spin_up_takes_tens_of_milliseconds():
    m = MotorPhysics()
    t63 = next(t for t in range(1, 500) if (m.step(1.0, True), m.speed_deg_s)[1] > 0.63 * 980)
    assert 15 <= t63 <= 60


def test_speed_limit_caps_the_speed():
    m, _ = spin(1.0, 1000, MotorParams(max_speed_deg_s=500.0))
    assert m.speed_deg_s <= 500.0 + 1e-9


def test_encoder_counts_add_up_to_the_angle_without_loss():
    m = MotorPhysics()
    total = 0
    for t in range(3000):
        duty = math.sin(t / 300.0)
        total += m.step(duty, True)
        assert total == math.floor(m.motor_deg + 0.5)


def test_coasting_stops_by_friction_and_braking_stops_faster():
    coast, _ = spin(1.0, 500)
    brake, _ = spin(1.0, 500)
    c0, b0 = coast.motor_deg, brake.motor_deg
    for _ in range(2000):
        coast.step(0.0, False)
        brake.step(0.0, True)  # MOTORON with 0 % duty: short-circuit brake
    assert coast.speed_deg_s == 0.0 and brake.speed_deg_s == 0.0
    assert coast.motor_deg - c0 > 2 * (brake.motor_deg - b0) > 0


def test_backlash_lets_the_output_lag_after_a_reversal():
    m = MotorPhysics(MotorParams(backlash_deg=2.0))
    for _ in range(300):
        m.step(0.3, True)
    assert m.motor_deg - m.output_deg == pytest.approx(2.0)
    for _ in range(600):
        m.step(-0.3, True)
    assert m.motor_deg - m.output_deg == pytest.approx(-2.0)


def test_encoder_after_backlash_counts_the_output():
    m = MotorPhysics(MotorParams(backlash_deg=3.0, encoder_after_backlash=True))
    total = sum(m.step(0.3, True) for _ in range(300))
    assert total == math.floor(m.output_deg + 0.5)
    assert total < math.floor(m.motor_deg + 0.5)


@pytest.mark.parametrize("field, value", [("inertia_kg_m2", 0.0), ("coulomb_nm", -1.0),
                                          ("supply_v", -9.0)])
def test_bad_parameters_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        MotorParams(**{field: value})
