"""In-memory transport to a :class:`~nxt_link.emulator.emulator.BrickEmulator`, on a virtual clock.

The unit-test twin of :class:`~nxt_link.wire.serial_transport.SerialTransport`:
same contract, same framing code on both ends, but time is a
:class:`~nxt_link.wire.clock.VirtualClock` that moves only while the client waits.
``recv`` runs the emulator millisecond by millisecond until a frame is
delivered or the deadline passes, so a test with a 10-second trajectory and
dropped frames finishes in a fraction of a second and never depends on the
machine's load. Several transports may share one clock (two bricks); each
emulator catches up with the clock whenever it is used.

``damage`` lets a test decide the fate of every frame the brick sends, exactly:
it gets the frame's index (0, 1, ... in the order the brick sent them) and its
bytes (length prefix included) and returns the bytes to deliver instead
(damaged, truncated, lengthened, several frames or none at all). The random
faults of :class:`~nxt_link.emulator.emulator.FaultParams` are for soak runs; this is
for deterministic tests of one kind of damage at one place.
"""
from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable

from nxt_link.emulator.emulator import BrickEmulator
from nxt_link.wire.clock import Deadline, VirtualClock
from nxt_link.wire.errors import LinkDisconnectedError, LinkTimeoutError
from nxt_link.wire.framing import FrameDecoder, frame

__all__ = ["MemoryTransport"]

log = logging.getLogger(__name__)


class MemoryTransport:
    """Telegrams straight into an emulator; ``clock`` must be a VirtualClock."""

    def __init__(self, emulator: BrickEmulator, clock: VirtualClock, name: str | None = None,
                 stale_frame_s: float = 0.25,
                 damage: Callable[[int, bytes], bytes] | None = None) -> None:
        self.emulator = emulator
        self.clock = clock
        self.name = name or f"memory:{emulator.config.name}"
        self._decoder = FrameDecoder(stale_after_s=stale_frame_s)
        self._ready: deque[bytes] = deque()
        self._epoch = emulator.link_epoch
        self._closed = False
        self._damage = damage
        self.frames_out = 0

    def _now_ms(self) -> float:
        # the emulator counts whole milliseconds; keep float noise out of comparisons
        return round(self.clock.now() * 1000.0, 6)

    def _check(self) -> None:
        if self._closed:
            raise LinkDisconnectedError(f"{self.name}: link is closed")
        if not self.emulator.link_up or self.emulator.link_epoch != self._epoch:
            raise LinkDisconnectedError(f"{self.name}: link lost")

    def send(self, telegram: bytes) -> None:
        self._check()
        now = self._now_ms()
        self.emulator.advance_to(now)
        self.emulator.receive(frame(telegram), now)

    def _collect(self, now: float | None = None) -> None:
        if now is None:
            now = self._now_ms()
        for data in self.emulator.take_output(now):
            if self._damage is not None:
                data = self._damage(self.frames_out, data)
            self.frames_out += 1
            self._ready.extend(self._decoder.feed(data, now / 1000.0))

    def recv(self, deadline: Deadline) -> bytes:
        while True:
            if self._ready:
                return self._ready.popleft()
            self._check()
            limit_ms = float("inf") if deadline.at is None else deadline.at * 1000.0
            if limit_ms == float("inf"):
                limit_ms = self._now_ms() + 3_600_000.0
            self.emulator.advance_to(self._now_ms())
            if self.emulator.run_until_output(limit_ms):
                self.clock.advance_to(self.emulator.now_ms / 1000.0)
                self._collect(max(self._now_ms(), self.emulator.now_ms))
                continue
            self._check()
            self.clock.advance_to(limit_ms / 1000.0)
            self._collect()
            if self._ready:
                continue
            raise LinkTimeoutError(f"{self.name}: no reply within {deadline.timeout_s:g} s")

    def discard_input(self, quiet_s: float) -> int:
        dropped = sum(len(t) + 2 for t in self._ready) + len(self._decoder.pending)
        self._ready.clear()
        self._decoder.reset()
        if self.emulator.link_up:
            end = self._now_ms() + quiet_s * 1000.0
            self.emulator.advance_to(self._now_ms())
            while self.emulator.run_until_output(end):
                self.clock.advance_to(self.emulator.now_ms / 1000.0)
                late = self.emulator.take_output(max(self._now_ms(), self.emulator.now_ms))
                self.frames_out += len(late)
                dropped += sum(len(d) for d in late)
                end = self._now_ms() + quiet_s * 1000.0
            self.clock.advance_to(end / 1000.0)
        return dropped

    def reconnect(self, deadline: Deadline) -> None:
        if self._closed:
            raise LinkDisconnectedError(f"{self.name}: link is closed")
        self.clock.sleep(0.1)
        self.emulator.restore_link()
        self._epoch = self.emulator.link_epoch
        self._decoder.reset()
        self._ready.clear()
        log.info("%s: reconnected", self.name)

    def close(self) -> None:
        self._closed = True
