"""Hostile programs and files: a valid program that never gives the CPU back, files whose
dope vectors claim more memory than the brick has, programs that allocate without end, and
damaged files. Each is refused or stopped cleanly: the emulator goes on answering, only the
package's own errors (``RxeError`` at load, ``VMError`` at run) come out, and each file is
refused before anything large is built.

Every test is bounded without depending on the machine's speed: what they assert is
counted (instructions per slice, examples, ticks), and a 60 s time limit (pytest-timeout,
tighter than the suite's) only turns a hang into a failure, far above what a test needs.
"""
from __future__ import annotations

import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from vmtools import FINCLUMP, NXC_DIR, results, run_program, tiny_rxe

from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.emulator.vm import RxeError, VMError, compile_nxc, load_rxe
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.rxe import CLUMP_RECORD_POOL_BYTES, POOL_SIZE
from nxt_link.emulator.vm.scheduler import INSTRUCTIONS_PER_TURN, MAX_OVERRUN
from nxt_link.emulator.vm.syscalls import SYSCALLS, Syscall
from nxt_link.wire.errors import LinkError

pytestmark = pytest.mark.timeout(60)

# The program; this nbc needs task b declared before a names it.
PING_PONG = "task b();\ntask a() { ExitTo(b); }\ntask b() { ExitTo(a); }\ntask main() { ExitTo(a); }\n"
GET_PROGRAM_NAME = bytes.fromhex("0011")
STOP_PROGRAM = bytes.fromhex("0001")


def _compile(tmp_path: Path, name: str, source: str) -> bytes:
    src = tmp_path / f"{name}.nxc"
    src.write_text(source)
    return compile_nxc(src).rxe


@pytest.fixture(scope="module")
def ping_pong(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    return _compile(tmp_path_factory.mktemp("nxc"), "pingpong", PING_PONG)


# -- a program that never waits ---------------------------------------------------------


@pytest.mark.parametrize("ipms", [1, 20, 500, 5000])
def test_an_exitto_ping_pong_gives_back_every_time_slice(ping_pong, ipms):
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=ipms), flash_files={"pp.rxe": ping_pong})
    fw.start_program_now("pp.rxe")
    assert fw.program is not None
    vm = fw.program.vm  # type: ignore[attr-defined]
    for _ in range(30):
        before = vm.instructions
        fw.tick()
        assert 1 <= vm.instructions - before <= ipms + MAX_OVERRUN + INSTRUCTIONS_PER_TURN
    # the brick answers while the program runs, and STOPPROGRAM ends it
    assert fw.handle(GET_PROGRAM_NAME) == b"\x02\x11\x00" + b"pp.rxe".ljust(20, b"\0")
    assert fw.handle(STOP_PROGRAM) == b"\x02\x01\x00"
    fw.tick()
    assert fw.program is None and fw.program_errors == []


def test_a_program_whose_turns_end_normally_keeps_the_firmwares_slices(tmp_path):
    """The bound only applies past the budget to turns that end in an event: a task that
    computes without end gets exactly its budget each slice, as before."""
    rxe = _compile(tmp_path, "spin", "task main() { long x = 0; while (true) x++; }\n")
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=500), flash_files={"s.rxe": rxe})
    fw.start_program_now("s.rxe")
    vm = fw.program.vm  # type: ignore[union-attr]
    for _ in range(10):
        before = vm.instructions
        fw.tick()
        assert vm.instructions - before == 500


def test_the_emulated_brick_answers_a_client_while_the_ping_pong_runs(rig, ping_pong):
    brick = rig.add("r1", flash_files={"pp.rxe": ping_pong}, start_program="pp.rxe")
    assert brick.get_current_program_name() == "pp.rxe"
    assert brick.get_battery_level() == 9000
    brick.stop_program()
    rig.clock.sleep(0.01)
    brick.get_battery_level()  # the brick has run its milliseconds: the program stopped
    firmware = rig.emulators["r1"].firmware
    assert firmware.program is None and firmware.program_errors == []


@pytest.mark.slow
def test_nxt_python_talks_to_a_pty_brick_running_the_ping_pong(pty_server, ping_pong):
    import nxt.locator

    server = pty_server("r1", time_scale=1.0, flash_files={"pp.rxe": ping_pong},
                        start_program="pp.rxe")
    brick = nxt.locator.find(backends=["devfile"], filename=server.path, config=None)
    try:
        assert brick.get_current_program_name() == "pp.rxe"
        assert brick.get_battery_level() == 9000
    finally:
        brick.close()


