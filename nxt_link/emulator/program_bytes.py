"""What the Python models of the brick programs share with each other, as the NXC programs
do: C's integer division, the session layer's check and header of the message being handled
(``msg``), and reading and writing little-endian fields of it and of the response being
built (``out``), sealed with the CRC-16 of the session layer and sent to the response mailbox.

The models mirror their NXC programs statement by statement (a lockstep test compares them
with the compiled programs), so these helpers keep the NXC programs' arithmetic: negative
values wrap to 16 bits, divisions truncate toward zero.
"""
from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from nxt_link.programs.stream_protocol import RESPONSE_QUEUE, crc16

if TYPE_CHECKING:
    from nxt_link.emulator.firmware import ProgramHost

__all__ = ["div", "MessageBytes"]

log = logging.getLogger(__name__)


def div(a: int, b: int) -> int:
    """C/NXC integer division: truncates toward zero."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


class MessageBytes:
    """The session layer's globals of a brick program: the message being handled (``msg``),
    its header, the response being built (``out``), the count of messages ignored, and the
    host that :meth:`send_out` sends through (set by the program's ``step``)."""

    def __init__(self) -> None:
        self.msg: bytes | bytearray = b""
        self.out = bytearray()
        self.rq_kind = 0
        self.rq_session = 0
        self.rq_seq = 0
        self.bad_messages = 0
        self._host: ProgramHost | None = None

    def open_message(self) -> int:
        """The length of ``msg`` without its check, its header read into ``rq_kind``,
        ``rq_session`` and ``rq_seq``; 0 (and one more of ``bad_messages``) when it is too
        short or fails its check, as both NXC programs' ``handle_message`` begins."""
        length = len(self.msg)
        if length < 7:
            self.bad_messages += 1
            return 0
        n = length - 2
        if crc16(bytes(self.msg[:n])) != self.rd_u16(n):
            self.bad_messages += 1
            log.debug("brick program: message failed its check")
            return 0
        self.rq_kind = self.rd_u8(0)
        self.rq_session = self.rd_u16(1)
        self.rq_seq = self.rd_u16(3)
        return n

    def rd_u8(self, i: int) -> int:
        return self.msg[i]

    def rd_u16(self, i: int) -> int:
        return self.msg[i] + self.msg[i + 1] * 256

    def rd_s16(self, i: int) -> int:
        v = self.msg[i] + self.msg[i + 1] * 256
        return v - 65536 if v > 32767 else v

    def wr_u8(self, i: int, v: int) -> None:
        self.out[i] = v & 0xFF

    def wr_16(self, i: int, v: int) -> None:
        if v < 0:
            v += 65536
        self.out[i] = v & 0xFF
        self.out[i + 1] = div(v, 256) & 0xFF

    def send_out(self, n: int) -> None:
        """Seal the first ``n`` bytes of the response with their CRC and send it."""
        self.wr_16(n, crc16(bytes(self.out[:n])))
        assert self._host is not None
        self._host.send_response_string(RESPONSE_QUEUE, bytes(self.out))
