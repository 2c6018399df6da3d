"""The behaviour protocol between the PC and the Legolog brick program (codec only).

Legolog (Levesque and Pagnucco, §2.1-2.2) runs a robot one *primitive action* at a time:
the PC asks the brick to execute a behaviour, the brick acknowledges, runs it and answers
with a sensing value (or asks for more time); the PC polls the brick for exogenous
actions; the PC can abort; a brick whose PC stops acknowledging goes into a PANIC state
that only an abort ends. This module is that protocol on NXT mailboxes, in the same
session layer as the setpoint streaming protocol (:mod:`nxt_link.programs.stream_protocol`):

* the same mailboxes: PC -> brick inbox ``CMD_INBOX`` (1), brick -> PC
  ``SendResponseString(RESPONSE_QUEUE)`` = mailbox 11, read with MESSAGEREAD;
* the same envelope: ``kind u8, session u16, seq u16`` (+ ``state u8`` in responses),
  little-endian fields, at most 58 bytes, and a CRC-16/CCITT of everything before it in
  the last two bytes (:func:`~nxt_link.programs.stream_protocol.crc16`); a damaged message is
  ignored and the sender's timeout re-sends it;
* its own message kinds (lower-case letters, so the follower program ignores them and
  vice versa).

PC -> brick:

* ``HELLO`` (version) -> ``WELCOME``: a new session id resets the program (stops any
  behaviour, next ACT is 1).
* ``ACT`` seq=n (behaviour, args) -> ``ACK`` at once, then ``DONE`` (status, sensing
  values) when the behaviour ends, or ``MORE_TIME`` (part k) every ``ACTION_MS`` while it
  runs. ACTs are numbered 1, 2, ... per session; the brick starts ACT n only once: a copy
  of n (the PC re-sends when an answer is late) is answered ``ACK DUPLICATE`` and, if n
  has finished, its ``DONE`` again. ``DONE`` is not acknowledged (as in Legolog, the last
  part of a sensing value is not): a lost DONE is fetched again by re-sending the ACT.
* ``CONT`` seq=n (part k): Legolog's *continue*, acknowledges MORE_TIME k of ACT n. The
  brick re-sends an unacknowledged MORE_TIME every ``RESEND_MS``; after ``MAX_SENDS``
  copies without a CONT it goes into PANIC.
* ``EXOG`` (ack_through) -> ``EVENTS`` (the events numbered after ``ack_through``) or
  ``NONE``. The brick numbers the events it detects 1, 2, ... and drops them only when a
  later poll acknowledges them, so a lost answer loses nothing and a repeated poll
  duplicates nothing.
* ``ABORT`` -> ``ABORTED``: stop every behaviour, coast the motors, leave PANIC. Accepted
  in every state and from any session (it is the way out of PANIC for a new PC process).

Brick -> PC, besides the answers: ``PANIC`` every ``PANIC_PERIOD_MS`` while in PANIC
(everything but ABORT is ignored then). PANIC messages carry the brick's abort count, so
copies still queued from before an ABORT are recognised as stale.

Byte layouts are in ``docs/nxt-link.md``; the NXC program ``nxt_link/programs/nxc/cplus_legolog.nxc``
implements the brick side with the same constants (a test compares them).

>>> m = encode_request(Act(session=7, seq=1, behaviour=1, args=(30,)))
>>> decode_request(m)
Act(session=7, seq=1, behaviour=1, args=(30,))
"""
from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

from nxt_link.programs.stream_protocol import (
    CMD_INBOX,
    RESPONSE_MAILBOX,
    RESPONSE_QUEUE,
    Envelope,
)
from nxt_link.wire.errors import TelegramError

__all__ = [
    "PROTOCOL_VERSION",
    "PROGRAM_NAME",
    "CMD_INBOX",
    "RESPONSE_QUEUE",
    "RESPONSE_MAILBOX",
    "CONTROL_MS",
    "ACTION_MS",
    "RESEND_MS",
    "MAX_SENDS",
    "PANIC_PERIOD_MS",
    "MAX_ARGS",
    "MAX_EVENTS_PER_MESSAGE",
    "EVENT_SLOTS",
    "Kind",
    "State",
    "AckCode",
    "Status",
    "Behaviour",
    "Sense",
    "Event",
    "Hello",
    "Act",
    "Cont",
    "Exog",
    "Abort",
    "Request",
    "Welcome",
    "Ack",
    "MoreTime",
    "Done",
    "Events",
    "NoEvents",
    "Aborted",
    "Panic",
    "Response",
    "encode_request",
    "decode_request",
    "encode_response",
    "decode_response",
]

