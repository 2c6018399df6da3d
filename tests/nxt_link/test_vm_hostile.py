"""Hostile programs and files: a valid program that never gives the CPU back, files whose
dope vectors claim more memory than the brick has, programs that allocate without end, and
damaged files. Each is refused or stopped cleanly: the emulator goes on answering, only the
package's own errors (``RxeError`` at load, ``VMError`` at run) come out, and each file is
refused before anything large is built.

Every test is bounded without depending on the machine's speed: what they assert is
counted (instructions per slice, examples, ticks), and :func:`vmtools.bounded` only turns a
hang into a failure, far above what the test needs.
"""
from __future__ import annotations

from pathlib import Path

import pytest
from vmtools import bounded

from nxt_link.firmware import Firmware, FirmwareParams
from nxt_link.vm import compile_nxc
from nxt_link.vm.scheduler import INSTRUCTIONS_PER_TURN, MAX_OVERRUN

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
    with bounded():
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
    with bounded():
        for _ in range(10):
            before = vm.instructions
            fw.tick()
            assert vm.instructions - before == 500


def test_the_emulated_brick_answers_a_client_while_the_ping_pong_runs(rig, ping_pong):
    brick = rig.add("r1", flash_files={"pp.rxe": ping_pong}, start_program="pp.rxe")
    with bounded():
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
        with bounded():
            assert brick.get_current_program_name() == "pp.rxe"
            assert brick.get_battery_level() == 9000
    finally:
        brick.close()
