"""Bluetooth framing: a 2-byte little-endian length prefix before every telegram.

:func:`frame` adds the prefix; :class:`FrameDecoder` reassembles telegrams from
reads that split or coalesce frames at arbitrary points. A serial byte stream
has no other frame marker, so the decoder also needs a way back into step
after damage:

* a length of 0 or above :data:`MAX_TELEGRAM` cannot be a frame: everything
  buffered is discarded (a *desync*);
* a frame that stays incomplete for longer than ``stale_after_s`` since its
  last byte is discarded (a *truncated* frame: the rest is never coming,
  e.g. the link dropped mid-frame).

The decoder is pure: the caller passes the time of each read from whatever
clock it lives on, so it works the same for the pty emulator (wall clock) and
the in-memory one (virtual clock).

>>> d = FrameDecoder()
>>> d.feed(b"\\x03\\x00\\x02\\x0b", now=0.0) + d.feed(b"\\x00\\x05", now=0.0)
[b'\\x02\\x0b\\x00']
>>> d.pending
b'\\x05'
"""
from __future__ import annotations

import logging
import struct
from dataclasses import dataclass

__all__ = ["MAX_TELEGRAM", "frame", "FrameDecoder", "DecoderStats"]

log = logging.getLogger(__name__)

#: Largest telegram either side accepts: the brick's Bluetooth buffer is 128
#: bytes including the 2-byte prefix (firmware SIZE_OF_BTBUF).
MAX_TELEGRAM = 126


def frame(telegram: bytes) -> bytes:
    """Prefix ``telegram`` with its 2-byte little-endian length.

    >>> frame(bytes.fromhex("00 0b")).hex(" ")
    '02 00 00 0b'
    """
    if not 0 < len(telegram) <= MAX_TELEGRAM:
        raise ValueError(f"telegram length {len(telegram)} outside 1..{MAX_TELEGRAM}")
    return struct.pack("<H", len(telegram)) + telegram


@dataclass(slots=True)
class DecoderStats:
    """Counters a caller can log or test: how much damage was thrown away."""

    frames: int = 0
    desyncs: int = 0
    stale_discards: int = 0
    bytes_discarded: int = 0


class FrameDecoder:
    """Incremental length-prefix decoder with desync and stale-frame recovery.

    Args:
        stale_after_s: discard an incomplete frame when no byte arrived for this
            long (in the caller's clock); ``None`` never discards.
        max_telegram: largest acceptable telegram length.
    """

    def __init__(self, stale_after_s: float | None = 0.25, max_telegram: int = MAX_TELEGRAM):
        self._buf = bytearray()
        self._last_byte_at: float | None = None
        self.stale_after_s = stale_after_s
        self.max_telegram = max_telegram
        self.stats = DecoderStats()

    @property
    def pending(self) -> bytes:
        """Bytes received that do not yet form a complete frame."""
        return bytes(self._buf)

    def reset(self) -> None:
        """Forget any partial frame (after a reconnect or an explicit resync)."""
        if self._buf:
            self.stats.bytes_discarded += len(self._buf)
        self._buf.clear()
        self._last_byte_at = None

    def expire(self, now: float) -> bool:
        """Discard a stale partial frame; return True if something was dropped."""
        if (self._buf and self.stale_after_s is not None and self._last_byte_at is not None
                and now - self._last_byte_at > self.stale_after_s):
            log.debug("discarding stale partial frame %s", self._buf.hex())
            self.stats.stale_discards += 1
            self.reset()
            return True
        return False

    def feed(self, data: bytes, now: float = 0.0) -> list[bytes]:
        """Add received bytes; return the telegrams (prefix removed) now complete."""
        self.expire(now)
        if data:
            self._buf += data
            self._last_byte_at = now
        out: list[bytes] = []
        while len(self._buf) >= 2:
            length = self._buf[0] | (self._buf[1] << 8)
            if length == 0 or length > self.max_telegram:
                log.debug("impossible frame length %d, discarding %s", length, self._buf.hex())
                self.stats.desyncs += 1
                self.reset()
                break
            if len(self._buf) < 2 + length:
                break
            out.append(bytes(self._buf[2:2 + length]))
            del self._buf[:2 + length]
            self.stats.frames += 1
        if not self._buf:
            self._last_byte_at = None
        return out