PROTOCOL_VERSION = 1
#: File name of the compiled Legolog brick program (fits the firmware's 19-character field).
PROGRAM_NAME = "cplus_legolog.rxe"
#: Period of the program's event loop (Legolog's Fig. 2 ``while (true)``).
CONTROL_MS = 10
#: A behaviour running longer than this asks for more time (Legolog: 3 s per action).
ACTION_MS = 3000
#: An unacknowledged MORE_TIME is sent again after this long (Legolog's 3.5 s time-out).
RESEND_MS = 3500
#: Copies of one MORE_TIME sent without a CONT before the brick panics (about 10.5 s).
MAX_SENDS = 3
#: While in PANIC the brick beeps and sends a PANIC message this often.
PANIC_PERIOD_MS = 1000
#: Arguments of one ACT.
MAX_ARGS = 8
#: Events carried by one EVENTS message.
MAX_EVENTS_PER_MESSAGE = 8
#: Events the brick keeps until the PC acknowledges them; more are counted as lost.
EVENT_SLOTS = 16



class Kind(enum.IntEnum):
    """First byte of every message (lower-case ASCII letters, unlike the streaming protocol)."""

    HELLO = 0x68  # 'h'
    ACT = 0x61  # 'a'
    CONT = 0x63  # 'c'
    EXOG = 0x65  # 'e'
    ABORT = 0x78  # 'x'
    WELCOME = 0x77  # 'w'
    ACK = 0x6B  # 'k'
    MORE_TIME = 0x6D  # 'm'
    DONE = 0x64  # 'd'
    EVENTS = 0x76  # 'v'
    NONE = 0x6E  # 'n'
    ABORTED = 0x7A  # 'z'
    PANIC = 0x70  # 'p'


class State(enum.IntEnum):
    """The brick's state in every response (Legolog's OK split in two, and PANIC)."""

    IDLE = 0  # OK, no behaviour running
    RUNNING = 1  # OK, a behaviour runs
    PANIC = 2  # the PC stopped acknowledging; only ABORT is accepted


class AckCode(enum.IntEnum):
    """Result of an ACT in its ACK."""

    OK = 0  # started
    DUPLICATE = 1  # this ACT was started before: not started again
    BUSY = 2  # another ACT is still running
    GAP = 3  # seq is ahead of the next expected ACT
    UNKNOWN_BEHAVIOUR = 4
    BAD_ARGS = 5
    BAD_LENGTH = 6
    BAD_VERSION = 7  # (WELCOME) the HELLO's protocol version is not spoken


class Status(enum.IntEnum):
    """How a behaviour ended (DONE)."""

    OK = 0
    STUCK = 1  # the drive or tray motor does not turn although powered
    LOST = 2  # the line was lost
    TIMEOUT = 3  # no landmark within the time allowed


class Behaviour(enum.IntEnum):
    """The delivery robot's behaviours (``cplus_legolog.nxc``)."""

    FOLLOW = 1  # follow the line to the next landmark; args: [max seconds]
    TURN = 2  # turn 180 degrees onto the line
    TRAY_UP = 3
    TRAY_DOWN = 4
    WAIT_BUTTON = 5  # wait for a press of the touch sensor; args: [max seconds, 0 = no limit]


class Sense(enum.IntEnum):
    """Keys of the sensing values in a DONE; the client names them by ``name.lower()``."""

    LANDMARK = 1  # number of the landmark reached (FOLLOW), 0 if none
    LIGHT = 2  # light sensor, percent
    TOUCH = 3  # touch sensor: 1 pressed (WAIT_BUTTON: pressed during the wait)
    TRAY = 4  # tray motor angle, degrees
    DISTANCE = 5  # distance driven, mm (FOLLOW)


class Event(enum.IntEnum):
    """Exogenous events the brick detects; the client names them by ``name.lower()``."""

    BUTTON = 1  # touch sensor pressed while no behaviour waits for it


# ---------------------------------------------------------------------------
# requests (PC -> brick)


