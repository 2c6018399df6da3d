"""The firmware's input module for one sensor port: from the A/D reading to the values.

What the NXT firmware (``c_input.c``, ``cInputCtrl`` every millisecond) computes for the
passive and light sensors, which is what GETINPUTVALUES reports and what an NXC program
reads (``SensorRaw``, ``SensorNormalized``, ``Sensor``):

* ``raw`` — the 10-bit A/D value (0..1023) the sensor produces; the *environment* sets
  it (a :class:`~nxt_link.world.World`, or a test). A released touch sensor reads 1023,
  a pressed one about 183; a light sensor reads *lower* the brighter the surface;
* ``normalized`` — for light sensors (types 5, 6) ``cInputCalcFullScale(raw, 200, 68,
  inverted)``: ``1023 - min(1023, (raw - 200) * 100 / 68)``; for the others the raw value;
* ``boolean`` — ``normalized <= 460`` (45 % of full scale; the firmware tests
  ``> THRESHOLD_FALSE`` first, so ``THRESHOLD_TRUE`` never matters with slope 0);
* ``scaled`` by mode (high three bits of ``sensor_mode``): RAW -> normalized; BOOLEAN ->
  boolean; TRANSITIONCNT / PERIODCOUNTER -> counts of boolean changes (debounced 100 ms);
  PCTFULLSCALE -> ``normalized * 100 / 1023``; CELSIUS / FAHRENHEIT as the firmware;
  ANGLESTEPS (the legacy rotation sensor) is not modelled (scaled stays 0);
* ``invalid`` — after a type change the data are invalid for 20 ms
  (``INVALID_RELOAD_NORMAL``), after a mode change until the next sample.

Sensor values of type NO_SENSOR stay 0; I2C types (10, 11) are not modelled.
The state of one port is one object, :class:`InputPort`, which a VM or a program model
reads as its input port.

>>> p = InputPort()
>>> p.set_type_and_mode(SensorType.LIGHT_ACTIVE, SensorMode.PCTFULLSCALE)
>>> p.raw = light_percent_to_raw(45)
>>> for _ in range(21): p.step()
>>> p.valid, p.scaled
(True, 45)
"""
from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = ["SensorType", "SensorMode", "InputPort", "light_percent_to_raw",
           "TOUCH_RAW_PRESSED", "TOUCH_RAW_RELEASED", "NO_OF_INPUTS"]

