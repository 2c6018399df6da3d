"""Bricks emulated in this process, each on its own pseudo-terminal, for the commands that
run without a real brick (``cplus run``, ``execute``, ``online``, ``serve --robot``).

:class:`EmulatedBricks` starts one :class:`~nxt_link.emulator.pty_server.PtyBrickServer` per brick
and opens a :class:`~nxt_link.wire.serial_transport.SerialTransport` (pyserial, on the pty) to
each, so the PC side runs exactly the serial path it runs with a real brick.

By default everything runs on one :class:`~nxt_link.wire.clock.SimClock`: the bricks, the link's
timeouts and the thread that uses the bricks (a participant while the bricks are open) read
simulated time, which moves only as the emulation does. A run's outcome then depends on its
inputs alone — a loaded machine makes it slower, never makes a brick look lost — and the
same seed gives the same run, byte for byte: the link model's jitter, the faults and the
world's sensor noise are seeded from ``seed`` (each brick its own), and so are the session
ids (:meth:`EmulatedBricks.session_ids`), which otherwise come from the system's random
source. With a ``time_scale`` the bricks run on the wall clock instead, that many times
faster than real time, as a ``cplus brick`` process does (``1``: real time).
"""
from __future__ import annotations

import random
from collections.abc import Iterable
from contextlib import ExitStack
from dataclasses import replace
from types import TracebackType
from typing import TYPE_CHECKING

from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig
from nxt_link.emulator.pty_server import PtyBrickServer
from nxt_link.wire.clock import MONOTONIC, Clock, SimClock

if TYPE_CHECKING:
    from nxt_link.wire.serial_transport import SerialTransport

__all__ = ["EmulatedBricks"]


class EmulatedBricks:
    """In-process emulated bricks on ptys; a context manager (or :meth:`open`/:meth:`close`).

    Args:
        time_scale: None (default): simulated time on a fresh :class:`SimClock`; a number:
            the wall clock, that many times faster than real time.
        seed: the random seed of the first brick's link, faults and world (the next brick
            gets ``seed + 1``, ...) where its config has none, and of the session ids.
        compiled: run the brick programs compiled (``cplus_follow.rxe``,
            ``cplus_legolog.rxe``, by nbc, cached) on the bytecode interpreter when nbc is
            there; False: their Python models.
    """

    def __init__(self, time_scale: float | None = None, *, seed: int = 0, compiled: bool = False) -> None:
        if time_scale is not None and not time_scale > 0:
            raise ValueError("time scale must be > 0")
        self.time_scale = time_scale
        self.seed = seed
        self.compiled = compiled
        self.clock: Clock = SimClock() if time_scale is None else MONOTONIC
        self.servers: dict[str, PtyBrickServer] = {}
        self.transports: dict[str, SerialTransport] = {}
        self._stack = ExitStack()
        self._rng = random.Random(f"session ids {seed}")

    @property
    def simulated(self) -> bool:
        return isinstance(self.clock, SimClock)

    def open(self) -> EmulatedBricks:
        """Make the calling thread a participant of the simulated clock (until :meth:`close`)."""
        if isinstance(self.clock, SimClock):
            self._stack.enter_context(self.clock.participant("pc"))
        return self

    def configure(self, config: EmulatorConfig) -> EmulatorConfig:
        """``config`` as this emulation runs it: its seed, the stale-frame time on the
        bricks' clock, the compiled program."""
        scale = self.time_scale or 1.0
        faults = config.faults
        if self.simulated:   # each brick its own seed; on the wall clock nothing repeats anyway
            base = self.seed if faults.seed is None else faults.seed
            faults = replace(faults, seed=base + len(self.servers))
        config = replace(config, faults=faults, stale_frame_ms=config.stale_frame_ms * scale)
        if self.compiled and not config.flash_files:
            files = _compiled(config.startup_program)
            if files is not None:
                config = replace(config, flash_files=files[0], symbols=files[1])
        return config

    def add(self, config: EmulatorConfig) -> SerialTransport:
        """Start a brick and return an open transport to it (its server is
        ``servers[config.name]``)."""
        from nxt_link.wire.serial_transport import SerialTransport  # pyserial, only when used
        config = self.configure(config)
        clock = self.clock if isinstance(self.clock, SimClock) else None
        server = PtyBrickServer(BrickEmulator(config), time_scale=1.0 if clock else self.time_scale or 1.0,
                                clock=clock)
        server.start()
        self._stack.callback(server.stop)
        self.servers[config.name] = server
        transport = SerialTransport(server.path, clock=self.clock,
                                    label=f"emulated brick {config.name}" if clock else None)
        self._stack.callback(transport.close)
        self.transports[config.name] = transport
        return transport

    def session_ids(self, names: Iterable[str]) -> dict[str, int] | None:
        """Fresh session ids for ``names``, from the seed (simulated time; None otherwise:
        the system's random source, as with real bricks)."""
        if not self.simulated:
            return None
        return {name: self._rng.randrange(1, 0x10000) for name in names}

    def close(self) -> None:
        """Close the links, stop the bricks, and leave the simulated clock."""
        self._stack.close()

    def __enter__(self) -> EmulatedBricks:
        return self.open()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _compiled(program: str) -> tuple[dict[str, bytes], dict[str, str]] | None:
    """The compiled program's flash files and symbols, or None without nbc."""
    from nxt_link.emulator.emulator import compiled_follower, compiled_legolog
    from nxt_link.emulator.vm import NbcMissingError
    from nxt_link.programs import behaviour_protocol
    from nxt_link.programs.stream_protocol import PROGRAM_NAME
    try:
        if program == PROGRAM_NAME:
            return compiled_follower()
        if program == behaviour_protocol.PROGRAM_NAME:
            return compiled_legolog()
    except NbcMissingError:
        return None
    return None
