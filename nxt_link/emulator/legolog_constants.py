"""The constants of the Legolog brick program, ``nxc/cplus_legolog.nxc``: its statuses, its
ports, and the numbers of its control laws.

Every upper-case integer here, the protocol's constants this module imports included, is one
the NXC program must ``#define`` with the same value: :data:`ROBOT_CONSTANTS` collects them
(``tests/nxt_link/test_behaviour_nxc.py`` compares them).  Apart from the model
(:mod:`nxt_link.emulator.legolog_program`, which gives these names too) because both of the
model's parts, :mod:`~nxt_link.emulator.legolog_state` and
:mod:`~nxt_link.emulator.legolog_behaviours`, use them.
"""
from __future__ import annotations

# the protocol's constants that the NXC program #defines too: part of ROBOT_CONSTANTS
from nxt_link.programs.behaviour_protocol import (  # noqa: F401
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
    RESPONSE_QUEUE,
)

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
                   if name.isupper() and isinstance(value, int)}

