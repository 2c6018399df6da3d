"""The setpoint streaming protocol between the PC and the brick program (codec only).

The firmware's mailboxes have no flow control: a queue holds 5 messages and a
write to a full queue silently drops the *oldest* one; Bluetooth frames can be
lost or damaged; the link can drop. So every message of this protocol:

* carries a **session** id (16 bits, chosen by the PC at HELLO) and a
  **sequence number** (16 bits);
* ends with a **CRC-16/CCITT** (polynomial 0x1021, initial value 0xFFFF)
  over all preceding bytes, which catches every single-byte error and every
  burst up to 16 bits; the brick silently ignores a message that fails it
  (the PC then retransmits);
* is answered by exactly one response in the brick's response mailbox
  (NXC ``SendResponseString(RESPONSE_QUEUE, ...)`` = mailbox 11), which echoes
  the session and sequence number, so the PC matches responses to requests and
  can discard stale ones.

State-changing requests (CONFIG, SETPOINTS, PREPARE, GO) are *sequenced*: the
brick applies sequence number ``expected`` only, re-acknowledges older ones
without applying them again (DUPLICATE) and refuses newer ones (GAP) with the
number it expects, so the PC can go back. That is go-back-N with a window of
at most 4 messages (one below the mailbox depth): nothing is applied twice or
out of order, and a lost message or acknowledgement costs one retransmission.
Reads (HELLO, QUERY, LOGREAD) and STOP are idempotent and unsequenced. Every
ACK carries a running checksum of the setpoints stored, so the PC verifies
that the brick holds exactly what was sent, in order.

All multi-byte fields are little-endian; a message is at most 58 bytes (the
mailbox payload limit). Byte layouts are in ``docs/nxt-link.md``; the NXC
program ``nxt_link/programs/nxc/cplus_follow.nxc`` implements the brick side with the
same constants (a test compares them).

>>> m = encode_request(Setpoints(session=7, seq=2, first_row=0, values=(10, -5)))
>>> decode_request(m)
Setpoints(session=7, seq=2, first_row=0, values=(10, -5))
"""
from __future__ import annotations

import enum
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from operator import attrgetter
from typing import Generic, Literal, TypeVar

from nxt_link.wire.errors import TelegramError

__all__ = [
    "PROTOCOL_VERSION",
    "PROGRAM_NAME",
    "CMD_INBOX",
    "RESPONSE_QUEUE",
    "RESPONSE_MAILBOX",
    "MAX_VALUES",
    "MAX_PORTS",
    "CONTROL_MS",
    "MAX_MESSAGE",
    "SETPOINT_VALUES_PER_MESSAGE",
    "LOG_VALUES_PER_MESSAGE",
    "REQ_HEAD",
    "RESP_HEAD",
    "seal",
    "unseal",
    "Envelope",
    "Kind",
    "State",
    "Code",
    "crc16",
    "Hello",
    "Config",
    "Setpoints",
    "Prepare",
    "Go",
    "Query",
    "LogRead",
    "Stop",
    "Request",
    "Welcome",
    "Ack",
    "LogData",
    "Response",
    "encode_request",
    "decode_request",
    "encode_response",
    "decode_response",
    "rows_per_setpoint_message",
    "rows_per_log_message",
    "setpoint_checksum",
]

PROTOCOL_VERSION = 1
#: File name of the compiled brick program (15.3 name, fits the 19-char field).
PROGRAM_NAME = "cplus_follow.rxe"
#: PC -> brick: the program reads this inbox (NXC ``ReceiveRemoteString(1, ...)``).
CMD_INBOX = 1
#: brick -> PC: NXC ``SendResponseString(RESPONSE_QUEUE, ...)`` ...
RESPONSE_QUEUE = 1
#: ... which lands in mailbox RESPONSE_QUEUE + 10, read with MESSAGEREAD.
RESPONSE_MAILBOX = RESPONSE_QUEUE + 10
#: Capacity of each of the brick's two value arrays (references, measurements).
MAX_VALUES = 3000
MAX_PORTS = 3
#: Period of the brick program's control loop.
CONTROL_MS = 10
#: Largest message: the mailbox payload limit (59 bytes incl. NUL).
MAX_MESSAGE = 58

#: The session layer every message shares (this protocol and the behaviour protocol):
#: a request head, a response head, and a CRC-16 check after the body (:func:`seal`,
#: :class:`Envelope`).
REQ_HEAD = struct.Struct("<BHH")  # kind, session, seq
RESP_HEAD = struct.Struct("<BHHB")  # kind, session, seq, state
_CHECK = 2
_M = TypeVar("_M")

