"""pyserial transport: a real ``/dev/rfcommN`` or the emulator's pseudo-terminal.

The only module of the package that imports :mod:`serial`. It turns pyserial's
exceptions into the package's tree (``PortOpenError``, ``LinkDisconnectedError``,
``LinkTimeoutError``) and waits with ``select`` on the port's file descriptor
against a :class:`~nxt_link.clock.Deadline`, so a recv costs no more than the
time until the bytes arrive. Frames are reassembled by
:class:`~nxt_link.framing.FrameDecoder` whatever the read boundaries are.

Reconnecting means closing and reopening the same path: for a bound
``/dev/rfcommN`` that re-establishes the Bluetooth link, for the emulator the
path is a symlink it re-points at a fresh pty after a simulated disconnect.
"""
from __future__ import annotations

import logging
import os
import select
from collections import deque

import serial

from nxt_link.clock import MONOTONIC, Clock, Deadline
from nxt_link.errors import LinkDisconnectedError, LinkTimeoutError, PortOpenError
from nxt_link.framing import FrameDecoder, frame

__all__ = ["SerialTransport"]

log = logging.getLogger(__name__)

_POLL_S = 0.05


class SerialTransport:
    """Telegrams over a serial device (pyserial).

    Args:
        path: device path, e.g. ``/dev/rfcomm0`` or the emulator's pty symlink.
        clock: deadlines are measured on it; it must be a real clock (the
            bytes arrive in real time).
        write_timeout_s: give up a write after this long (a stuck device).
        stale_frame_s: drop a partial frame after this long without bytes.
        reconnect_interval_s: pause between reopen attempts.

    Raises:
        PortOpenError: the path cannot be opened as a serial port.
    """

    def __init__(self, path: str, *, clock: Clock = MONOTONIC, write_timeout_s: float = 2.0,
                 stale_frame_s: float = 0.25, reconnect_interval_s: float = 0.1) -> None:
        self.name = path
        self.clock = clock
        self._write_timeout_s = write_timeout_s
        self._reconnect_interval_s = reconnect_interval_s
        self._decoder = FrameDecoder(stale_after_s=stale_frame_s)
        self._ready: deque[bytes] = deque()
        self._port: serial.Serial | None = None
        self._open()

    # -- lifecycle ---------------------------------------------------------

    def _open(self) -> None:
        if not os.path.exists(self.name):
            raise PortOpenError(f"cannot open {self.name}: no such device")
        try:
            self._port = serial.Serial(self.name, baudrate=115200, timeout=0,
                                       write_timeout=self._write_timeout_s)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise PortOpenError(f"cannot open {self.name}: {_reason(exc)}") from None
        try:
            self._port.reset_input_buffer()  # nothing stale from an earlier connection
        except (serial.SerialException, OSError):
            pass
        self._decoder.reset()
        self._ready.clear()
        log.info("opened %s", self.name)

    def close(self) -> None:
        if self._port is not None:
            try:
                self._port.close()
            except (serial.SerialException, OSError):
                pass
            self._port = None
            log.info("closed %s", self.name)

    def reconnect(self, deadline: Deadline) -> None:
        self.close()
        last: Exception | None = None
        while True:
            try:
                self._open()
                return
            except PortOpenError as exc:
                last = exc
            if deadline.expired():
                raise LinkDisconnectedError(f"{self.name}: could not reconnect ({last})")
            self.clock.sleep(min(self._reconnect_interval_s, deadline.remaining() or 0.0))

    def __enter__(self) -> SerialTransport:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- I/O ----------------------------------------------------------------

    def _require(self) -> serial.Serial:
        if self._port is None:
            raise LinkDisconnectedError(f"{self.name}: link is closed")
        return self._port

    def send(self, telegram: bytes) -> None:
        port = self._require()
        data = frame(telegram)
        log.debug("%s send %s", self.name, data.hex())
        try:
            port.write(data)
        except serial.SerialTimeoutException:
            raise LinkTimeoutError(f"{self.name}: write timed out") from None
        except (serial.SerialException, OSError) as exc:
            self.close()
            raise LinkDisconnectedError(f"{self.name}: {_reason(exc)}") from None

    def _read_available(self, wait_s: float) -> bytes:
        port = self._require()
        try:
            ready, _, _ = select.select([port.fileno()], [], [], max(0.0, wait_s))
            if not ready:
                return b""
            data = port.read(max(1, port.in_waiting))
        except (serial.SerialException, OSError, ValueError) as exc:
            self.close()
            raise LinkDisconnectedError(f"{self.name}: link lost ({_reason(exc)})") from None
        if data:
            log.debug("%s recv %s", self.name, data.hex())
        return data

    def recv(self, deadline: Deadline) -> bytes:
        while True:
            if self._ready:
                return self._ready.popleft()
            remaining = deadline.remaining()
            wait = _POLL_S if remaining is None else min(_POLL_S, remaining)
            data = self._read_available(wait)
            self._ready.extend(self._decoder.feed(data, self.clock.now()))
            if self._ready:
                continue
            if deadline.expired():
                raise LinkTimeoutError(f"{self.name}: no reply within {deadline.timeout_s:g} s")

    def discard_input(self, quiet_s: float) -> int:
        dropped = sum(len(t) + 2 for t in self._ready) + len(self._decoder.pending)
        self._ready.clear()
        self._decoder.reset()
        limit = Deadline(self.clock, max(1.0, 20 * quiet_s))
        while not limit.expired():
            data = self._read_available(quiet_s)
            if not data:
                break
            dropped += len(data)
        if dropped:
            log.debug("%s discarded %d byte(s)", self.name, dropped)
        return dropped


def _reason(exc: BaseException) -> str:
    text = str(exc) or type(exc).__name__
    if isinstance(exc, serial.SerialException) and exc.args and isinstance(exc.args[0], int):
        text = os.strerror(exc.args[0])
    # pyserial wraps OSError as "[Errno 2] could not open port X: [Errno 2] No such file..."
    if "] " in text:
        text = text.rsplit("] ", 1)[-1]
    return text.strip().rstrip(":") or type(exc).__name__
