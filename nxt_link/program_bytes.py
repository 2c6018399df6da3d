"""What the Python models of the brick programs share with each other, as the NXC programs
do: C's integer division, and reading and writing little-endian fields of the message being
handled (``msg``) and of the response being built (``out``), sealed with the CRC-16 of the
session layer and sent to the response mailbox.

The models mirror their NXC programs statement by statement (a lockstep test compares them
with the compiled programs), so these helpers keep the NXC programs' arithmetic: negative
values wrap to 16 bits, divisions truncate toward zero.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from nxt_link.stream_protocol import RESPONSE_QUEUE, crc16

if TYPE_CHECKING:
    from nxt_link.firmware import ProgramHost

__all__ = ["div", "MessageBytes"]


def div(a: int, b: int) -> int:
    """C/NXC integer division: truncates toward zero."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


class MessageBytes:
    """Field access on ``self.msg`` (bytes received) and ``self.out`` (the response), and
    :meth:`send_out` through ``self._host``; the program classes set all three."""

    msg: bytes | bytearray
    out: bytearray
    _host: ProgramHost | None

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