#: int16 values that fit a SETPOINTS message after header, first_row, count, check.
SETPOINT_VALUES_PER_MESSAGE = (MAX_MESSAGE - REQ_HEAD.size - 3 - _CHECK) // 2
#: int16 values that fit a LOGDATA message.
LOG_VALUES_PER_MESSAGE = (MAX_MESSAGE - RESP_HEAD.size - 3 - _CHECK) // 2


class Kind(enum.IntEnum):
    """First byte of every message (ASCII letters, readable in hex dumps)."""

    HELLO = 0x48  # 'H'
    CONFIG = 0x43  # 'C'
    SETPOINTS = 0x53  # 'S'
    PREPARE = 0x50  # 'P'
    GO = 0x47  # 'G'
    QUERY = 0x51  # 'Q'
    LOGREAD = 0x4C  # 'L'
    STOP = 0x58  # 'X'
    WELCOME = 0x57  # 'W'
    ACK = 0x41  # 'A'
    LOGDATA = 0x44  # 'D'


class State(enum.IntEnum):
    """The brick program's state (reported in every response)."""

    IDLE = 0  # session open, nothing configured
    LOADING = 1  # configured, receiving setpoints
    LOADED = 2  # all setpoints stored
    HOMING = 3  # moving to the first setpoint (the initial configuration)
    READY = 4  # at the initial configuration, holding, waiting for GO
    RUNNING = 5  # following the references, logging
    DONE = 6  # trajectory finished, holding the last reference; log complete
    STOPPED = 7  # STOP received: motors coasting


class Code(enum.IntEnum):
    """Result code of an ACK."""

    OK = 0
    DUPLICATE = 1  # sequence number already applied: not applied again
    GAP = 2  # sequence number ahead of the expected one: not applied
    BAD_STATE = 3  # request not allowed in the current state
    BAD_CONFIG = 4  # CONFIG values out of range
    OUT_OF_LIMITS = 5  # a setpoint outside its port's [min, max]
    BAD_ORDER = 6  # SETPOINTS first_row is not the next row to store
    BAD_RANGE = 7  # rows beyond n_rows (SETPOINTS) or not logged yet (LOGREAD)
    BAD_LENGTH = 8  # body length does not match its count
    BAD_VERSION = 9  # HELLO with a protocol version the program does not speak


def _crc_table() -> tuple[int, ...]:
    table = []
    for i in range(256):
        c = i << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x1021) & 0xFFFF if c & 0x8000 else (c << 1) & 0xFFFF
        table.append(c)
    return tuple(table)


_CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE; the NXC program computes the same with the same table.

    >>> hex(crc16(b"123456789"))
    '0x29b1'
    """
    for b in data:
        crc = ((crc << 8) & 0xFFFF) ^ _CRC_TABLE[((crc >> 8) ^ b) & 0xFF]
    return crc


def setpoint_checksum(values: Iterable[int]) -> int:
    """CRC-16 over the little-endian int16 bytes of ``values`` in order.

    The brick keeps the same running checksum over what it stored, so the PC can
    verify that the brick holds exactly the setpoints sent, in order.
    """
    crc = 0xFFFF
    for v in values:
        crc = crc16(bytes((v & 0xFF, (v >> 8) & 0xFF)), crc)
    return crc


# ---------------------------------------------------------------------------
# requests (PC -> brick)


@dataclass(frozen=True, slots=True)
class Hello:
    session: int
    seq: int = 0
    version: int = PROTOCOL_VERSION
    kind = Kind.HELLO


@dataclass(frozen=True, slots=True)
class Config:
    """Ports are firmware port numbers (0=A, 1=B, 2=C); gains in %/degree = num/den."""

    session: int
    seq: int
    ports: tuple[int, ...]
    n_rows: int
    tick_ms: int
    kp_num: int
    kp_den: int
    max_power: int
    tolerance_deg: int
    min_deg: tuple[int, ...]
    max_deg: tuple[int, ...]
    kind = Kind.CONFIG


@dataclass(frozen=True, slots=True)
class Setpoints:
    """Rows ``first_row ...`` flattened row-major: ``len(values) = rows * n_ports``."""

    session: int
    seq: int
    first_row: int
    values: tuple[int, ...]
    kind = Kind.SETPOINTS


@dataclass(frozen=True, slots=True)
class Prepare:
    session: int
    seq: int
    kind = Kind.PREPARE


@dataclass(frozen=True, slots=True)
class Go:
    """Start following the references ``delay_ms`` after this message arrives.

    The PC fixes one start time T for all bricks and sends GO with the time
    left until T; a retransmitted GO carries a smaller delay, and the brick
    applies only the first copy it gets, so every brick starts at T plus its
    own one-way delay even when a copy was lost.
    """

    session: int
    seq: int
    delay_ms: int = 0
    kind = Kind.GO


@dataclass(frozen=True, slots=True)
class Query:
    session: int
    seq: int
    kind = Kind.QUERY


@dataclass(frozen=True, slots=True)
class LogRead:
    session: int
    seq: int
    first_row: int
    count: int
    kind = Kind.LOGREAD


@dataclass(frozen=True, slots=True)
class Stop:
    session: int
    seq: int
    kind = Kind.STOP


Request = Hello | Config | Setpoints | Prepare | Go | Query | LogRead | Stop

SEQUENCED_KINDS = frozenset({Kind.CONFIG, Kind.SETPOINTS, Kind.PREPARE, Kind.GO})


def seal(body: bytes) -> bytes:
    """``body`` with its CRC-16 check appended; refused when the mailbox cannot carry it."""
    if len(body) + _CHECK > MAX_MESSAGE:
        raise TelegramError(f"message of {len(body) + _CHECK} bytes exceeds {MAX_MESSAGE}")
    return body + struct.pack("<H", crc16(body))


def unseal(message: bytes) -> bytes:
    """The body of a sealed message; a short or damaged one is a :class:`TelegramError`."""
    if len(message) < _CHECK + 1:
        raise TelegramError("message too short")
    body, check = message[:-_CHECK], struct.unpack("<H", message[-_CHECK:])[0]
    if crc16(body) != check:
        raise TelegramError("message check failed")
    return body


class Envelope(Generic[_M]):
    """One direction of the session layer, so that both protocols code only their bodies.

    A message is its header (:data:`REQ_HEAD`, or :data:`RESP_HEAD` for a response), the body
    ``body(message)`` writes and ``parse(*header, body)`` reads (None: a kind it does not
    know), and the CRC-16 check of :func:`seal`; a field out of range or a body too short for
    its kind is a :class:`TelegramError` worded alike in both protocols.
    """

    def __init__(self, what: Literal["request", "response"], body: Callable[[_M], bytes],
                 parse: Callable[..., _M | None]) -> None:
        self.what = what
        self.head, self._header = _HEADERS[what]
        self._body = body
        self._parse = parse

    def encode(self, message: _M) -> bytes:
        try:
            return seal(self.head.pack(*self._header(message)) + self._body(message))
        except struct.error as exc:
            raise TelegramError(f"field out of range: {exc}") from None

    def decode(self, message: bytes) -> _M:
        body = unseal(message)
        if len(body) < self.head.size:
            raise TelegramError(f"{self.what} header truncated")
        header = self.head.unpack_from(body)
        try:
            decoded = self._parse(*header, body[self.head.size:])
        except struct.error:
            raise TelegramError(f"malformed {self.what} of kind 0x{header[0]:02X}") from None
        if decoded is None:
            raise TelegramError(f"unknown {self.what} kind 0x{header[0]:02X}")
        return decoded


_HEADERS = {"request": (REQ_HEAD, attrgetter("kind", "session", "seq")),
            "response": (RESP_HEAD, attrgetter("kind", "session", "seq", "state"))}


def _values(fmt_count: int, data: bytes) -> tuple[int, ...]:
    return struct.unpack(f"<{fmt_count}h", data)


def encode_request(req: Request) -> bytes:
    """Encode a request as a mailbox payload (<= 58 bytes, may contain NULs).

    Raises:
        TelegramError: a field does not fit (too many values, out of int16 range).
    """
    return _REQUESTS.encode(req)


def _request_body(req: Request) -> bytes:
    if isinstance(req, Hello):
        return struct.pack("<B", req.version)
    if isinstance(req, Config):
        n = len(req.ports)
        if not 1 <= n <= MAX_PORTS or len(req.min_deg) != n or len(req.max_deg) != n:
            raise TelegramError("CONFIG needs 1-3 ports with one min and max each")
        ports = list(req.ports) + [0xFF] * (MAX_PORTS - n)
        lo = list(req.min_deg) + [0] * (MAX_PORTS - n)
        hi = list(req.max_deg) + [0] * (MAX_PORTS - n)
        return struct.pack("<B3BHHBBBB3h3h", n, *ports, req.n_rows, req.tick_ms, req.kp_num, req.kp_den,
                           req.max_power, req.tolerance_deg, *lo, *hi)
    if isinstance(req, Setpoints):
        count = len(req.values)
        if count > SETPOINT_VALUES_PER_MESSAGE:
            raise TelegramError(f"{count} values exceed {SETPOINT_VALUES_PER_MESSAGE}")
        return struct.pack(f"<HB{count}h", req.first_row, count, *req.values)
    if isinstance(req, LogRead):
        return struct.pack("<HB", req.first_row, req.count)
    if isinstance(req, Go):
        return struct.pack("<H", req.delay_ms)
    return b""


def decode_request(message: bytes) -> Request:
    """Decode a request (the brick's side; the emulator's program model uses it).

    Raises:
        TelegramError: damaged (check fails), unknown kind, or malformed body.
    """
    return _REQUESTS.decode(message)


def _request(kind: int, session: int, seq: int, rest: bytes) -> Request | None:
    if kind == Kind.HELLO:
        return Hello(session, seq, struct.unpack("<B", rest)[0])
    if kind == Kind.CONFIG:
        (n, p0, p1, p2, n_rows, tick_ms, kp_num, kp_den, max_power, tol,
         l0, l1, l2, h0, h1, h2) = struct.unpack("<B3BHHBBBB3h3h", rest)
        if not 1 <= n <= MAX_PORTS:
            raise TelegramError(f"CONFIG with {n} ports")
        return Config(session, seq, (p0, p1, p2)[:n], n_rows, tick_ms, kp_num, kp_den,
                      max_power, tol, (l0, l1, l2)[:n], (h0, h1, h2)[:n])
    if kind == Kind.SETPOINTS:
        first_row, count = struct.unpack_from("<HB", rest)
        data = rest[3:]
        if len(data) != 2 * count:
            raise TelegramError("SETPOINTS length does not match its count")
        return Setpoints(session, seq, first_row, _values(count, data))
    if kind == Kind.LOGREAD:
        first_row, count = struct.unpack("<HB", rest)
        return LogRead(session, seq, first_row, count)
    if kind == Kind.GO:
        return Go(session, seq, struct.unpack("<H", rest)[0])
    simple = {Kind.PREPARE: Prepare, Kind.QUERY: Query, Kind.STOP: Stop}
    if kind in simple and not rest:
        return simple[Kind(kind)](session, seq)  # type: ignore[return-value]
    return None


# ---------------------------------------------------------------------------
# responses (brick -> PC)


@dataclass(frozen=True, slots=True)
class Welcome:
    session: int
    seq: int
    state: int
    version: int
    code: int
    expected_seq: int
    max_values: int
    rows_stored: int
    logged: int
    control_ms: int
    kind = Kind.WELCOME


@dataclass(frozen=True, slots=True)
class Ack:
    """``value``: the largest |reference - angle| now (QUERY), else 0.

    ``checksum``: running :func:`setpoint_checksum` of the stored setpoints.
    """

    session: int
    seq: int
    state: int
    code: int
    expected_seq: int
    rows_stored: int
    logged: int
    value: int
    checksum: int
    kind = Kind.ACK


@dataclass(frozen=True, slots=True)
class LogData:
    """Measured angles of rows ``first_row ...``, flattened row-major."""

    session: int
    seq: int
    state: int
    first_row: int
    values: tuple[int, ...]
    kind = Kind.LOGDATA


Response = Welcome | Ack | LogData


def encode_response(resp: Response) -> bytes:
    """Encode a response (the brick's side)."""
    return _RESPONSES.encode(resp)


def _response_body(resp: Response) -> bytes:
    if isinstance(resp, Welcome):
        return struct.pack("<BBHHHHB", resp.version, resp.code, resp.expected_seq, resp.max_values,
                           resp.rows_stored, resp.logged, resp.control_ms)
    if isinstance(resp, Ack):
        return struct.pack("<BHHHhH", resp.code, resp.expected_seq, resp.rows_stored, resp.logged,
                           resp.value, resp.checksum)
    count = len(resp.values)
    if count > LOG_VALUES_PER_MESSAGE:
        raise TelegramError(f"{count} values exceed {LOG_VALUES_PER_MESSAGE}")
    return struct.pack(f"<HB{count}h", resp.first_row, count, *resp.values)


def decode_response(message: bytes) -> Response:
    """Decode a response (the PC's side).

    Raises:
        TelegramError: damaged, unknown kind or malformed.
    """
    return _RESPONSES.decode(message)


def _response(kind: int, session: int, seq: int, state: int, rest: bytes) -> Response | None:
    if kind == Kind.WELCOME:
        return Welcome(session, seq, state, *struct.unpack("<BBHHHHB", rest))
    if kind == Kind.ACK:
        return Ack(session, seq, state, *struct.unpack("<BHHHhH", rest))
    if kind == Kind.LOGDATA:
        first_row, count = struct.unpack_from("<HB", rest)
        data = rest[3:]
        if len(data) != 2 * count:
            raise TelegramError("LOGDATA length does not match its count")
        return LogData(session, seq, state, first_row, _values(count, data))
    return None


_REQUESTS = Envelope[Request]("request", _request_body, _request)
_RESPONSES = Envelope[Response]("response", _response_body, _response)


def rows_per_setpoint_message(n_ports: int) -> int:
    """Rows of ``n_ports`` int16 values one SETPOINTS message carries (24 values)."""
    return SETPOINT_VALUES_PER_MESSAGE // n_ports


def rows_per_log_message(n_ports: int) -> int:
    """Rows one LOGDATA response carries (23 values)."""
    return LOG_VALUES_PER_MESSAGE // n_ports
