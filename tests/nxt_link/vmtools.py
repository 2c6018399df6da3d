"""Helpers of the bytecode-interpreter tests: nbc once per session, a lockstep twin.

:class:`Twin` stands in for an emulator's firmware and drives two firmwares
with the same telegrams at the same milliseconds: one runs the Python model of
``cplus_follow.nxc``, the other the compiled program on the interpreter (with
an infinitely fast CPU, as the model assumes). After every command and every
millisecond it compares what the PC could see or feel: the reply bytes, the
contents of every mailbox (the program's responses), and each output port's
commanded state, applied duty and counters. The first difference raises
:class:`Disagreement` with the millisecond and what differs.
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any

from nxt_link.emulator import BrickEmulator
from nxt_link.firmware import Firmware, FirmwareParams
from nxt_link.vm import Compiled, compile_nxc, load_rxe
from nxt_link.vm.errors import VMError

NXC_DIR = Path(__file__).resolve().parent / "nxc"


class Disagreement(AssertionError):
    pass


def output_state(fw: Firmware) -> list[tuple[Any, ...]]:
    return [(o.power, o.mode, o.regulation_mode, o.turn_ratio, o.run_state, o.tacho_limit,
             o.tacho_count, o.block_tacho_count, o.rotation_count, o.applied_duty_pct)
            for o in fw.outputs]


class Twin:
    """Two firmwares in lockstep; the model's answers go on the link."""

    def __init__(self, model: Firmware, compiled: Firmware) -> None:
        self.model = model
        self.compiled = compiled
        self.ticks = 0
        self.commands = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.model, name)

    @property
    def now_ms(self) -> int:
        return self.model.now_ms

    def handle(self, telegram: bytes) -> bytes | None:
        a = self.model.handle(telegram)
        b = self.compiled.handle(telegram)
        self.commands += 1
        if a != b:
            raise Disagreement(f"at {self.now_ms} ms, command {telegram.hex()}: model replied "
                               f"{a.hex() if a else a}, program {b.hex() if b else b}")
        self._compare("after command " + telegram.hex())
        return a

    def tick(self) -> None:
        self.model.tick()
        self.compiled.tick()
        self.ticks += 1
        if self.compiled.program_errors:
            raise Disagreement(f"the program failed: {self.compiled.program_errors}")
        self._compare("")

    def _compare(self, when: str) -> None:
        a, b = self.model, self.compiled
        at = f"at {a.now_ms} ms{' ' + when if when else ''}"
        if (a.program is None) != (b.program is None):
            raise Disagreement(f"{at}: program running: model {a.program is not None}, "
                               f"compiled {b.program is not None}")
        for q, (ma, mb) in enumerate(zip(a.mailboxes, b.mailboxes)):
            if list(ma) != list(mb):
                raise Disagreement(f"{at}: mailbox {q}: model {[m.hex() for m in ma]}, "
                                   f"program {[m.hex() for m in mb]}")
        sa, sb = output_state(a), output_state(b)
        if sa != sb:
            raise Disagreement(f"{at}: outputs: model {sa}, program {sb}")


def make_twin(emu: BrickEmulator, compiled: Compiled) -> Twin:
    """Replace ``emu``'s firmware (running the model) by a model/program twin."""
    model = emu.firmware
    params = FirmwareParams(**{**{f: getattr(model.params, f)
                                  for f in model.params.__dataclass_fields__},
                               "vm_instructions_per_ms": None})
    fw = Firmware(params, tuple(o.motor.params for o in model.outputs),
                  flash_files={"cplus_follow.rxe": compiled.rxe})
    if model.program is not None:
        fw.start_program_now("cplus_follow.rxe")
    twin = Twin(model, fw)
    emu.firmware = twin  # type: ignore[assignment]
    return twin


def compile_test_program(name: str, tmp: Path) -> Compiled:
    """Compile ``tests/nxt_link/nxc/<name>.nxc`` (nbc is a declared test dependency)."""
    assert shutil.which("nbc"), "nbc is not installed (apt-get install -y nbc)"
    return compile_nxc(NXC_DIR / f"{name}.nxc")


def run_program(rxe: bytes, *, ms: int = 5000, ipms: int | None = None,
                name: str = "t.rxe") -> Firmware:
    """Run a compiled program on a fresh brick until it ends (or ``ms``)."""
    load_rxe(rxe, name)  # refuse a bad file with its own error first
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=ipms), flash_files={name: rxe})
    fw.start_program_now(name)
    for _ in range(ms):
        if fw.program is None:
            break
        fw.tick()
    return fw


def results(fw: Firmware, queue: int = 0) -> list[str]:
    """The messages a test program wrote to mailbox ``queue`` (without the NUL)."""
    return [m[:-1].decode("latin-1") for m in fw.mailboxes[queue]]


def nbc_version() -> str:
    return subprocess.run(["nbc"], capture_output=True, text=True).stdout.splitlines()[0]


__all__ = ["Twin", "Disagreement", "make_twin", "run_program", "results", "compile_test_program",
           "VMError", "output_state"]
