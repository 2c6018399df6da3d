"""pyserial transport: a real ``/dev/rfcommN`` or the emulator's pseudo-terminal.

The only module of the package that imports :mod:`serial`. It turns pyserial's
exceptions into the package's tree (``PortOpenError``, ``LinkDisconnectedError``,
``LinkTimeoutError``) and waits with ``select`` on the port's file descriptor
against a :class:`~nxt_link.wire.clock.Deadline`, so a recv costs no more than the
time until the bytes arrive. Frames are reassembled by
:class:`~nxt_link.wire.framing.FrameDecoder` whatever the read boundaries are.

Reconnecting means closing and reopening the same path: for a bound
``/dev/rfcommN`` that re-establishes the Bluetooth link, for the emulator the
path is a symlink it re-points at a fresh pty after a simulated disconnect.

On a :class:`~nxt_link.wire.clock.SimClock` (a brick emulated in this process by a
:class:`~nxt_link.emulator.pty_server.PtyBrickServer` on the same clock) the bytes still go
through pyserial and the pty, but every wait is a wait on the simulated clock: the
transport counts what it writes and reads on the pty's
:class:`~nxt_link.wire.clock.Channel`, and a read waits for the bytes the clock counted
(or for the deadline) instead of selecting on the port in real time.
"""
from __future__ import annotations

import logging
import os
import select
from collections import deque

import serial

from nxt_link.wire.clock import MONOTONIC, READABLE, Channel, Clock, Deadline, SimClock
from nxt_link.wire.errors import LinkDisconnectedError, LinkTimeoutError, PortOpenError
from nxt_link.wire.framing import FrameDecoder, frame

__all__ = ["SerialTransport"]

log = logging.getLogger(__name__)

_POLL_S = 0.05
#: Real time within which bytes counted on a simulated clock must show up (see
#: :data:`nxt_link.emulator.pty_server.ARRIVAL_S`).
_ARRIVAL_S = 5.0


class SerialTransport:
    """Telegrams over a serial device (pyserial).

    Args:
        path: device path, e.g. ``/dev/rfcomm0`` or the emulator's pty symlink.
        clock: deadlines are measured on it: a real clock (the bytes arrive in
            real time), or the :class:`~nxt_link.wire.clock.SimClock` of the in-process
            emulated brick behind ``path``.
        write_timeout_s: give up a write after this long (a stuck device).
        stale_frame_s: drop a partial frame after this long without bytes.
        reconnect_interval_s: pause between reopen attempts.
        label: how messages and events name the link (default ``path``): an in-process
            emulated brick's pty lives in a fresh temporary directory, and a run's log must
            not depend on its name.

    Raises:
        PortOpenError: the path cannot be opened as a serial port.
    """

    def __init__(self, path: str, *, clock: Clock = MONOTONIC, write_timeout_s: float = 2.0,
                 stale_frame_s: float = 0.25, reconnect_interval_s: float = 0.1,
                 label: str | None = None) -> None:
        self.path = path
        self.name = label or path
        self.clock = clock
        self._write_timeout_s = write_timeout_s
        self._reconnect_interval_s = reconnect_interval_s
        self._decoder = FrameDecoder(stale_after_s=stale_frame_s)
        self._ready: deque[bytes] = deque()
        self._port: serial.Serial | None = None
        self._sim: SimClock | None = clock if isinstance(clock, SimClock) else None
        self._channel: Channel | None = None
        self._open()

    # -- lifecycle ---------------------------------------------------------

    def _open(self) -> None:
        if not os.path.exists(self.path):
            raise PortOpenError(f"cannot open {self.name}: no such device")
        if self._sim is not None:
            self._channel = self._sim.channel(os.path.realpath(self.path))
            if self._channel is None:
                raise PortOpenError(f"cannot open {self.name}: no brick on this simulated clock "
                                    "serves it")
        try:
            self._port = serial.Serial(self.path, baudrate=115200, timeout=0,
                                       write_timeout=self._write_timeout_s)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise PortOpenError(f"cannot open {self.name}: {_reason(exc)}") from None
        try:
            self._port.reset_input_buffer()  # nothing stale from an earlier connection
        except (serial.SerialException, OSError):
            pass
        if self._sim is not None and self._channel is not None:
            self._sim.lost(self._channel.to_pc)   # pyserial flushed whatever was counted
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
        pipe = self._channel.to_brick if self._sim is not None and self._channel is not None else None
        if pipe is not None:
            self._sim.wrote(pipe, len(data))  # type: ignore[union-attr]
        try:
            port.write(data)
        except serial.SerialTimeoutException:
            if pipe is not None:
                self._sim.lost(pipe)  # type: ignore[union-attr]
            raise LinkTimeoutError(f"{self.name}: write timed out") from None
        except (serial.SerialException, OSError) as exc:
            if pipe is not None:
                self._sim.lost(pipe)  # type: ignore[union-attr]
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

    def _read_simulated(self, until: float | None) -> bytes:
        """On a simulated clock: wait on it for counted bytes (or ``until``), then read them."""
        port = self._require()
        sim, channel = self._sim, self._channel
        assert sim is not None and channel is not None
        if sim.wait_readable(channel.to_pc, until) != READABLE:
            return b""
        port = self._require()
        try:
            ready, _, _ = select.select([port.fileno()], [], [], _ARRIVAL_S)
            if not ready:
                log.warning("%s: %d counted byte(s) never arrived", self.name, channel.to_pc.pending)
                sim.lost(channel.to_pc)
                return b""
            data = port.read(max(1, port.in_waiting))
        except (serial.SerialException, OSError, ValueError) as exc:
            self.close()
            raise LinkDisconnectedError(f"{self.name}: link lost ({_reason(exc)})") from None
        sim.consumed(channel.to_pc, len(data))
        if data:
            log.debug("%s recv %s", self.name, data.hex())
        elif channel.closed:
            self.close()
            raise LinkDisconnectedError(f"{self.name}: link lost (the pty closed)")
        return data

    def recv(self, deadline: Deadline) -> bytes:
        while True:
            if self._ready:
                return self._ready.popleft()
            if self._sim is not None:
                data = self._read_simulated(deadline.at)
                self._ready.extend(self._decoder.feed(data, self.clock.now()))
                if self._ready:
                    continue
                if deadline.expired():
                    raise LinkTimeoutError(f"{self.name}: no reply within {deadline.timeout_s:g} s")
                continue
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
            if self._sim is not None:
                data = self._read_simulated(self.clock.now() + quiet_s)
            else:
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
