"""The brick emulator: firmware + brick program + motors behind a modelled Bluetooth link.

:class:`BrickEmulator` is a discrete-time simulation in 1 ms steps with no
clock and no I/O of its own. Its host feeds it the bytes the PC wrote
(:meth:`BrickEmulator.receive`), moves simulated time forward
(:meth:`BrickEmulator.advance_to`) and collects the frames whose delivery time
has come (:meth:`BrickEmulator.take_output`). Two hosts exist:

* :class:`nxt_link.emulator.pty_server.PtyBrickServer` — real time (optionally scaled)
  on a pseudo-terminal, for ``cplus brick`` and every pty-based test;
* :class:`nxt_link.emulator.memory_transport.MemoryTransport` — virtual time, in-process,
  for fast deterministic unit tests.

Link model (:class:`LinkParams`, protocol doc §7.2): each frame takes a one-way
delay (15 +- 5 ms) in each direction, in order; a reply leaves 1 ms after its
command is processed and the brick processes nothing else for 30 ms after a
reply left (the BlueCore receive/transmit turnaround); rare stalls (0.1 %,
0.5-2 s). :meth:`LinkParams.instant` turns all of it off for tests.

Faults (:class:`FaultParams`), each frame decided independently by a seeded
random generator:

* ``drop``: the frame is lost, in either direction;
* ``corrupt``: one byte of a reply frame (length prefix included) is flipped,
  or one payload byte of an incoming MESSAGEWRITE. Other incoming commands are
  left intact on purpose: the NXT protocol has no checksum, so a flipped
  opcode could turn a MESSAGEREAD into a STOPPROGRAM — no client can defend
  against that, and real RFCOMM links do not corrupt bytes that way. Message
  payloads are exactly what the streaming protocol's CRC-16 protects;
* ``delay_ms``: added to every frame's one-way delay, in both directions;
* ``disconnect_after``: after that many frames received the link drops once,
  losing whatever was in flight; the host reconnects it (a new pty behind the
  same symlink) while the brick, its program and its mailboxes keep running,
  as a real brick does when the Bluetooth link drops.

Around the brick (``EmulatorConfig.world``, ``EmulatorConfig.stalls``): a
:class:`~nxt_link.emulator.world.World` (a line track the robot drives on, which its light and
touch sensors read) and :class:`~nxt_link.emulator.stall.Stall` s (a motor held still
mid-trajectory). Two programs are installed, ``cplus_follow.rxe`` (the setpoint follower)
and ``cplus_legolog.rxe`` (the Legolog behaviour program), as Python models for when
their compiled files are not in flash; ``EmulatorConfig.start_program`` says which one
runs from power-on.
"""
from __future__ import annotations

import logging
import random
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.emulator.follower_program import FollowerProgram
from nxt_link.emulator.legolog_program import LegologProgram
from nxt_link.emulator.motor_model import MotorParams
from nxt_link.emulator.stall import Stall, StallSchedule
from nxt_link.emulator.vm.nbc import cached_compile, follower_source
from nxt_link.emulator.vm.program import FollowerView, Symbols, VMProgram
from nxt_link.emulator.world import World, WorldSpec
from nxt_link.programs import behaviour_protocol
from nxt_link.programs.stream_protocol import PROGRAM_NAME
from nxt_link.wire.framing import FrameDecoder, frame
from nxt_link.wire.telegram import Opcode

