"""The interpreter's speed-ups against the plain interpreter, millisecond by millisecond.

Fused blocks (:mod:`nxt_link.emulator.vm.fuse`), a lone clump running on past its turn boundaries
and busy-wait skipping (:mod:`nxt_link.emulator.vm.spin`) must not change anything a program does. Each test runs a program on two bricks at once,
one with the speed-up and one without, and after every millisecond compares everything:
the whole dataspace (floats by their bits), every clump's program counter, the queues,
the instruction count, the mailboxes, the output ports, the tones, the screen and the
errors. The programs are the interpreter's own test programs, a busy-waiting one, and
the follower program through a whole streamed execution.
"""
from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from vmtools import NXC_DIR, output_state, results, templates_program

from nxt_link.emulator.emulator import BrickEmulator, FaultParams, compiled_follower
from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.emulator.vm import compile_nxc
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.spin import SpinDetector
from nxt_link.emulator.vm.templates import wrap_expr, wrap_src
from nxt_link.emulator.vm.values import Mutex, wrap
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming

PROGRAMS = ("vm_arith", "vm_float", "vm_arrays", "vm_strings", "vm_calls", "vm_tasks", "vm_io",
            "vm_spin", "vm_turns", "vm_types", "vm_templates")


@pytest.fixture(scope="module")
def rxe(tmp_path_factory) -> dict[str, bytes]:
    programs = {name: compile_nxc(NXC_DIR / f"{name}.nxc").rxe for name in PROGRAMS
                if name != "vm_templates"}
    src = tmp_path_factory.mktemp("nxc") / "vm_templates.nxc"
    src.write_text(templates_program())
    programs["vm_templates"] = compile_nxc(src).rxe
    return programs


def frozen(v: Any) -> Any:
    """A value for exact comparison: floats by their bits, containers as tuples."""
    if isinstance(v, float):
        return ("float", struct.pack("<d", v))
    if isinstance(v, list):
        return tuple(frozen(e) for e in v)
    if isinstance(v, bytearray):
        return bytes(v)
    if isinstance(v, Mutex):
        return ("mutex", v.owner, tuple(v.waiting))
    return v


def state(fw: Firmware) -> dict[str, Any]:
    """Everything observable of a brick and the interpreter inside it."""
    s: dict[str, Any] = {
        "now": fw.now_ms, "running": fw.program is not None, "errors": list(fw.program_errors),
        "mailboxes": [list(box) for box in fw.mailboxes], "outputs": output_state(fw),
        "tones": [(t.at_ms, t.frequency_hz, t.duration_ms) for t in fw.tones],
        "screen": fw.io.display.lines()}
    vm = fw._vm
    if vm is not None:
        s.update(instructions=vm.instructions, pcs=list(vm.pcs), runq=list(vm.runq),
                 restq=list(vm.restq), fire=list(vm.fire), mem=frozen(vm.mem))
    return s


class Lockstep:
    """Two firmwares with the same program and the same inputs, compared every tick."""

    def __init__(self, rxe: bytes, ipms: int | None, fast: dict[str, bool],
                 slow: dict[str, bool], name: str = "p.rxe") -> None:
        self.pair = [Firmware(FirmwareParams(vm_instructions_per_ms=ipms, **opts),
                              flash_files={name: rxe}) for opts in (fast, slow)]
        for fw in self.pair:
            fw.start_program_now(name)
        self.fast = self.pair[0]
        self.vms = [fw._vm for fw in self.pair]
        slow_vm = self.vms[1]
        if slow_vm is not None and not slow.get("vm_fused", True):
            # the reference: one instruction at a time, and a turn boundary every 20
            # instructions even for a clump alone in the run queue
            slow_vm._solo_ok = False

    def run(self, ms: int, stimulus: Callable[[Firmware, int], None] | None = None) -> int:
        for t in range(ms):
            if self.fast.program is None:
                return t
            for fw in self.pair:
                if stimulus:
                    stimulus(fw, t)
                fw.tick()
            a, b = (state(fw) for fw in self.pair)
            assert a == b, f"at {t} ms: " + ", ".join(k for k in a if a[k] != b.get(k))
        return ms


def io_stimulus(fw: Firmware, t: int) -> None:
    """What ``vm_io`` waits for: a light sensor, a touch, a message (as in test_vm_programs)."""
    if t == 0:
        fw.inputs[2].raw = 500
    if t == 600:
        fw.inputs[0].raw = 183
    if t == 800:
        assert fw.write_mailbox(2, b"ping\0") == 0


def spin_stimulus(fw: Firmware, t: int) -> None:
    if t == 100:
        assert fw.write_mailbox(1, b"go\0") == 0


STIMULI = {"vm_io": io_stimulus, "vm_spin": spin_stimulus}


@pytest.mark.parametrize("ipms", [None, 500, 7])
@pytest.mark.parametrize("name", PROGRAMS)
def test_fused_blocks_run_every_program_exactly_as_single_instructions(rxe, name, ipms):
    run = Lockstep(rxe[name], ipms, {"vm_fused": True}, {"vm_fused": False})
    ran = run.run(3000, STIMULI.get(name))
    fw = run.fast
    assert ran > 0 and fw._vm is None or fw._vm.instructions > 0  # type: ignore[union-attr]


def test_a_task_woken_by_a_release_runs_at_the_next_turn_boundary(rxe):
    # the releasing task is alone in the run queue until the release queues the other:
    # from then on the queue rotates every 20 instructions again
    run = Lockstep(rxe["vm_turns"], 500, {"vm_fused": True}, {"vm_fused": False})
    run.run(200)
    seen, work = (int(v) for v in results(run.fast, 0))
    assert work == 300 and 0 < seen < 10


