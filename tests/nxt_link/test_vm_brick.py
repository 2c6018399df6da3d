"""The compiled program on emulated bricks behind real ptys: nxt-python uploads and
starts programs, a whole execution runs on the interpreter, ``cplus brick`` runs
the compiled follower by default, ``--program`` any file, and says when it cannot."""
from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import nxt.error
import nxt.locator
import pytest
from vmtools import FINCLUMP, NXC_DIR, tiny_rxe

from nxt_link.emulator.emulator import compiled_follower
from nxt_link.emulator.vm import compile_nxc
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.host.brick import Brick
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming
from nxt_link.wire.clock import SimClock
from nxt_link.wire.serial_transport import SerialTransport

pytestmark = pytest.mark.slow   # processes and ptys, in real time

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def follower():
    return compiled_follower()


def test_nxt_python_uploads_lists_reads_back_starts_and_deletes(pty_server, tmp_path):
    src = tmp_path / "calls.nxc"
    src.write_text('task main() { SendResponseString(0, "hello PC"); while (true) Wait(100); }\n')
    data = compile_nxc(src).rxe
    server = pty_server("r1", time_scale=1.0, program_running=False)
    brick = nxt.locator.find(backends=["devfile"], filename=server.path, config=None)
    try:
        with brick.open_file("calls.rxe", "wb", len(data)) as f:
            f.write(data)
        assert ("calls.rxe", len(data)) in list(brick.find_files("*.rxe"))
        with brick.open_file("calls.rxe", "rb") as f:
            assert f.read() == data
        with pytest.raises(nxt.error.FileExistsError):
            brick.open_file("calls.rxe", "wb", 10)
        brick.start_program("calls.rxe")
        deadline = time.monotonic() + 60   # a guard against hanging, not a measure
        while time.monotonic() < deadline and not server.emulator.firmware.mailboxes[10]:
            time.sleep(0.05)
        assert brick.get_current_program_name() == "calls.rxe"
        _, message = brick.message_read(10, 0, True)  # the program's response queue 0
        assert message == b"hello PC\0"
        with pytest.raises(nxt.error.SystemProtocolError):
            brick.file_delete("calls.rxe")  # a running program's file is busy
        brick.stop_program()
        time.sleep(0.1)
        brick.file_delete("calls.rxe")
        assert list(brick.find_files("*.*")) == []
    finally:
        brick.close()


def test_an_execution_runs_on_the_compiled_program(pty_server, wave, follower):
    """Over the pty, on simulated time (the interpreter's speed changes nothing but the wall time)."""
    files, symbols = follower
    clock = SimClock()
    with clock.participant("test"):
        server = pty_server("r1", flash_files=files, symbols=symbols, clock=clock)
        emu = server.emulator
        assert emu.vm_program is not None
        stream = SetpointStream("r1", ("A", "B"), 50, wave(40, (60, -45)))
        timing = SessionTiming(ack_timeout_s=0.5, max_silent_s=5.0, homing_timeout_s=5.0)
        brick = Brick(SerialTransport(server.path, clock=clock), name="r1")
        try:
            log = execute_streams([stream], {"r1": brick}, options=ExecutionOptions(timing=timing))
        finally:
            brick.close()
            server.stop()
    assert emu.program.reference_rows() == list(stream.rows)
    assert log.brick("r1").measured_deg == tuple(emu.program.measured_rows())
    assert emu.firmware.program_errors == []


def _brick_process(*extra: str, env: dict | None = None) -> tuple[str, str]:
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "brick", "--name", "r9",
                             "--no-latency", *extra], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, env=env)
    assert proc.stdout is not None
    path = proc.stdout.readline().strip()
    time.sleep(1.5)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, err
    return path, err


def test_cplus_brick_reports_a_program_the_brick_aborts(tmp_path):
    data = compile_nxc(NXC_DIR / "vm_arrays.nxc").rxe
    prog = tmp_path / "arrays.rxe"
    prog.write_bytes(data)
    path, err = _brick_process("--program", str(prog))
    assert path.endswith("tty")
    assert "cplus brick: r9: program arrays.rxe aborted: INDEX: index 10 is outside" in err


def test_cplus_brick_without_nbc_runs_the_model_and_says_so():
    env = {**os.environ, "PATH": os.path.dirname(sys.executable)}
    _, err = _brick_process(env=env)
    assert "nbc not found: running the Python model of cplus_follow.nxc" in err


def test_cplus_brick_serves_a_program_that_never_gives_the_cpu_back(tmp_path):
    """Two tasks handing over to each other with ExitTo: the brick keeps its milliseconds
    (so it answers), and SIGTERM stops it (``_brick_process`` asserts exit code 0)."""
    src = tmp_path / "pingpong.nxc"
    src.write_text("task b();\ntask a() { ExitTo(b); }\ntask b() { ExitTo(a); }\n"
                   "task main() { ExitTo(a); }\n")
    prog = tmp_path / "pingpong.rxe"
    prog.write_bytes(compile_nxc(src).rxe)
    path, err = _brick_process("--program", str(prog))
    assert path.endswith("tty") and "aborted" not in err


def _bomb() -> bytes:
    """A file whose dope vectors claim 65,535 rows of 65,535 zero-byte elements."""
    toc = [(TC.ARRAY, 0, 0), (TC.ARRAY, 0, 0), (TC.SWORD, 0, 0)]
    return tiny_rxe(FINCLUMP, toc=toc, static=struct.pack("<H", 1),
                    dope_vectors=[(32, 0, 0xFFFF), (32, 0, 0xFFFF)], contents=struct.pack("<H", 2))


@pytest.mark.parametrize("make, text", [
    (lambda d: (d / "x.rxe", b"junk"), "x.rxe: not an NXT executable"),
    (lambda d: (d / "a_very_long_program_name.rxe", b""), "at most 19 characters"),
    (lambda d: (d / "missing.rxe", None), "cannot read"),
    (lambda d: (d / "bomb.rxe", _bomb()),
     "bomb.rxe: array at dataspace entry 0: dope vector 1 gives 0-byte elements"),
    (lambda d: (d / "cut.rxe", compiled_follower()[0]["cplus_follow.rxe"][:5000]),
     "cut.rxe: truncated: the header promises"),
])
def test_cplus_brick_refuses_a_bad_program_in_one_line(tmp_path, make, text):
    path, data = make(tmp_path)
    if data is not None:
        path.write_bytes(data)
    proc = subprocess.run([sys.executable, "-m", "cplus", "brick", "--name", "r1", "--program",
                           str(path)], capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and text in proc.stderr

