"""The settings of a brick session and the few constants and words its parts share.

:class:`ControllerSettings` (the brick's P-controller) and :class:`SessionTiming` (the
protocol's timeouts) are what a caller sets; the window, the id ranges and the GO constants
are the protocol's.  Apart from :mod:`nxt_link.host.session` (which gives the public names
too) so that the session's parts, :mod:`~nxt_link.host.session_link`,
:mod:`~nxt_link.host.session_setup` and the session itself, can use them without importing
each other.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import Code, State

PORT_NUMBERS = {"A": 0, "B": 1, "C": 2}
WINDOW = 4  # one below the mailbox depth of 5
_QUERY_ID0 = 0x8000  # ids of unsequenced requests start here, sequenced ones below
MAX_GO_DELAY_MS = 30000  # echoed in an int16 ACK field
GO_COPIES = 3  # at 30 % loss, all three are lost once in 37 ...
GO_RESEND_S = 0.1  # ... so one more copy every 0.1 s until acknowledged


@dataclass(frozen=True, slots=True)
class ControllerSettings:
    """The brick's P-controller: ``power % = kp_num * error_deg / kp_den``.

    Defaults: gain 2 %/degree (little overshoot with the default motor model,
    about 1 degree of steady-state error), full power allowed, the initial
    configuration is reached when every motor is within 3 degrees.
    """

    kp_num: int = 2
    kp_den: int = 1
    max_power: int = 100
    tolerance_deg: int = 3

    def __post_init__(self) -> None:
        if not (1 <= self.kp_num <= 255 and 1 <= self.kp_den <= 255):
            raise ValueError("controller gain: kp_num and kp_den must be in 1..255")
        if not 1 <= self.max_power <= 100:
            raise ValueError("controller max_power must be in 1..100")
        if not 0 <= self.tolerance_deg <= 255:
            raise ValueError("controller tolerance must be in 0..255 degrees")


@dataclass(frozen=True, slots=True)
class SessionTiming:
    """Timeouts of the streaming protocol (on the bricks' clock).

    Attributes:
        ack_timeout_s: no acknowledgement progress for this long -> resend.
        empty_after_s: the response mailbox found empty by a read sent at least
            this long after a request means that the request or its response was
            lost -> resend at once, without waiting for ``ack_timeout_s`` (the
            brick handles its inbox every 10 ms, in the order it arrived).
        poll_gap_s: pause before reading an empty response mailbox again.
        query_interval_s: QUERY period while homing and running; a GO not yet
            acknowledged is sent again this often.
        max_silent_s: no valid response for this long (counted from the last
            one) -> the brick has gone.
        homing_timeout_s: the initial configuration must be reached in time.
        program_start_timeout_s: STARTPROGRAM until the program answers.
    """

    ack_timeout_s: float = 0.6
    poll_gap_s: float = 0.01
    query_interval_s: float = 0.25
    max_silent_s: float = 10.0
    homing_timeout_s: float = 15.0
    program_start_timeout_s: float = 5.0
    empty_after_s: float = 0.05



def _with_seq(req: sp.Request, seq: int) -> sp.Request:
    return replace(req, seq=seq)


def _state_name(state: int) -> str:
    try:
        return State(state).name
    except ValueError:
        return str(state)


def _refusal(brick: str, req: sp.Request, code: int) -> str:
    try:
        reason = Code(code).name.lower().replace("_", " ")
    except ValueError:
        reason = f"code {code}"
    what = req.kind.name
    if isinstance(req, sp.Setpoints):
        what = f"SETPOINTS from row {req.first_row}"
    return f"brick {brick} refused {what}: {reason}"