NO_OF_INPUTS = 4
SENSOR_RESOLUTION = 1023
THRESHOLD_FALSE = SENSOR_RESOLUTION * 45 // 100  # 460
DEBOUNCE_RELOAD = 100
INVALID_RELOAD_NORMAL = 20
# light sensor full-scale mapping (c_input.c: NEWLIGHTSENSORMIN/-PCTDYN with VCC 5000 mV)
LIGHT_ZERO = 800 // (5000 // 1023)  # 200
LIGHT_MAX = (1023 * 4400) // 5000  # 900
LIGHT_PCT_DYN = ((LIGHT_MAX - LIGHT_ZERO) * 100) // 1023  # 68
# reflection (RCX light, type 3)
REFLECTION_ZERO = 1906 // (5000 // 1023)  # 476
REFLECTION_PCT_DYN = ((((1023 * 4398) // 5000) - REFLECTION_ZERO) * 100) // 1023  # 39

TOUCH_RAW_PRESSED = 183
TOUCH_RAW_RELEASED = 1023


class SensorType(enum.IntEnum):
    NO_SENSOR = 0x00
    SWITCH = 0x01  # touch sensor
    TEMPERATURE = 0x02
    REFLECTION = 0x03
    ANGLE = 0x04
    LIGHT_ACTIVE = 0x05
    LIGHT_INACTIVE = 0x06
    SOUND_DB = 0x07
    SOUND_DBA = 0x08
    CUSTOM = 0x09
    LOWSPEED = 0x0A
    LOWSPEED_9V = 0x0B
    HIGHSPEED = 0x0C


class SensorMode(enum.IntEnum):
    RAW = 0x00
    BOOLEAN = 0x20
    TRANSITIONCNT = 0x40
    PERIODCOUNTER = 0x60
    PCTFULLSCALE = 0x80
    CELSIUS = 0xA0
    FAHRENHEIT = 0xC0
    ANGLESTEPS = 0xE0


MODE_MASK = 0xE0
SLOPE_MASK = 0x1F


def _full_scale(raw: int, zero: int, pct: int) -> int:
    """``cInputCalcFullScale`` with inversion (light and reflection sensors)."""
    v = raw - zero if raw >= zero else 0
    v = (v * 100) // pct
    if v > SENSOR_RESOLUTION:
        v = SENSOR_RESOLUTION
    return SENSOR_RESOLUTION - v


def light_percent_to_raw(percent: float) -> int:
    """The A/D value for which a light sensor in PCTFULLSCALE mode reads ``percent``.

    The inverse of the firmware's mapping, aimed at the middle of the percent's bucket
    (the firmware truncates), so a whole percent comes back unchanged and a fractional
    one comes back rounded to the nearest.
    """
    percent = min(100.0, max(0.0, percent))
    normalized = (percent + 0.5) * SENSOR_RESOLUTION / 100.0
    raw = LIGHT_ZERO + (SENSOR_RESOLUTION - normalized) * LIGHT_PCT_DYN / 100.0
    return int(round(min(1023.0, max(0.0, raw))))


@dataclass(slots=True)
class InputPort:
    """One input port: configuration, the A/D value and what the firmware derives from it.

    Attributes:
        sensor_type, sensor_mode: as set by SETINPUTMODE or an NXC ``SetSensorType/Mode``.
        raw: A/D value (0..1023), set by the environment.
        normalized, scaled, boolean: computed by :meth:`step` as the firmware does.
        invalid: data not valid yet (GETINPUTVALUES ``valid`` is its negation).
    """

    sensor_type: int = 0
    sensor_mode: int = 0
    raw: int = TOUCH_RAW_RELEASED
    normalized: int = 0
    scaled: int = 0
    boolean: bool = False
    invalid: bool = True
    invalid_timer: int = INVALID_RELOAD_NORMAL
    old_type: int = 0
    debounce: int = 0
    edge_count: int = 0
    old_normalized: int = 0

    @property
    def valid(self) -> bool:
        return not self.invalid

    def set_type_and_mode(self, sensor_type: int, sensor_mode: int) -> None:
        """SETINPUTMODE / NXC SetSensorType+SetSensorMode: the data become invalid."""
        self.sensor_type = int(sensor_type)
        self.sensor_mode = int(sensor_mode)
        self.invalid = True

    def reset_scaled(self) -> None:
        """RESETINPUTSCALEDVALUE / NXC ResetSensor: counters start from zero."""
        self.scaled = 0
        self.edge_count = 0

    def step(self) -> None:
        """One millisecond of ``cInputCtrl`` for this port."""
        if self.sensor_type != self.old_type:
            self.debounce = 0
            self.edge_count = 0
            self.invalid_timer = INVALID_RELOAD_NORMAL
            self.invalid = True
            self.old_type = self.sensor_type
        elif self.invalid_timer:
            self.invalid_timer -= 1
            if self.invalid_timer == 0:
                self.invalid = False
        else:
            self.invalid = False
        if not self.invalid:
            self._calc()

    def _calc(self) -> None:
        t = self.sensor_type
        if t in (SensorType.LIGHT_ACTIVE, SensorType.LIGHT_INACTIVE):
            value = _full_scale(self.raw, LIGHT_ZERO, LIGHT_PCT_DYN)
        elif t == SensorType.REFLECTION:
            value = _full_scale(self.raw, REFLECTION_ZERO, REFLECTION_PCT_DYN)
        elif t in (SensorType.SWITCH, SensorType.TEMPERATURE, SensorType.ANGLE,
                   SensorType.SOUND_DB, SensorType.SOUND_DBA, SensorType.CUSTOM):
            value = self.raw
        else:
            return  # NO_SENSOR and digital sensors: no analogue values
        self._value(value)

    def _value(self, new: int) -> None:
        """``cInputCalcSensorValue`` (absolute measure, slope 0)."""
        present = new <= THRESHOLD_FALSE
        self.normalized = new
        mode = self.sensor_mode & MODE_MASK
        if mode == SensorMode.RAW:
            self.scaled = new
        elif mode == SensorMode.BOOLEAN:
            self.scaled = int(present)
        elif mode == SensorMode.TRANSITIONCNT:
            if self.debounce > 0:
                self.debounce -= 1
            elif self.boolean != present:
                self.debounce = DEBOUNCE_RELOAD
                self.scaled += 1
        elif mode == SensorMode.PERIODCOUNTER:
            if self.debounce > 0:
                self.debounce -= 1
            elif self.boolean != present:
                self.debounce = DEBOUNCE_RELOAD
                self.boolean = present
                self.edge_count += 1
                if self.edge_count > 1 and not present:
                    self.edge_count = 0
                    self.scaled += 1
        elif mode == SensorMode.PCTFULLSCALE:
            self.scaled = (new * 100) // SENSOR_RESOLUTION
        elif mode == SensorMode.FAHRENHEIT:
            celsius_tenths = (new * 900) // SENSOR_RESOLUTION - 200
            self.scaled = (180 * celsius_tenths) // 100 + 320
        elif mode == SensorMode.CELSIUS:
            self.scaled = (new * 900) // SENSOR_RESOLUTION - 200
        self.old_normalized = new
        self.boolean = present