@dataclass(frozen=True, slots=True)
class Hello:
    session: int
    seq: int = 0
    version: int = PROTOCOL_VERSION
    kind = Kind.HELLO


@dataclass(frozen=True, slots=True)
class Act:
    """Execute ``behaviour`` with ``args``; ``seq`` numbers the ACTs of a session from 1."""

    session: int
    seq: int
    behaviour: int
    args: tuple[int, ...] = ()
    kind = Kind.ACT


@dataclass(frozen=True, slots=True)
class Cont:
    """Acknowledge MORE_TIME ``part`` of ACT ``seq``."""

    session: int
    seq: int
    part: int
    kind = Kind.CONT


@dataclass(frozen=True, slots=True)
class Exog:
    """Poll for events; the PC has every event up to number ``ack_through``."""

    session: int
    seq: int
    ack_through: int
    kind = Kind.EXOG


@dataclass(frozen=True, slots=True)
class Abort:
    session: int
    seq: int
    kind = Kind.ABORT


Request = Hello | Act | Cont | Exog | Abort


# ---------------------------------------------------------------------------
# responses (brick -> PC)


@dataclass(frozen=True, slots=True)
class Welcome:
    """``last_act``: the last ACT of this session the brick started (0: none)."""

    session: int
    seq: int
    state: int
    version: int
    code: int
    last_act: int
    aborts: int
    action_ms: int
    kind = Kind.WELCOME


@dataclass(frozen=True, slots=True)
class Ack:
    session: int
    seq: int
    state: int
    code: int
    behaviour: int
    kind = Kind.ACK


@dataclass(frozen=True, slots=True)
class MoreTime:
    session: int
    seq: int
    state: int
    part: int
    elapsed_ms: int
    kind = Kind.MORE_TIME


@dataclass(frozen=True, slots=True)
class Done:
    """``values``: (Sense key, value) pairs."""

    session: int
    seq: int
    state: int
    status: int
    behaviour: int
    elapsed_ms: int
    values: tuple[tuple[int, int], ...]
    kind = Kind.DONE


@dataclass(frozen=True, slots=True)
class Events:
    """Events numbered ``first``, ``first + 1``, ...; each is (Event code, args).

    ``lost``: events the brick could not keep since the program started (full queue).
    """

    session: int
    seq: int
    state: int
    first: int
    lost: int
    events: tuple[tuple[int, tuple[int, ...]], ...]
    kind = Kind.EVENTS


@dataclass(frozen=True, slots=True)
class NoEvents:
    """No event after the poll's ``ack_through``; ``next_event`` is the next number."""

    session: int
    seq: int
    state: int
    next_event: int
    lost: int
    kind = Kind.NONE


@dataclass(frozen=True, slots=True)
class Aborted:
    """``aborts``: the brick's abort count now; ``last_act``: the last ACT it started."""

    session: int
    seq: int
    state: int
    aborts: int
    last_act: int
    kind = Kind.ABORTED


@dataclass(frozen=True, slots=True)
class Panic:
    """``seq``: the ACT that was running; ``aborts``: the brick's abort count then."""

    session: int
    seq: int
    state: int
    aborts: int
    behaviour: int
    kind = Kind.PANIC


Response = Welcome | Ack | MoreTime | Done | Events | NoEvents | Aborted | Panic


# ---------------------------------------------------------------------------
# codec


def encode_request(req: Request) -> bytes:
    """Encode a request as a mailbox payload (<= 58 bytes, may contain NULs).

    Raises:
        TelegramError: a field does not fit (too many arguments, out of range).
    """
    return _REQUESTS.encode(req)


def _request_body(req: Request) -> bytes:
    if isinstance(req, Hello):
        return struct.pack("<B", req.version)
    if isinstance(req, Act):
        n = len(req.args)
        if n > MAX_ARGS:
            raise TelegramError(f"{n} arguments exceed {MAX_ARGS}")
        return struct.pack(f"<BB{n}h", req.behaviour, n, *req.args)
    if isinstance(req, Cont):
        return struct.pack("<B", req.part)
    if isinstance(req, Exog):
        return struct.pack("<H", req.ack_through)
    return b""


def decode_request(message: bytes) -> Request:
    """Decode a request (the brick's side; tests and tools use it).

    Raises:
        TelegramError: damaged (check fails), unknown kind, or malformed body.
    """
    return _REQUESTS.decode(message)