@pytest.mark.slow
def test_cplus_brick_running_the_ping_pong_answers_every_command_and_stops_on_sigterm(tmp_path, ping_pong):
    """The issue's case end to end: ``cplus brick --program`` running the ping-pong (every
    slice spent, slower than real time on the interpreter) answered one direct command and
    then none, and ignored SIGTERM until killed: its serving loop ran the brick towards a
    real time it never caught up with. An independent client (nxt-python) now gets every
    answer, and SIGTERM ends the brick (exit 0, its summary counting them all)."""
    import signal
    import subprocess
    import sys

    import nxt.locator

    rxe = tmp_path / "pp.rxe"
    rxe.write_bytes(ping_pong)
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "brick", "--name", "pp", "--no-latency",
                             "--program", str(rxe)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=Path(__file__).resolve().parents[2])
    try:
        assert proc.stdout is not None
        path = proc.stdout.readline().strip()
        brick = nxt.locator.find(backends=["devfile"], filename=path, config=None)
        try:
            for _ in range(40):
                assert brick.get_current_program_name() == "pp.rxe"     # the program runs throughout
            assert brick.get_battery_level() == 9000
        finally:
            brick.close()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "cplus brick: pp: 41 frames in, 41 out," in err


# -- files that claim more than the brick has -----------------------------------------------

# sword[][] at static offset 0, its dope vector index 1 as its default
_GRID_TOC = [(TC.ARRAY, 0, 0), (TC.ARRAY, 0, 0), (TC.SWORD, 0, 0)]
_AFTER_TWO_DVS = 2 + 10 * 3  # dataspace offset of the contents after dope vectors 0..2


def dope_vector_bomb() -> bytes:
    """The issue's file: dope vectors of zero-byte elements claim 65,535 rows of 65,535."""
    return tiny_rxe(FINCLUMP, toc=_GRID_TOC, static=struct.pack("<H", 1),
                    dope_vectors=[(_AFTER_TWO_DVS, 0, 0xFFFF), (_AFTER_TWO_DVS, 0, 0xFFFF)],
                    contents=struct.pack("<H", 2))


def _shared_rows() -> bytes:
    """Well-formed dope vectors, 1000 rows all pointing at the same 1000-element row: 2 KB
    of file for 2 MB of arrays."""
    return tiny_rxe(FINCLUMP, toc=_GRID_TOC, static=struct.pack("<H", 1),
                    dope_vectors=[(_AFTER_TWO_DVS, 2, 1000), (_AFTER_TWO_DVS, 2, 1000)],
                    contents=struct.pack("<H", 2) * 1000)


def _flat(count: int) -> bytes:
    """One sword[] of ``count`` elements; the header understates the dataspace."""
    return tiny_rxe(FINCLUMP, toc=[(TC.ARRAY, 0, 0), (TC.SWORD, 0, 0)], static=struct.pack("<H", 1),
                    dope_vectors=[(2 + 20, 2, count)], contents=bytes(2 * count), dataspace_size=24)


#: what one clump and the 2-byte static dataspace leave of the pool for the arrays
_ROOM = POOL_SIZE - CLUMP_RECORD_POOL_BYTES - 2


