"""The firmware's input module for one sensor port: what a program and SETINPUTMODE see.

One :class:`InputPort` per sensor port, with the fields of the firmware's IO
map (``c_input.iom``): sensor type and mode, the raw A/D reading (0-1023), the
normalized value, the scaled value and the "invalid data" flag. A sensor world
only sets :attr:`InputPort.raw` (what the A/D converter reads on the pin,
e.g. ``183`` for a pressed touch sensor, higher for a darker surface under a
light sensor); every millisecond :meth:`InputPort.step` derives the rest as
``cInputCtrl``/``cInputCalcSensorValues`` do for the analog sensors:

* a type change marks the data invalid for 20 ms (300 ms for a sound sensor),
  a program's write of the invalid flag lasts until the next step;
* normalization by type: light, sound and RCX light sensors are rescaled to
  their dynamic range and inverted (a brighter light gives a larger value),
  touch and custom sensors pass the raw value through;
* the mode's slope (low 5 bits) selects absolute (45 %/55 % thresholds, with
  hysteresis) or dynamic boolean detection; the mode then gives the scaled
  value: raw, boolean, transition count, period count, percent of full scale,
  Celsius/Fahrenheit (from the normalized value), or angle steps.

Digital (I2C/RS485) and color sensors are not modelled: their values stay as
the program or the world set them. The temperature sensor's polynomial is
not modelled either: its normalized value is the raw one.

A world sets a light sensor's A/D value for a reflectance in percent with
:func:`light_percent_to_raw` (the inverse of the light sensor's mapping), and a
touch sensor's with :data:`TOUCH_RAW_PRESSED` / :data:`TOUCH_RAW_RELEASED`.

>>> p = InputPort()
>>> p.sensor_type, p.sensor_mode = SensorType.LIGHT_ACTIVE, SensorMode.PCT_FULL_SCALE
>>> p.raw = light_percent_to_raw(45)
>>> for _ in range(21): p.step()
>>> p.invalid, p.scaled
(False, 45)
"""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["InputPort", "SensorType", "SensorMode", "light_percent_to_raw", "TOUCH_RAW_PRESSED",
           "TOUCH_RAW_RELEASED", "step_ports"]

AD_MAX = 1023
_THRESHOLD_FALSE = AD_MAX * 45 // 100
_THRESHOLD_TRUE = AD_MAX * 55 // 100
_ANGLE_A = AD_MAX * 4400 // 10000
_ANGLE_B = AD_MAX * 6600 // 10000
_ANGLE_C = AD_MAX * 8900 // 10000
_DEBOUNCE_RELOAD = 100
_INVALID_RELOAD = 20
_INVALID_RELOAD_SOUND = 300
_ROT_SLOW_SPEED = 30
_ROT_OV_SAMPLING = 7


class SensorType:
    NO_SENSOR = 0
    SWITCH = 1
    TEMPERATURE = 2
    REFLECTION = 3
    ANGLE = 4
    LIGHT_ACTIVE = 5
    LIGHT_INACTIVE = 6
    SOUND_DB = 7
    SOUND_DBA = 8
    CUSTOM = 9
    LOWSPEED = 10
    LOWSPEED_9V = 11
    HIGHSPEED = 12


class SensorMode:
    RAW = 0x00
    BOOLEAN = 0x20
    TRANSITION_COUNT = 0x40
    PERIOD_COUNTER = 0x60
    PCT_FULL_SCALE = 0x80
    CELSIUS = 0xA0
    FAHRENHEIT = 0xC0
    ANGLE_STEPS = 0xE0
    SLOPE_MASK = 0x1F
    MODE_MASK = 0xE0


def _full_scale(raw: int, zero: int, pct_dyn: int, invert: bool) -> int:
    """``cInputCalcFullScale``."""
    v = raw - zero if raw >= zero else 0
    v = v * 100 // pct_dyn if pct_dyn else 0
    v = min(v, AD_MAX)
    return AD_MAX - v if invert else v


