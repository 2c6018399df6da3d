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
import struct
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from nxt_link.emulator.emulator import BrickEmulator
from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.emulator.vm import Compiled, compile_nxc, load_rxe
from nxt_link.emulator.vm.errors import VMError
from nxt_link.emulator.vm.rxe import FORMAT_STRING

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
    """Compile ``tests/nxt_link/programs/nxc/<name>.nxc`` (nbc is a declared test dependency)."""
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


def templates_program() -> str:
    """NXC (mostly NBC assembly) running every inline integer instruction between every pair
    of integer types on the values in c1..w1; results fold into ``acc`` and ``flags``."""
    srcs = ["c1", "b1", "i1", "u1", "l1", "w1"]
    dests = ["c2", "b2", "i2", "u2", "l2", "w2"]
    ccs = ["LT", "GT", "LTEQ", "GTEQ", "EQ", "NEQ"]
    body: list[str] = []

    def block(*lines: str) -> None:
        body.append("  asm {\n" + "\n".join("    " + x for x in lines) + "\n  }")

    for shift, op in enumerate(["add", "sub", "mul", "and", "or", "xor"]):
        block(*(f"{op} {d}, {srcs[(k + shift) % 6]}, {srcs[(k + 2 * shift + 1) % 6]}"
                for k, d in enumerate(dests)))
        body.append("  dests();")
    for op in ("mov", "neg", "abs", "not"):
        for shift in range(6):
            block(*(f"{op} {d}, {srcs[(k + shift) % 6]}" for k, d in enumerate(dests)))
            body.append("  dests();")
    block("or l2, i1, 1", "div l2, l1, l2", "or w2, w1, 1", "div w2, l1, w2", "or c2, c1, 1",
          "mod i2, i1, c2")
    body.append("  dests();")
    for n, cc in enumerate(ccs):
        for k, a in enumerate(srcs):
            d = dests[(k + n) % 6]
            block(f"cmp {cc}, {d}, {a}, {srcs[(k + n + 1) % 6]}")
            body.append(f"  mix({d});")
            block(f"tst {cc}, {d}, {a}")
            body.append(f"  mix({d});")
    label = 0
    lines = []
    for cc in ccs:
        for a in srcs:
            for b in srcs + [None]:
                label += 1
                branch = f"brcmp {cc}, L{label}, {a}, {b}" if b else f"brtst {cc}, L{label}, {a}"
                lines += ["mul flags, flags, 3", branch, "add flags, flags, 1", f"L{label}:"]
    block(*lines)
    for arr in ("ca", "ba", "ia", "wa"):
        for d in dests:
            block(f"index {d}, {arr}, k")
            body.append(f"  mix({d});")
        for s in srcs:
            block(f"replace {arr}, {arr}, k, {s}", f"index l2, {arr}, k")
            body.append("  mix(l2);")
    return ("""// Generated by the tests: every integer instruction the interpreter writes out inline,
// between every pair of integer types, on the values main() puts in c1..w1.
char c1, c2;
byte b1, b2;
int i1, i2;
unsigned int u1, u2;
long l1, l2;
unsigned long w1, w2;
long acc = 0;
long flags = 0;
long k = 0;
char ca[] = {-3, 5, 100, -128};
byte ba[] = {0, 255, 7, 128};
int ia[] = {-32768, 1000, -1, 32767};
unsigned long wa[] = {0, 4294967295, 2147483648, 12345};

// folds a value in; the division and the sign test see a value stored unwrapped
void mix(long v)
{
  acc = acc * 31 + v + v / 977;
  if (v < 0) acc = acc ^ 21845;
}

void dests() { mix(c2); mix(b2); mix(i2); mix(u2); mix(l2); mix(w2); }

void ops()
{
""" + "\n".join(body) + """
}

task main()
{
  long vals[] = {0, 1, -1, 127, 128, 255, 256, -128, -129, 32767, 32768, 65535, 65536,
                 -32768, -32769, 2147483647, -2147483647, 123456789, -987654321};
  for (int j = 0; j < ArrayLen(vals); j++) {
    long v = vals[j];
    long x = vals[(j + 5) % ArrayLen(vals)];
    c1 = v; b1 = x; i1 = v; u1 = x; l1 = v; w1 = x;
    k = j % 4;
    ops();
    c1 = x; b1 = v; i1 = x; u1 = v; l1 = x; w1 = v;
    ops();
  }
  string s = NumToStr(acc);
  SendMessage(0, s);
  s = NumToStr(flags);
  SendMessage(0, s);
}
""")


#: FINCLUMP -1 -1: the end of a clump that schedules nobody
FINCLUMP = (0x602A, 0xFFFF, 0xFFFF)


def tiny_rxe(code: tuple[int, ...] | list[int], *, toc: list[tuple[int, int, int]],
             static: bytes, dope_vectors: Sequence[tuple[int, int, int]] = (),
             contents: bytes = b"", dataspace_size: int | None = None,
             clumps: Sequence[tuple[int, tuple[int, ...], int]] = ((0, (), 0),)) -> bytes:
    """An executable of one clump, written byte by byte, to say what no compiler would.

    Args:
        code: the clump's code words.
        toc: dataspace table of contents, ``(type code, flags, offset)`` per entry.
        static: the static defaults (one value per top-level entry without flag 1);
            their length is also the static dataspace size.
        dope_vectors: ``(offset, element size, count)`` of dope vectors 1, 2, ...
            (dope vector 0, the array of them, is added at the start of the dynamic
            data, right after the static data).
        contents: bytes after the dope vectors, at dataspace offset
            ``len(static) + 10 * (len(dope_vectors) + 1)``.
        dataspace_size: what the header claims (default: the real size).
        clumps: ``(fire count, dependents, first code word)`` per clump (default: one clump
            that runs at once, without dependents, from word 0).
    """
    static_size = len(static)
    dvs = [(static_size, 10, len(dope_vectors) + 1)] + list(dope_vectors)
    dyn = b"".join(struct.pack("<HHHHH", off, es, n, 0xFFFF, 0xFFFF) for off, es, n in dvs)
    dyn += contents
    ds_size = static_size + len(dyn) if dataspace_size is None else dataspace_size
    header = FORMAT_STRING + bytes((0, 6)) + struct.pack(
        "<11H", len(toc), ds_size, static_size, static_size + len(dyn), static_size, len(dyn),
        0, len(dvs) - 1, static_size, len(clumps), len(code))

    def even(b: bytes) -> bytes:
        return b + b"\0" * (len(b) % 2)

    body = even(b"".join(struct.pack("<BBH", *e) for e in toc))
    body += even(static + dyn)
    body += b"".join(struct.pack("<BBH", fire, len(deps), start) for fire, deps, start in clumps)
    body = even(body + bytes(d for _, deps, _ in clumps for d in deps))
    return header + body + struct.pack(f"<{len(code)}H", *code)


def nbc_version() -> str:
    return subprocess.run(["nbc"], capture_output=True, text=True).stdout.splitlines()[0]


__all__ = ["Twin", "Disagreement", "make_twin", "run_program", "results", "compile_test_program",
           "VMError", "output_state", "templates_program", "tiny_rxe",
           "FINCLUMP"]