@pytest.mark.parametrize("data, text", [
    (dope_vector_bomb(), "dope vector 1 gives 0-byte elements, the array's elements (sword[]) "
                         "reach byte 2"),
    (_shared_rows(), "dope vector 2 claims 1000 elements: the initial arrays need more than the "
                     f"{_ROOM} bytes of RAM the brick has left for them (32768 less 30 of static "
                     "data and clump records)"),
    (_flat(_ROOM // 2 + 1), f"dope vector 1 claims {_ROOM // 2 + 1} elements"),
])
def test_a_file_claiming_more_memory_than_the_brick_has_is_refused_at_once(data, text):
    with pytest.raises(RxeError) as info:
        load_rxe(data, "bomb.rxe")
    assert str(info.value).startswith("bomb.rxe: array at dataspace entry 0: ")
    assert text in str(info.value)
    fw = Firmware(flash_files={"bomb.rxe": data})
    fw.start_program_now("bomb.rxe")
    assert fw.program is None and len(fw.program_errors) == 1


@pytest.mark.parametrize("toc, text", [
    # the element's member lies 40 bytes into 2-byte elements
    ([(TC.ARRAY, 0, 0), (TC.SWORD, 0, 40)],
     "array at dataspace entry 0: dope vector 1 gives 2-byte elements, the array's elements "
     "(sword) reach byte 42"),
    # the firmware cannot copy a mutex (or a void) out of an array element
    ([(TC.ARRAY, 0, 0), (TC.CLUSTER, 0, 2), (TC.SWORD, 0, 0), (TC.MUTEX, 0, 2)],
     "dataspace entry 0: array elements of type {sword, mutex} hold a mutex"),
])
def test_array_elements_the_firmware_could_not_hold_are_refused(toc, text):
    data = tiny_rxe(FINCLUMP, toc=toc, static=struct.pack("<H", 1),
                    dope_vectors=[(2 + 20, 2, 3)], contents=bytes(6))
    with pytest.raises(RxeError) as info:
        load_rxe(data, "t.rxe")
    assert str(info.value) == "t.rxe: " + text


def test_initial_arrays_that_fill_the_pool_exactly_still_load_and_run():
    data = _flat(_ROOM // 2 - 1)  # 4-byte aligned: _ROOM - 2 bytes
    exe = load_rxe(data)
    assert len(exe.initial[0]) == _ROOM // 2 - 1
    fw = Firmware(flash_files={"full.rxe": data})
    fw.start_program_now("full.rxe")
    fw.tick()
    assert fw.program_errors == []


@pytest.mark.parametrize("body, text", [
    # 60,000 copies of a 20,000-byte row: refused before one is made
    ("int row[]; ArrayInit(row, 7, 10000); ArrayInit(grid, row, 60000);",
     "ARRINIT: out of memory: 1200000000 bytes needed, the brick's pool has 32768 "
     "(60000 elements holding 20000 bytes of arrays each)"),
    # rows replaced by longer ones until the pool is full
    ("int row[]; ArrayInit(grid, row, 100); ArrayInit(row, 1, 2000);"
     " for (int i = 0; i < 100; i++) grid[i] = row;",
     "out of memory"),
])
def test_nested_arrays_count_in_the_pool_so_a_program_cannot_allocate_without_end(tmp_path, body,
                                                                                   text):
    rxe = _compile(tmp_path, "grow", "int grid[][];\ntask main() { " + body + " }\n")
    fw = Firmware(flash_files={"g.rxe": rxe})
    fw.start_program_now("g.rxe")
    for _ in range(200):
        fw.tick()
        if fw.program is None:
            break
    (error,) = fw.program_errors
    assert error.startswith("program g.rxe aborted: ") and text in error


# -- instructions no compiler writes ---------------------------------------------------------


def test_setout_without_fields_names_ports_and_does_nothing():
    data = tiny_rxe((0xE031, 6, 0) + FINCLUMP, toc=[(TC.UBYTE, 0, 0)], static=b"\0")
    fw = Firmware(flash_files={"t.rxe": data})
    fw.start_program_now("t.rxe")
    fw.tick()
    assert fw.program is None and fw.program_errors == []


def test_a_variable_size_instruction_without_operands_stops_the_program_naming_it():
    data = tiny_rxe((0xE031, 4) + FINCLUMP, toc=[(TC.UBYTE, 0, 0)], static=b"\0")
    fw = Firmware(flash_files={"t.rxe": data})
    fw.start_program_now("t.rxe")
    fw.tick()
    assert fw.program is None
    assert fw.program_errors == ["program t.rxe aborted: SETOUT: a variable-size instruction of "
                                 "4 bytes, without its first operand at pc 0 (0x0000), clump 0"]
    assert fw.handle(GET_PROGRAM_NAME)[:3] == b"\x02\x11\xec"  # the link says: no program


@pytest.mark.parametrize("code, toc, static, text", [
    # BRCMP.EQ +4, sword 0, sword[] 1: a scalar is no aggregate
    ((0x8426, 4, 0, 1), [(TC.SWORD, 0, 0), (TC.ARRAY, 0, 2), (TC.SWORD, 0, 0)],
     b"\0\0\x01\0", "BRCMP: comparing a sword with a sword[]"),
    # NEG slong 0, mutex 1
    ((0x6002, 0, 1), [(TC.SLONG, 0, 0), (TC.MUTEX, 0, 4)], bytes(4) + b"\xff\0\0\0",
     "NEG: a mutex is no operand (slong destination, mutex source)"),
])
def test_operands_of_the_wrong_kind_stop_the_program_naming_them(code, toc, static, text):
    data = tiny_rxe(code + FINCLUMP, toc=toc, static=static, dope_vectors=[(0, 2, 0)])
    fw = Firmware(flash_files={"t.rxe": data})
    fw.start_program_now("t.rxe")
    fw.tick()
    assert fw.program is None
    assert fw.program_errors == [f"program t.rxe aborted: {text} at pc 0 (0x0000), clump 0"]


@pytest.mark.parametrize("fused", [True, False])
def test_anything_an_instruction_raises_stops_the_program_with_a_vm_error(tmp_path, monkeypatch,
                                                                          fused):
    """The last line of defence: a value the interpreter cannot handle ends the program
    like any run-time error, with the instruction named, and the brick answers."""
    def broken(vm, args):
        raise KeyError("no such thing")

    monkeypatch.setitem(SYSCALLS, 24, Syscall(broken, SYSCALLS[24].arity))  # RandomNumber
    rxe = _compile(tmp_path, "rnd", "task main() { long a = 1; long b = a + 2; "
                                    "int r = Random(); NumOut(0, 0, r + b); }\n")
    fw = Firmware(FirmwareParams(vm_fused=fused), flash_files={"r.rxe": rxe})
    fw.start_program_now("r.rxe")
    fw.tick()
    (error,) = fw.program_errors
    assert error.startswith("program r.rxe aborted: SYSCALL: the interpreter cannot execute it "
                            "(KeyError: 'no such thing') at pc ")
    assert fw.program is None and fw.handle(GET_PROGRAM_NAME)[:3] == b"\x02\x11\xec"


def test_the_vm_errors_are_the_packages_errors():
    assert issubclass(RxeError, LinkError) and issubclass(RxeError, ValueError)
    assert issubclass(VMError, LinkError) and issubclass(VMError, RuntimeError)


# -- damaged files ------------------------------------------------------------------------


def _seed(name: str) -> bytes:
    return compile_nxc(NXC_DIR / f"{name}.nxc").rxe


SEEDS = {name: _seed(name) for name in ("vm_arrays", "vm_calls", "vm_tables")}


def test_the_seed_of_initial_tables_runs():
    fw = run_program(SEEDS["vm_tables"])
    assert fw.program_errors == [] and results(fw) == ["25"]


def _regions(data: bytes) -> dict[str, tuple[int, int]]:
    """Where a file's tables are: header fields, TOC, dope vectors, codespace."""
    (ds_count, _, static_size, _, dyn_off, _, _, _, dva_offset, _, code_count
     ) = struct.unpack_from("<11H", data, 16)
    defaults = 38 + 4 * ds_count
    defaults += defaults % 2
    dva = defaults + dyn_off + dva_offset - static_size
    count = struct.unpack_from("<H", data, dva + 4)[0]
    return {"header": (16, 38), "toc": (38, 38 + 4 * ds_count), "dope": (dva, dva + 10 * count),
            "code": (len(data) - 2 * code_count, len(data)), "anywhere": (0, len(data))}


@st.composite
def damaged(draw: st.DrawFn, name: str) -> bytes:
    """A seed with a few bytes or words changed (anywhere, or aimed at the header, the
    table of contents, the dope vectors or the code), cut short or with bytes inserted."""
    data = bytearray(SEEDS[name])
    regions = _regions(SEEDS[name])
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(("byte", "word")))
        lo, hi = regions[draw(st.sampled_from(sorted(regions)))]
        pos = draw(st.integers(lo, min(hi, len(data)) - 2))
        if kind == "byte":
            data[pos] = draw(st.integers(0, 255))
        else:
            word = draw(st.sampled_from((0, 1, 2, 0x7FFF, 0x8000, 0xFFFE, 0xFFFF))
                        | st.integers(0, 0xFFFF))
            data[pos:pos + 2] = struct.pack("<H", word)
    cut = draw(st.sampled_from(("none", "truncate", "insert")))
    if cut == "truncate":
        del data[draw(st.integers(0, len(data) - 1)):]
    elif cut == "insert":
        pos = draw(st.integers(0, len(data)))
        data[pos:pos] = draw(st.binary(min_size=1, max_size=4))
    return bytes(data)


@pytest.mark.parametrize("name", sorted(SEEDS))
@settings(max_examples=120)
@given(data=st.data())
def test_a_damaged_file_is_refused_or_run_and_only_the_packages_errors_come_out(name, data):
    raw = data.draw(damaged(name))
    try:
        load_rxe(raw, "d.rxe")
    except RxeError as exc:
        assert str(exc).startswith("d.rxe: ") and "\n" not in str(exc)
        return
    # it loads: it runs, ends or is aborted (50 slices of the default 500 instructions),
    # and the brick still answers
    fw = Firmware(flash_files={"d.rxe": raw})
    fw.start_program_now("d.rxe")
    for _ in range(50):
        fw.tick()
        if fw.program is None:
            break
    assert all("\n" not in e and e.startswith(("program d.rxe aborted: ", "cannot run d.rxe"))
               for e in fw.program_errors)
    reply = fw.handle(GET_PROGRAM_NAME)
    assert reply is not None and reply[2] in (0x00, 0xEC)