def _request(kind: int, session: int, seq: int, rest: bytes) -> Request | None:
    if kind == Kind.HELLO:
        return Hello(session, seq, struct.unpack("<B", rest)[0])
    if kind == Kind.ACT:
        behaviour, n = struct.unpack_from("<BB", rest)
        if len(rest) != 2 + 2 * n or n > MAX_ARGS:
            raise TelegramError("ACT length does not match its argument count")
        return Act(session, seq, behaviour, struct.unpack_from(f"<{n}h", rest, 2))
    if kind == Kind.CONT:
        return Cont(session, seq, struct.unpack("<B", rest)[0])
    if kind == Kind.EXOG:
        return Exog(session, seq, struct.unpack("<H", rest)[0])
    if kind == Kind.ABORT and not rest:
        return Abort(session, seq)
    return None


def encode_response(resp: Response) -> bytes:
    """Encode a response (the brick's side)."""
    return _RESPONSES.encode(resp)


def _response_body(resp: Response) -> bytes:
    if isinstance(resp, Welcome):
        return struct.pack("<BBHHH", resp.version, resp.code, resp.last_act, resp.aborts, resp.action_ms)
    if isinstance(resp, Ack):
        return struct.pack("<BB", resp.code, resp.behaviour)
    if isinstance(resp, MoreTime):
        return struct.pack("<BI", resp.part, resp.elapsed_ms)
    if isinstance(resp, Done):
        flat = [x for pair in resp.values for x in pair]
        n = len(resp.values)
        return struct.pack("<BBIB" + "Bh" * n, resp.status, resp.behaviour, resp.elapsed_ms, n, *flat)
    if isinstance(resp, Events):
        out = bytearray(struct.pack("<HHB", resp.first, resp.lost, len(resp.events)))
        for code, args in resp.events:
            out += struct.pack(f"<BB{len(args)}h", code, len(args), *args)
        return bytes(out)
    if isinstance(resp, NoEvents):
        return struct.pack("<HH", resp.next_event, resp.lost)
    if isinstance(resp, Aborted):
        return struct.pack("<HH", resp.aborts, resp.last_act)
    return struct.pack("<HB", resp.aborts, resp.behaviour)


def decode_response(message: bytes) -> Response:
    """Decode a response (the PC's side).

    Raises:
        TelegramError: damaged, unknown kind or malformed.
    """
    return _RESPONSES.decode(message)


def _response(kind: int, session: int, seq: int, state: int, rest: bytes) -> Response | None:
    if kind == Kind.WELCOME:
        return Welcome(session, seq, state, *struct.unpack("<BBHHH", rest))
    if kind == Kind.ACK:
        return Ack(session, seq, state, *struct.unpack("<BB", rest))
    if kind == Kind.MORE_TIME:
        return MoreTime(session, seq, state, *struct.unpack("<BI", rest))
    if kind == Kind.DONE:
        status, behaviour, elapsed, n = struct.unpack_from("<BBIB", rest)
        if len(rest) != 7 + 3 * n:
            raise TelegramError("DONE length does not match its value count")
        flat = struct.unpack_from("<" + "Bh" * n, rest, 7)
        values = tuple((flat[2 * i], flat[2 * i + 1]) for i in range(n))
        return Done(session, seq, state, status, behaviour, elapsed, values)
    if kind == Kind.EVENTS:
        first, lost, n = struct.unpack_from("<HHB", rest)
        pos = 5
        events = []
        for _ in range(n):
            code, nargs = struct.unpack_from("<BB", rest, pos)
            args = struct.unpack_from(f"<{nargs}h", rest, pos + 2)
            events.append((code, args))
            pos += 2 + 2 * nargs
        if pos != len(rest):
            raise TelegramError("EVENTS length does not match its events")
        return Events(session, seq, state, first, lost, tuple(events))
    if kind == Kind.NONE:
        return NoEvents(session, seq, state, *struct.unpack("<HH", rest))
    if kind == Kind.ABORTED:
        return Aborted(session, seq, state, *struct.unpack("<HH", rest))
    if kind == Kind.PANIC:
        return Panic(session, seq, state, *struct.unpack("<HB", rest))
    return None


_REQUESTS = Envelope[Request]("request", _request_body, _request)
_RESPONSES = Envelope[Response]("response", _response_body, _response)