_VCC = 5000
_REFLECTION = (1906 // (_VCC // AD_MAX), ((AD_MAX * 4398 // _VCC) - 1906 // (_VCC // AD_MAX))
               * 100 // AD_MAX)
_LIGHT = (800 // (_VCC // AD_MAX), ((AD_MAX * 4400 // _VCC) - 800 // (_VCC // AD_MAX))
          * 100 // AD_MAX)
_SOUND = (650 // (_VCC // AD_MAX), ((AD_MAX * 4980 // _VCC) - 650 // (_VCC // AD_MAX))
          * 100 // AD_MAX)
#: A/D values of a touch sensor
TOUCH_RAW_PRESSED = 183
TOUCH_RAW_RELEASED = AD_MAX


def light_percent_to_raw(percent: float) -> int:
    """The A/D value for which a light sensor in PCT_FULL_SCALE mode reads ``percent``.

    The inverse of the firmware's mapping, aimed at the middle of the percent's bucket
    (the firmware truncates), so a whole percent comes back unchanged and a fractional
    one comes back rounded to the nearest (within the A/D's resolution, 0.15 %).
    """
    percent = min(100.0, max(0.0, percent))
    normalized = (percent + 0.5) * AD_MAX / 100.0
    raw = _LIGHT[0] + (AD_MAX - normalized) * _LIGHT[1] / 100.0
    return int(round(min(float(AD_MAX), max(0.0, raw))))


_ANALOG = (SensorType.SWITCH, SensorType.TEMPERATURE, SensorType.REFLECTION, SensorType.ANGLE,
           SensorType.LIGHT_ACTIVE, SensorType.LIGHT_INACTIVE, SensorType.SOUND_DB,
           SensorType.SOUND_DBA, SensorType.CUSTOM)


@dataclass(slots=True)
class InputPort:
    """IO-map fields of one input port plus the module's private state.

    Attributes:
        sensor_type, sensor_mode: as set by SETINPUTMODE or a program.
        raw: the A/D reading (``ADRaw``, 0-1023); the sensor world's input.
        normalized: ``SensorRaw``.
        scaled: ``SensorValue`` (signed 16 bits).
        invalid: ``InvalidData``.
        custom_zero, custom_pct_full_scale: the custom sensor's calibration.
    """

    sensor_type: int = 0
    sensor_mode: int = 0
    raw: int = AD_MAX
    normalized: int = 0
    scaled: int = 0
    invalid: bool = True
    boolean: int = 0
    custom_zero: int = 0
    custom_pct_full_scale: int = 0
    _old_type: int = field(default=0, repr=False)
    _invalid_timer: int = field(default=_INVALID_RELOAD, repr=False)
    _debounce: int = field(default=0, repr=False)
    _edges: int = field(default=0, repr=False)
    _last_angle: int = field(default=0, repr=False)
    _samples: int = field(default=0, repr=False)

    def reset(self) -> None:
        """Program start and end (``cCmdResetDevices``): no sensor, raw mode, values 0."""
        self.sensor_type = SensorType.NO_SENSOR
        self.sensor_mode = SensorMode.RAW
        self.normalized = 0
        self.scaled = 0
        self.invalid = True

    def step(self) -> None:
        """One millisecond of the input module (``cInputCtrl`` for this port)."""
        if self.sensor_type != self._old_type:
            self._debounce = self._edges = self._last_angle = self._samples = 0
            self._invalid_timer = (_INVALID_RELOAD_SOUND if self.sensor_type in
                                   (SensorType.SOUND_DB, SensorType.SOUND_DBA) else _INVALID_RELOAD)
            self.invalid = True
            self._old_type = self.sensor_type
        elif self._invalid_timer:
            self._invalid_timer -= 1
            if self._invalid_timer == 0:
                self.invalid = False
        else:
            self.invalid = False
        if not self.invalid and self.sensor_type in _ANALOG:
            self._calc()

    def _calc(self) -> None:
        t = self.sensor_type
        v = max(0, min(AD_MAX, self.raw))
        if t == SensorType.REFLECTION:
            v = _full_scale(v, _REFLECTION[0], _REFLECTION[1], True)
        elif t in (SensorType.LIGHT_ACTIVE, SensorType.LIGHT_INACTIVE):
            v = _full_scale(v, _LIGHT[0], _LIGHT[1], True)
        elif t in (SensorType.SOUND_DB, SensorType.SOUND_DBA):
            v = _full_scale(v, _SOUND[0], _SOUND[1], True)
        elif t == SensorType.CUSTOM:
            v = _full_scale(v, self.custom_zero, self.custom_pct_full_scale, False)
        self._value(v, self.sensor_mode & SensorMode.SLOPE_MASK,
                    self.sensor_mode & SensorMode.MODE_MASK)

    def _value(self, new: int, slope: int, mode: int) -> None:
        """``cInputCalcSensorValue``."""
        present = self.boolean
        if slope == 0:
            if new > _THRESHOLD_FALSE:
                present = 0
            elif new < _THRESHOLD_TRUE:
                present = 1
        elif new > AD_MAX - slope:
            present = 0
        elif new < slope:
            present = 1
        else:
            delta = self.normalized - new
            if delta < 0 and -delta > slope:
                present = 0
            elif delta >= 0 and delta > slope:
                present = 1
        self.normalized = new
        if mode == SensorMode.RAW:
            self.scaled = new
        elif mode == SensorMode.BOOLEAN:
            self.scaled = present
        elif mode == SensorMode.TRANSITION_COUNT:
            if self._debounce:
                self._debounce -= 1
            elif self.boolean != present:
                self._debounce = _DEBOUNCE_RELOAD
                self.scaled = _s16(self.scaled + 1)
        elif mode == SensorMode.PERIOD_COUNTER:
            if self._debounce:
                self._debounce -= 1
            elif self.boolean != present:
                self._debounce = _DEBOUNCE_RELOAD
                self.boolean = present
                self._edges += 1
                if self._edges > 1 and present == 0:
                    self._edges = 0
                    self.scaled = _s16(self.scaled + 1)
        elif mode == SensorMode.PCT_FULL_SCALE:
            self.scaled = new * 100 // AD_MAX
        elif mode == SensorMode.FAHRENHEIT:
            c = _s16(new * 900 // AD_MAX - 200)
            self.scaled = _s16((180 * (c & 0xFFFFFFFF)) // 100 + 320)
        elif mode == SensorMode.CELSIUS:
            self.scaled = _s16(new * 900 // AD_MAX - 200)
        elif mode == SensorMode.ANGLE_STEPS:
            self._angle(new)
        self.boolean = present

    def _angle(self, new: int) -> None:
        sample = 0 if new < _ANGLE_A else 1 if new < _ANGLE_B else 2 if new < _ANGLE_C else 3
        last = self._last_angle
        if last in (0, 3):
            up, down = (1, 2) if last == 0 else (2, 1)
            if sample == up:
                if self._samples >= _ROT_SLOW_SPEED:
                    self._samples += 1
                    if self._samples >= _ROT_SLOW_SPEED + _ROT_OV_SAMPLING:
                        self.scaled = _s16(self.scaled + 1)
                        self._last_angle = sample
                else:
                    self.scaled = _s16(self.scaled + 1)
                    self._last_angle = sample
            elif sample == down:
                self.scaled = _s16(self.scaled - 1)
                self._last_angle = sample
            elif sample == last and self._samples < _ROT_SLOW_SPEED:
                self._samples += 1
        else:
            up, down = (3, 0) if last == 1 else (0, 3)
            if sample == up:
                self.scaled = _s16(self.scaled + 1)
                self._last_angle = sample
            elif sample == down:
                self.scaled = _s16(self.scaled - 1)
                self._last_angle = sample
            self._samples = 0


def step_ports(ports: list[InputPort]) -> None:
    """One millisecond of the input module for every port: :meth:`InputPort.step`, skipped
    for a port it would leave as it is (no analog sensor, no type change or invalid data
    pending)."""
    for p in ports:
        t = p.sensor_type
        if t == p._old_type and not p._invalid_timer and not p.invalid and t not in _ANALOG:
            continue
        p.step()


def _s16(v: int) -> int:
    v &= 0xFFFF
    return v - 0x10000 if v & 0x8000 else v
