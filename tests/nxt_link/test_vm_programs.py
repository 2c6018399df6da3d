"""The interpreter on small NXC programs of our own, compiled by nbc in the tests.

Each program computes known results and writes them to a mailbox; every
instruction class is exercised: math with overflow, logic, comparison
(signed/unsigned, aggregates), data (arrays, clusters, strings, conversions,
flatten), control flow (branches, nested calls, tasks, mutexes, waits) and
system I/O (mailboxes, ports, sound, display, files).
"""
from __future__ import annotations

import struct
from pathlib import Path

import pytest
from vmtools import NXC_DIR, results, run_program, templates_program

from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.emulator.vm import compile_nxc, decode_clump, disassemble, load_rxe

PROGRAMS = ("vm_arith", "vm_float", "vm_arrays", "vm_strings", "vm_calls", "vm_tasks", "vm_io",
            "vm_types")


@pytest.fixture(scope="module")
def rxe() -> dict[str, bytes]:
    return {name: compile_nxc(NXC_DIR / f"{name}.nxc").rxe for name in PROGRAMS}


def test_integer_arithmetic_wraps_like_the_brick(rxe):
    fw = run_program(rxe["vm_arith"])
    assert fw.program_errors == []
    assert results(fw, 0) == [
        "-2147483648 -32768 0 127 4294967295",  # long, int, byte, char, unsigned long overflow
        "-3 -1 0 -7 1410065408",  # C division/modulo, x/0 = 0, x%0 = x, 32-bit product
    ]
    assert results(fw, 1) == [
        "10 95 85 0 -90 7",  # and, or, xor, logical not, negation, abs
        "1 1 720 22",  # signed and unsigned comparison, shifts
    ]
    assert results(fw, 2) == ["338350 2004310016"]  # sum of squares, 15! mod 2^32 as a long


def test_integer_types_against_each_other(rxe):
    # moves, arithmetic, comparisons and branches between every width and signedness on
    # edge values, folded into checksums (the values the interpreter gave one instruction
    # at a time, before any instruction was compiled from a template)
    for ipms in (None, 7):
        fw = run_program(rxe["vm_types"], ipms=ipms, ms=5000)
        assert fw.program_errors == []
        assert results(fw, 0) == ["48514654", "1236387425"]


def test_every_inline_instruction_between_every_pair_of_types(tmp_path: Path):
    # NBC assembly, so that every type combination really occurs (nbc's own code generator
    # converts through temporaries); the checksums are what the interpreter gave one
    # instruction at a time, before any instruction was compiled from a template
    src = tmp_path / "vm_templates.nxc"
    src.write_text(templates_program())
    rxe = compile_nxc(src).rxe
    for ipms in (None, 500):
        fw = run_program(rxe, ipms=ipms, ms=2000)
        assert fw.program_errors == []
        assert results(fw, 0) == ["-1574789430", "-1464737080"]


def test_float_arithmetic_is_float32(rxe):
    fw = run_program(rxe["vm_float"])
    assert fw.program_errors == []
    assert results(fw, 0) == [
        "3.38 0.33 3.75",
        "16777216 1.41 2 -2 3.5 0",  # 2^24+1 rounds, float->long truncates, x/0 = 0
        "1 1 15 0 0",
    ]


def test_arrays_clusters_and_a_fatal_index(rxe):
    fw = run_program(rxe["vm_arrays"])
    assert results(fw, 0) == ["10 81 4 9 8 686", "42 -70000 3 -70000 0 1", "2 9 5"]
    assert results(fw, 1) == []  # never reached
    (error,) = fw.program_errors
    assert "INDEX: index 10 is outside the array" in error and "(10 elements)" in error
    assert "at pc " in error and "clump 0" in error
    assert fw.program is None  # the firmware aborted the program


def test_strings_and_conversions(rxe):
    fw = run_program(rxe["vm_strings"])
    assert fw.program_errors == []
    assert results(fw, 0) == ["Hello, NXT!", "NXT -1234 -56 11 11 1 1",
                              "Jello, NXT! 101 A\0\0\0"]
    assert results(fw, 1) == ["123456"]  # flattened and unflattened


def test_nested_calls_and_reference_arguments(rxe):
    fw = run_program(rxe["vm_calls"])
    assert results(fw, 0) == ["112 4 2 1 144"]
    assert results(fw, 1) == [] and fw.program_errors == []  # Stop(true) ended it


def test_tasks_share_a_mutex_and_wait_on_the_clock(rxe):
    fw = run_program(rxe["vm_tasks"], ms=2000)
    assert fw.program_errors == []
    assert results(fw, 0) == ["110 21"]  # no increment lost; worker2 finishes first
    assert results(fw, 1) == ["501"]  # Wait(500) from the first slice


def test_tasks_interleave_in_time_slices(rxe):
    # a slow CPU: the same results, only later
    fast = run_program(rxe["vm_tasks"], ms=3000)
    slow = run_program(rxe["vm_tasks"], ms=3000, ipms=30)
    assert results(slow, 0) == results(fast, 0)
    assert int(results(slow, 1)[0]) >= int(results(fast, 1)[0])


