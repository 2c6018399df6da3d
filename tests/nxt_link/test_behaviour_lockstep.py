"""The Python model of cplus_legolog.nxc against the compiled program, millisecond by millisecond.

The same sessions run on two firmwares at once, each with its own copy of the world (same
seed, so the same noise): one runs the model, the other the compiled ``.rxe`` on the
bytecode interpreter. Every reply, every mailbox and every output port must be identical
after every command and every millisecond (``vmtools.Twin``); then the robots drove the
same way and their sensors read the same. A difference fails the test (no tolerance).
"""
from __future__ import annotations

from pathlib import Path

import pytest
from vmtools import Disagreement, Twin

from nxt_link import (
    Behaviour,
    BehaviourClient,
    BehaviourFailed,
    Brick,
    BrickEvent,
    BrickPanicError,
    delivery_world,
)
from nxt_link.emulator import legolog_behaviours
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.vm import Compiled, cached_compile
from nxt_link.emulator.world import Blocked, World, WorldSpec
from nxt_link.host.brick import RetryPolicy
from nxt_link.programs import behaviour_protocol as bp
from nxt_link.wire.clock import VirtualClock

NXC = Path(bp.__file__).resolve().parent / "nxc" / "cplus_legolog.nxc"
POLICY = RetryPolicy(reply_timeout_s=0.2, retries=3, quiet_s=0.02, reconnect_timeout_s=2.0)


@pytest.fixture(scope="module")
def legolog() -> Compiled:
    return cached_compile(NXC)


class Pair:
    """An emulated robot whose firmware is a model/program twin, and a client for it."""

    def __init__(self, compiled: Compiled, world: WorldSpec, faults: FaultParams | None = None,
                 program_running: bool = True) -> None:
        self.emu = BrickEmulator(EmulatorConfig(name="robot", world=world,
                                                link=LinkParams.instant(),
                                                faults=faults or FaultParams(seed=world.seed),
                                                program_running=program_running))
        model = self.emu.firmware
        params = FirmwareParams(**{**{f: getattr(model.params, f)
                                      for f in model.params.__dataclass_fields__},
                                   # an infinitely fast brick, as the model assumes
                                   "vm_instructions_per_ms": None})
        fw = Firmware(params, tuple(o.motor.params for o in model.outputs),
                      flash_files={bp.PROGRAM_NAME: compiled.rxe})
        self.world = World(world, seed=self.emu.config.faults.seed)
        fw.attach(self.world)
        if program_running:
            fw.start_program_now(bp.PROGRAM_NAME)
        self.twin = Twin(model, fw)
        self.emu.firmware = self.twin  # type: ignore[assignment]
        self.clock = VirtualClock()
        self.client = BehaviourClient(Brick(MemoryTransport(self.emu, self.clock), name="robot",
                                            policy=POLICY))

    def press(self, hold_s: float = 0.3) -> None:
        assert self.emu.world is not None
        self.emu.world.press(hold_s)
        self.world.press(hold_s)

    def wait(self, seconds: float) -> None:
        self.clock.sleep(seconds)
        self.emu.advance_to(self.clock.now() * 1000.0)


def test_a_delivery_round_is_identical_tick_by_tick(legolog):
    p = Pair(legolog, delivery_world(seed=21))
    p.client.connect()
    results = [p.client.act(b, a) for b, a in [
        (Behaviour.FOLLOW, ()), (Behaviour.TRAY_UP, ()), (Behaviour.TURN, ()),
        (Behaviour.FOLLOW, ()), (Behaviour.TRAY_DOWN, ()), (Behaviour.WAIT_BUTTON, (1,))]]
    assert [r.sensing.get("landmark") for r in results] == [2, None, None, 1, None, None]
    p.press()
    p.wait(0.5)
    assert p.client.poll_events() == [BrickEvent("button")]
    assert p.twin.ticks > 12000 and p.twin.commands > 50
    # both robots really drove there and back
    assert p.world.nearest_landmark() == 1 and p.world.distance_mm > 1800


def test_failures_more_time_panic_and_abort_are_identical(legolog):
    base = delivery_world(seed=22)
    spec = WorldSpec(track=base.track, landmarks=base.landmarks, start=base.start,
                     blocked=(Blocked(900.0, 1000.0),), seed=22)
    p = Pair(legolog, spec, faults=FaultParams(drop=0.1, corrupt=0.05, seed=22))
    p.client.connect()
    with pytest.raises(BehaviourFailed, match="stuck"):
        p.client.act(Behaviour.FOLLOW)

    def busy(_elapsed: float) -> None:
        p.wait(15.0)  # the PC stops answering: both bricks panic
    with pytest.raises(BrickPanicError):
        p.client.act(Behaviour.WAIT_BUTTON, on_more_time=busy)
    p.client.abort()
    p.client.act(Behaviour.TURN)
    assert p.client.act(Behaviour.FOLLOW).sensing["landmark"] == 1
    assert p.twin.compiled.tones  # the compiled program beeped in PANIC as the model did


def test_a_program_started_by_the_pc_is_identical(legolog):
    p = Pair(legolog, delivery_world(seed=23), program_running=False)
    p.client.connect()  # STARTPROGRAM, then HELLO
    assert p.client.act(Behaviour.TRAY_UP).status == bp.Status.OK
    assert p.twin.compiled.program_name == bp.PROGRAM_NAME


def test_a_model_that_drifts_from_the_program_is_caught(legolog, monkeypatch):
    # one more %/% of steering in the model than in the NXC program
    monkeypatch.setattr(legolog_behaviours, "KP_NUM", legolog_behaviours.KP_NUM + 1)
    p = Pair(legolog, delivery_world(seed=24))
    p.client.connect()
    with pytest.raises(Disagreement, match="outputs"):
        p.client.act(Behaviour.FOLLOW)
