"""Shared fixtures for the nxt_link tests: emulated bricks in memory and on ptys."""
from __future__ import annotations

import math

import pytest

from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.pty_server import PtyBrickServer
from nxt_link.host.brick import Brick, RetryPolicy
from nxt_link.wire.clock import VirtualClock

FAST = RetryPolicy(reply_timeout_s=0.2, retries=3, quiet_s=0.02, reconnect_timeout_s=2.0)


def make_emulator(name: str = "r1", *, faults: FaultParams | None = None,
                  link: LinkParams | None = None, program_running: bool = True,
                  **kw) -> BrickEmulator:
    return BrickEmulator(EmulatorConfig(
        name=name, link=link or LinkParams.instant(), faults=faults or FaultParams(),
        program_running=program_running, **kw))


class MemoryRig:
    """Emulated bricks on one virtual clock, each behind a MemoryTransport + Brick."""

    def __init__(self) -> None:
        self.clock = VirtualClock()
        self.emulators: dict[str, BrickEmulator] = {}
        self.bricks: dict[str, Brick] = {}
        self.events: list = []

    def add(self, name: str = "r1", policy: RetryPolicy = FAST, damage=None, **kw) -> Brick:
        emu = make_emulator(name, **kw)
        self.emulators[name] = emu
        brick = Brick(MemoryTransport(emu, self.clock, damage=damage), name=name, policy=policy,
                      on_event=self.events.append)
        self.bricks[name] = brick
        return brick


@pytest.fixture
def rig() -> MemoryRig:
    return MemoryRig()


@pytest.fixture
def pty_server():
    """Start emulated bricks on ptys (instant link, 10x time, or on ``clock``, a SimClock that
    the test's thread takes part in); all stopped at the end."""
    servers: list[PtyBrickServer] = []

    def start(name: str = "r1", *, time_scale: float = 10.0, clock=None, **kw) -> PtyBrickServer:
        if clock is not None:
            time_scale = 1.0
        kw.setdefault("stale_frame_ms", 250.0 * time_scale)
        server = PtyBrickServer(make_emulator(name, **kw), time_scale=time_scale, clock=clock)
        server.start()
        servers.append(server)
        return server

    yield start
    for s in servers:
        s.stop()
        assert s.error is None, f"emulator thread failed: {s.error!r}"


def wave_rows(n: int, amplitudes: tuple[int, ...], period_ticks: float = 40.0
              ) -> tuple[tuple[int, ...], ...]:
    """A smooth trajectory starting at zero (what a planned arm motion looks like)."""
    return tuple(tuple(int(round(a * math.sin(2 * math.pi * k / (period_ticks * (1 + 0.5 * j)))))
                       for j, a in enumerate(amplitudes))
                 for k in range(n))


@pytest.fixture
def wave():
    return wave_rows