__all__ = ["LinkParams", "FaultParams", "EmulatorConfig", "EmulatorStats", "BrickEmulator",
           "compiled_follower", "compiled_legolog"]

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class LinkParams:
    """Bluetooth timing model (defaults from the protocol doc §7.2).

    Attributes:
        one_way_ms: mean one-way transfer delay per frame.
        jitter_ms: uniform +- jitter on the one-way delay.
        processing_ms: time from processing a command to its reply leaving.
        turnaround_ms: the brick processes no command for this long after a
            reply left (radio receive/transmit switch).
        stall_probability: chance per frame of an extra stall.
        stall_min_ms, stall_max_ms: range of a stall.
    """

    one_way_ms: float = 15.0
    jitter_ms: float = 5.0
    processing_ms: float = 1.0
    turnaround_ms: float = 30.0
    stall_probability: float = 0.001
    stall_min_ms: float = 500.0
    stall_max_ms: float = 2000.0

    @classmethod
    def instant(cls) -> LinkParams:
        """No latency at all (unit tests)."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if min(self.one_way_ms, self.jitter_ms, self.processing_ms, self.turnaround_ms,
               self.stall_min_ms, self.stall_max_ms) < 0:
            raise ValueError("link delays must be >= 0")
        if self.jitter_ms > self.one_way_ms:
            raise ValueError("jitter_ms must not exceed one_way_ms")
        if not 0 <= self.stall_probability <= 1:
            raise ValueError("stall_probability must be in [0, 1]")


@dataclass(frozen=True, slots=True)
class FaultParams:
    """Fault injection (see the module docstring for what each one touches)."""

    drop: float = 0.0
    corrupt: float = 0.0
    delay_ms: float = 0.0
    disconnect_after: int | None = None
    seed: int | None = None

    def __post_init__(self) -> None:
        if not 0 <= self.drop < 1:
            raise ValueError("drop probability must be in [0, 1)")
        if not 0 <= self.corrupt < 1:
            raise ValueError("corrupt probability must be in [0, 1)")
        if self.delay_ms < 0:
            raise ValueError("delay must be >= 0 ms")
        if self.disconnect_after is not None and self.disconnect_after < 1:
            raise ValueError("disconnect-after must be >= 1 frame")


@dataclass(frozen=True, slots=True)
class EmulatorConfig:
    """Everything that defines one emulated brick.

    Attributes:
        name: the brick's name (GETDEVICEINFO, log messages).
        program_running: the brick program runs from power-on (as if started
            from the brick's menu); False: the PC must STARTPROGRAM it.
        flash_files: files in the brick's flash at power-on (name -> bytes),
            e.g. the compiled ``cplus_follow.rxe`` (:func:`compiled_follower`).
            Without a compiled ``cplus_follow.rxe`` the firmware runs the
            Python model of the program.
        symbols: NBC symbol tables of those programs (name -> text), to read
            their variables (:attr:`BrickEmulator.program`).
        start_program: the program that runs from power-on; default
            ``cplus_follow.rxe``, or ``cplus_legolog.rxe`` when there is a world
            (:attr:`startup_program`).
        stale_frame_ms: a partial incoming frame with no new byte for this
            long (simulated ms) is discarded.
        world: the track the robot drives on and senses (None: motors turn freely,
            sensors read nothing).
        stalls: motors to hold still mid-trajectory.
    """

    name: str = "NXT"
    firmware: FirmwareParams = field(default_factory=FirmwareParams)
    motors: MotorParams | tuple[MotorParams, ...] = field(default_factory=MotorParams)
    link: LinkParams = field(default_factory=LinkParams)
    faults: FaultParams = field(default_factory=FaultParams)
    program_running: bool = True
    stale_frame_ms: float = 250.0
    flash_files: Mapping[str, bytes] = field(default_factory=dict)
    symbols: Mapping[str, str] = field(default_factory=dict)
    start_program: str | None = None
    world: WorldSpec | None = None
    stalls: tuple[Stall, ...] = ()

    def __post_init__(self) -> None:
        ports = [s.port for s in self.stalls]
        if len(set(ports)) != len(ports):
            raise ValueError("two stalls on one port")

    @property
    def startup_program(self) -> str:
        """The program that runs from power-on (see ``start_program``)."""
        if self.start_program is not None:
            return self.start_program
        return behaviour_protocol.PROGRAM_NAME if self.world is not None else PROGRAM_NAME


#: Python models of the project's brick programs, run when their compiled file is not in
#: the brick's flash.
PROGRAMS = {PROGRAM_NAME: FollowerProgram, behaviour_protocol.PROGRAM_NAME: LegologProgram}


def compiled_legolog() -> tuple[dict[str, bytes], dict[str, str]]:
    """``cplus_legolog.rxe`` compiled by nbc (cached) as ``flash_files`` and ``symbols``;
    raises :class:`nxt_link.emulator.vm.NbcMissingError` without nbc."""
    name = behaviour_protocol.PROGRAM_NAME
    compiled = cached_compile(Path(behaviour_protocol.__file__).resolve().parent / "nxc"
                              / name.replace(".rxe", ".nxc"))
    return {name: compiled.rxe}, {name: compiled.symbols}


def compiled_follower() -> tuple[dict[str, bytes], dict[str, str]]:
    """``cplus_follow.rxe`` compiled by nbc (cached) as ``flash_files`` and ``symbols``;
    raises :class:`nxt_link.emulator.vm.NbcMissingError` without nbc."""
    compiled = cached_compile(follower_source())
    return {PROGRAM_NAME: compiled.rxe}, {PROGRAM_NAME: compiled.symbols}


@dataclass(slots=True)
class EmulatorStats:
    frames_in: int = 0
    frames_out: int = 0
    dropped_in: int = 0
    dropped_out: int = 0
    corrupted_in: int = 0
    corrupted_out: int = 0
    stalls: int = 0
    disconnects: int = 0


class BrickEmulator:
    """One emulated brick; times are simulated milliseconds (floats allowed)."""

    def __init__(self, config: EmulatorConfig | None = None) -> None:
        self.config = config or EmulatorConfig()
        fw_params = self.config.firmware
        if fw_params.name != self.config.name:
            fw_params = replace(fw_params, name=self.config.name[:14])
        self.firmware = Firmware(fw_params, self.config.motors,
                                 programs=dict(PROGRAMS),  # type: ignore[arg-type]
                                 flash_files=self.config.flash_files)
        self.world: World | None = None
        if self.config.world is not None:
            self.world = World(self.config.world, seed=self.config.faults.seed)
            self.firmware.attach(self.world)
        self.stalls = [StallSchedule(s) for s in self.config.stalls]
        for schedule in self.stalls:
            self.firmware.attach(schedule)
        if self.config.program_running:
            self.firmware.start_program_now(self.config.startup_program)
        self.stats = EmulatorStats()
        self._rng = random.Random(self.config.faults.seed)
        self._decoder = FrameDecoder(stale_after_s=self.config.stale_frame_ms / 1000.0)
        self._inbound: deque[tuple[float, bytes]] = deque()
        self._outbound: deque[tuple[float, bytes]] = deque()
        self._last_in_ms = 0.0
        self._last_out_ms = 0.0
        self._busy_until_ms = 0.0
        self._disconnected_once = False
        self.link_up = True
        self.link_epoch = 0

    # -- time -----------------------------------------------------------------

    @property
    def now_ms(self) -> int:
        return self.firmware.now_ms

    def advance_to(self, t_ms: float, until_reply: bool = False) -> None:
        """Run the brick up to simulated time ``t_ms`` (1 ms firmware steps); with
        ``until_reply``, stop early at the millisecond a command is answered with a frame
        that is deliverable at once (a host on real time then sends it without first
        running the rest of the way)."""
        fw = self.firmware
        inbound, outbound = self._inbound, self._outbound
        self._process_due()
        while fw.now_ms + 1 <= t_ms:
            fw.tick()
            if inbound and inbound[0][0] <= fw.now_ms:
                self._process_due()
                if until_reply and outbound and outbound[0][0] <= fw.now_ms:
                    return

    def run_until_output(self, limit_ms: float) -> bool:
        """Advance until a frame is deliverable or ``limit_ms``; True if one is."""
        fw = self.firmware
        inbound, outbound = self._inbound, self._outbound
        self._process_due()
        while True:
            if outbound and outbound[0][0] <= fw.now_ms:
                return True
            if fw.now_ms + 1 > limit_ms or not self.link_up:
                return False
            fw.tick()
            if inbound and inbound[0][0] <= fw.now_ms:
                self._process_due()

    # -- link: PC -> brick ---------------------------------------------------------

    def receive(self, data: bytes, at_ms: float) -> None:
        """Bytes the PC wrote, arriving at the brick's radio at ``at_ms``."""
        if not self.link_up:
            return
        for telegram in self._decoder.feed(data, at_ms / 1000.0):
            self._accept(telegram, at_ms)
            if not self.link_up:
                return

    def _accept(self, telegram: bytes, at_ms: float) -> None:
        faults = self.config.faults
        self.stats.frames_in += 1
        if (faults.disconnect_after is not None and not self._disconnected_once
                and self.stats.frames_in >= faults.disconnect_after):
            self._disconnected_once = True
            self.disconnect()
            return
        if faults.drop and self._rng.random() < faults.drop:
            self.stats.dropped_in += 1
            log.debug("%s: dropped incoming %s", self.config.name, telegram.hex())
            return
        if (faults.corrupt and len(telegram) > 5 and telegram[1] == Opcode.MESSAGE_WRITE
                and self._rng.random() < faults.corrupt):
            size = telegram[3]
            end = min(len(telegram) - 1, 4 + size - 1)  # payload bytes, not the NUL
            if end > 4:
                i = self._rng.randrange(4, end)
                b = bytearray(telegram)
                b[i] ^= self._rng.randrange(1, 256)
                telegram = bytes(b)
                self.stats.corrupted_in += 1
        deliver = max(at_ms + self._one_way_ms(), self._last_in_ms)
        self._last_in_ms = deliver
        self._inbound.append((deliver, telegram))

    def _one_way_ms(self) -> float:
        link, faults = self.config.link, self.config.faults
        delay = link.one_way_ms + faults.delay_ms
        if link.jitter_ms:
            delay += self._rng.uniform(-link.jitter_ms, link.jitter_ms)
        if link.stall_probability and self._rng.random() < link.stall_probability:
            delay += self._rng.uniform(link.stall_min_ms, link.stall_max_ms)
            self.stats.stalls += 1
        return delay

    def _process_due(self) -> None:
        now = self.firmware.now_ms
        while self._inbound and self._inbound[0][0] <= now and now >= self._busy_until_ms:
            _, telegram = self._inbound.popleft()
            reply = self.firmware.handle(telegram)
            if reply is not None:
                self._emit(reply, now)

    # -- link: brick -> PC -----------------------------------------------------------

    def _emit(self, reply: bytes, now: float) -> None:
        link, faults = self.config.link, self.config.faults
        leave = now + link.processing_ms
        self._busy_until_ms = leave + link.turnaround_ms
        data = frame(reply)
        if faults.drop and self._rng.random() < faults.drop:
            self.stats.dropped_out += 1
            log.debug("%s: dropped reply %s", self.config.name, data.hex())
            return
        if faults.corrupt and self._rng.random() < faults.corrupt:
            b = bytearray(data)
            b[self._rng.randrange(len(b))] ^= self._rng.randrange(1, 256)
            data = bytes(b)
            self.stats.corrupted_out += 1
        deliver = max(leave + self._one_way_ms(), self._last_out_ms)
        self._last_out_ms = deliver
        self._outbound.append((deliver, data))
        self.stats.frames_out += 1

    def next_output_ms(self) -> float | None:
        return self._outbound[0][0] if self._outbound else None

    def next_event_ms(self) -> float | None:
        """When something next happens on the link: a command processed or a frame out."""
        times = []
        if self._inbound:
            times.append(max(self._inbound[0][0], self._busy_until_ms))
        if self._outbound:
            times.append(self._outbound[0][0])
        return min(times) if times else None

    def take_output(self, up_to_ms: float) -> list[bytes]:
        """Frames (prefix included, possibly damaged) delivered by ``up_to_ms``."""
        out = []
        while self._outbound and self._outbound[0][0] <= up_to_ms:
            out.append(self._outbound.popleft()[1])
        return out

    # -- link drops ------------------------------------------------------------------

    def disconnect(self) -> None:
        """Drop the link: everything in flight is lost; the brick keeps running."""
        log.info("%s: link dropped at %d ms", self.config.name, self.now_ms)
        self.link_up = False
        self.link_epoch += 1
        self.stats.disconnects += 1
        self._inbound.clear()
        self._outbound.clear()
        self._decoder.reset()
        self._busy_until_ms = 0.0

    def restore_link(self) -> None:
        """A client connected again (host calls this after re-publishing the port)."""
        if not self.link_up:
            log.info("%s: link restored at %d ms", self.config.name, self.now_ms)
        self.link_up = True
        self._decoder.reset()

    # -- inspection --------------------------------------------------------------------

    @property
    def program(self) -> FollowerProgram | FollowerView | None:
        """The follower program's state, if it runs: its Python model, or the
        compiled program's variables read through its symbol table."""
        p = self.firmware.program
        if isinstance(p, FollowerProgram):
            return p
        name = self.firmware.program_name
        if isinstance(p, VMProgram) and name is not None and name in self.config.symbols:
            symbols = Symbols(self.config.symbols[name])
            if "refs" in symbols and "meas" in symbols:
                return FollowerView(p.vm, symbols)
        return None

    @property
    def vm_program(self) -> VMProgram | None:
        """The running compiled program, if one runs on the bytecode interpreter."""
        p = self.firmware.program
        return p if isinstance(p, VMProgram) else None

    @property
    def legolog(self) -> LegologProgram | None:
        """The running brick program model, if the Legolog behaviour program runs."""
        p = self.firmware.program
        return p if isinstance(p, LegologProgram) else None