def test_ports_sound_display_files_and_mailboxes(rxe):
    fw = Firmware(FirmwareParams(), flash_files={"io.rxe": rxe["vm_io"]})
    fw.start_program_now("io.rxe")
    fw.inputs[2].raw = 500  # a light sensor over a grey surface
    screen = []
    for t in range(3000):
        if t == 600:
            fw.inputs[0].raw = 183  # the touch sensor is pressed
        if t == 800:
            assert fw.write_mailbox(2, b"ping\0") == 0
        if t == 700:
            screen = fw.io.display.lines()
        fw.tick()
        if fw.program is None:
            break
    assert fw.program_errors == []
    assert fw.program is None  # it ended by itself after the last message
    assert results(fw, 0) == ["1 75 56 0", "hello"]
    assert results(fw, 1) == ["got ping"]
    assert [(t.frequency_hz, t.duration_ms) for t in fw.tones] == [(440, 200)]
    assert screen[1].startswith("touched") and screen[2].startswith("56")
    assert fw.flash.read_all("log.txt") == b"hello\r\n"  # a data file keeps what was written
    assert fw.outputs[0].rotation_count == 0  # devices reset when the program ended


def test_every_instruction_class_is_exercised(rxe):
    seen = set()
    for name in PROGRAMS:
        exe = load_rxe(rxe[name], name)
        for clump in exe.clumps:
            for ins in decode_clump(exe.code, clump):
                seen.add(("s" if ins.short else "l", ins.opcode))
    long_ops = {op for kind, op in seen if kind == "l"}
    # math, logic, comparison, data, strings, control flow, scheduling, ports, timing
    for op in (0x00, 0x01, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x11, 0x12, 0x15, 0x16,
               0x17, 0x18, 0x19, 0x1A, 0x1C, 0x1D, 0x1E, 0x1F, 0x20, 0x21, 0x22, 0x23, 0x24,
               0x25, 0x26, 0x27, 0x28, 0x29, 0x2A, 0x2F, 0x30, 0x31, 0x32, 0x33, 0x34, 0x35,
               0x36, 0x37):
        assert op in long_ops, f"opcode 0x{op:02X} not covered"
    # move, acquire, release and subroutine call come in their short encodings
    assert {("s", 0), ("s", 1), ("s", 2), ("s", 3)} <= seen


# -- fatal errors name the instruction ---------------------------------------------------


def _patch_first(data: bytes, opcode: int, new_word: int | None = None,
                 arg: tuple[int, int] | None = None) -> bytes:
    """Replace the first executed instruction with ``opcode`` (or one argument of it)."""
    exe = load_rxe(data)
    code_off = len(data) - 2 * len(exe.code)
    for clump in exe.clumps:
        for ins in decode_clump(exe.code, clump):
            if not ins.short and ins.opcode == opcode:
                b = bytearray(data)
                if new_word is not None:
                    struct.pack_into("<H", b, code_off + 2 * ins.pc, new_word)
                if arg is not None:
                    struct.pack_into("<H", b, code_off + 2 * (ins.pc + 1 + arg[0]), arg[1])
                return bytes(b)
    raise AssertionError("opcode not found")


def test_an_unknown_opcode_is_an_error_naming_it_and_the_pc(rxe):
    data = _patch_first(rxe["vm_calls"], 0x1C, new_word=0x6040)  # SET -> opcode 0x40, 3 words
    fw = run_program(data)
    (error,) = fw.program_errors
    assert "unknown opcode 0x40" in error and "at pc " in error


def test_an_opcode_the_firmware_lacks_is_an_error_naming_it(rxe):
    data = _patch_first(rxe["vm_calls"], 0x1C, new_word=0x600B)  # SET -> LSL
    (error,) = run_program(data).program_errors
    assert "opcode 0x0B (LSL) is not an instruction of firmware 1.28" in error


@pytest.mark.parametrize("sid, text", [
    (48, "unknown system call 48"),
    (32, "system call 32 (IOMapRead) is not supported by the emulated brick"),
])
def test_unknown_and_unsupported_system_calls_are_errors(rxe, sid, text):
    data = _patch_first(rxe["vm_calls"], 0x28, arg=(0, sid))
    (error,) = run_program(data).program_errors
    assert text in error and "at pc " in error


def test_disassembly_lists_every_clump(rxe):
    lines = disassemble(load_rxe(rxe["vm_calls"]))
    assert any("SUBCALL" in line for line in lines) and any("SYSCALL" in line for line in lines)


def test_a_subroutine_called_by_two_tasks_at_once_is_an_error(tmp_path: Path):
    src = tmp_path / "twice.nxc"
    src.write_text("void f() { Wait(10); }\ntask t1() { f(); }\ntask t2() { Wait(2); f(); }\n"
                   "task main() { Precedes(t1, t2); }\n")
    rxe = compile_nxc(src).rxe
    for fused in (True, False):
        fw = Firmware(FirmwareParams(vm_fused=fused), flash_files={"t.rxe": rxe})
        fw.start_program_now("t.rxe")
        for _ in range(50):
            fw.tick()
        (error,) = fw.program_errors
        assert "SUBCALL: subroutine clump" in error and "called while it is already running" in error
        assert fw.program is None


def test_running_out_of_memory_is_an_error(tmp_path: Path):
    src = tmp_path / "big.nxc"
    src.write_text("long a[];\ntask main() { long n = 20000; ArrayInit(a, 0, n); }\n")
    (error,) = run_program(compile_nxc(src).rxe).program_errors
    assert "out of memory" in error and "32768" in error