def test_a_fault_inside_a_block_names_the_same_instruction(rxe):
    # vm_arrays ends with an index out of range in the middle of straight-line code
    run = Lockstep(rxe["vm_arrays"], None, {"vm_fused": True}, {"vm_fused": False})
    run.run(100)
    fused, plain = run.pair
    (error,) = fused.program_errors
    assert "INDEX: index 10 is outside the array" in error
    assert fused.program_errors == plain.program_errors  # same pc, same clump
    a, b = run.vms
    assert a is not None and b is not None and a.fused and not b.fused
    assert a.instructions == b.instructions


def test_busy_waits_are_skipped_exactly(rxe):
    # a CPU fast enough to spin a lot, slow enough to compare against every instruction run
    run = Lockstep(rxe["vm_spin"], 20_000, {"vm_skip_busy_waits": True},
                   {"vm_skip_busy_waits": False})
    run.run(1000, spin_stimulus)
    fw = run.fast
    assert results(fw, 0) == ["40", "go", "turned", "counted", "played"]
    assert results(fw, 2) == ["helper done"]
    assert results(fw, 3) == ["both"]  # a port list (OUT_BC) drove two motors
    assert fw.program is None and fw.program_errors == []
    assert len(fw.tones) > 500  # the loop with a side effect ran every time round
    skipping, running = run.vms
    assert skipping is not None and running is not None
    assert skipping.instructions == running.instructions > 2_000_000
    assert skipping.skipped > skipping.instructions / 2 and running.skipped == 0


def test_a_busy_wait_on_an_infinitely_fast_brick_costs_little(rxe):
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=None), flash_files={"s.rxe": rxe["vm_spin"]})
    fw.start_program_now("s.rxe")
    vm = fw._vm
    assert vm is not None
    for _ in range(60):  # the clock and the mailbox busy-waits
        fw.tick()
    assert results(fw, 0) == ["40"]
    # a million instructions per millisecond counted, almost none of them run
    assert vm.instructions > 50_000_000
    assert vm.instructions - vm.skipped < vm.instructions / 200


def test_the_follower_runs_a_whole_execution_identically_fused_and_plain(rig, wave):
    files, _ = compiled_follower()
    rig.add("r1", faults=FaultParams(drop=0.05, seed=3))
    emu: BrickEmulator = rig.emulators["r1"]
    pair = Lockstep(files["cplus_follow.rxe"], 500, {"vm_fused": True}, {"vm_fused": False},
                    name="cplus_follow.rxe")
    emu.firmware = _Both(pair)  # type: ignore[assignment]
    stream = SetpointStream("r1", ("A", "B", "C"), 50, wave(40, (90, -60, 30)))
    timing = SessionTiming(ack_timeout_s=0.3, max_silent_s=5.0, homing_timeout_s=3.0)
    log = execute_streams([stream], rig.bricks, options=ExecutionOptions(timing=timing))
    assert log.brick("r1").reference_deg == stream.rows
    assert emu.firmware.ticks > 2000  # type: ignore[attr-defined]


class _Both:
    """Stands in for an emulator's firmware: the link talks to both, the fused one answers."""

    def __init__(self, run: Lockstep) -> None:
        self.run = run
        self.ticks = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.run.fast, name)

    @property
    def now_ms(self) -> int:
        return self.run.fast.now_ms

    def handle(self, telegram: bytes) -> bytes | None:
        a, b = (fw.handle(telegram) for fw in self.run.pair)
        assert a == b, f"at {self.now_ms} ms: {telegram.hex()} answered {a!r} and {b!r}"
        return a

    def tick(self) -> None:
        for fw in self.run.pair:
            fw.tick()
        self.ticks += 1
        a, b = (state(fw) for fw in self.run.pair)
        assert a == b, f"at {self.now_ms} ms: " + ", ".join(k for k in a if a[k] != b.get(k))


def test_a_zero_of_another_sign_is_another_state(rxe):
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=None), flash_files={"s.rxe": rxe["vm_spin"]})
    fw.start_program_now("s.rxe")
    vm = fw._vm
    assert vm is not None
    f = next(i for i, v in enumerate(vm.mem) if isinstance(v, float) and v == 0.0)
    detector = SpinDetector()
    assert detector.check(vm, 5000, 1_000_000) == 0  # the first snapshot
    assert detector.check(vm, 5100, 1_000_000) > 0  # the same state: a cycle of 100
    detector.reset()
    detector.check(vm, 5000, 1_000_000)
    vm.mem[f] = -vm.mem[f]
    assert detector.check(vm, 5100, 1_000_000) == 0


@settings(max_examples=300)
@given(st.sampled_from([TC.UBYTE, TC.SBYTE, TC.UWORD, TC.SWORD, TC.ULONG, TC.SLONG]),
       st.one_of(st.integers(-2**40, 2**40), st.sampled_from(
           [0, -1, 0x7F, 0x80, 0xFF, 0x100, 0x7FFF, 0x8000, 0xFFFF, 0x10000, 0x7FFFFFFF,
            0x80000000, 0xFFFFFFFF, 0x100000000, -0x80, -0x81, -0x8000, -0x80000001])))
def test_the_templates_wrap_integers_as_the_brick_does(tc, x):
    ns = {"x": x}
    exec(wrap_src(tc, "x", "out"), ns)
    assert ns["out"] == wrap(tc, x) == eval(wrap_expr(tc, "x"), {"x": x})
