"""The real serial path: pyserial on the emulator's pty, `cplus brick` as a process."""
from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from contextlib import nullcontext
from pathlib import Path

import pytest

from cplus.cli import main
from nxt_link.emulator.emulator import FaultParams
from nxt_link.host.brick import Brick, RetryPolicy
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming
from nxt_link.wire import errors
from nxt_link.wire.clock import MONOTONIC, SimClock
from nxt_link.wire.serial_transport import SerialTransport

ROOT = Path(__file__).resolve().parents[2]
# A reply later than 0.25 s (a dropped frame, or a busy machine) only costs a retry: with ten
# of them neither twelve per cent of dropped frames nor a loaded machine ends the session.
POLICY = RetryPolicy(reply_timeout_s=0.25, retries=10, quiet_s=0.02, reconnect_timeout_s=3.0)
OPTIONS = ExecutionOptions(timing=SessionTiming(ack_timeout_s=0.3, poll_gap_s=0.002,
                                                query_interval_s=0.05, max_silent_s=8.0),
                           start_delay_s=0.3)


def test_pty_is_a_raw_tty_behind_a_stable_symlink(pty_server):
    server = pty_server("r1")
    assert os.path.islink(server.path)
    assert stat.S_ISCHR(os.stat(server.path).st_mode)
    with SerialTransport(server.path) as t:
        b = Brick(t, name="r1", policy=POLICY)
        assert b.get_battery_level() == 9000
        assert b.get_current_program_name() == "cplus_follow.rxe"


@pytest.mark.parametrize("simulated", [True, False], ids=["simulated-time", "wall-clock"])
def test_two_bricks_over_ptys_with_drops_and_a_disconnect(pty_server, wave, simulated):
    """On simulated time (the bricks, the link and this thread on one SimClock: nothing
    depends on the machine's load), and on the wall clock, ten times faster, as `cplus brick`
    runs (the generous POLICY keeps a loaded machine from ending the session)."""
    clock = SimClock() if simulated else None
    with clock.participant("test") if clock is not None else nullcontext():
        servers = {
            "r1": pty_server("r1", faults=FaultParams(drop=0.12, disconnect_after=30, seed=3), clock=clock),
            "r2": pty_server("r2", faults=FaultParams(drop=0.12, seed=4), clock=clock),
        }
        streams = [SetpointStream("r1", ("A", "B"), 50, wave(60, (90, 60), 30)),
                   SetpointStream("r2", ("A", "C"), 50, wave(60, (-90, 30), 30))]
        bricks = {n: Brick(SerialTransport(s.path, clock=clock or MONOTONIC), name=n, policy=POLICY)
                  for n, s in servers.items()}
        try:
            log = execute_streams(streams, bricks, options=OPTIONS)
        finally:
            for b in bricks.values():
                b.close()
            for s in servers.values():
                s.stop()
    for stream in streams:
        emu = servers[stream.brick].emulator
        assert emu.program.reference_rows() == list(stream.rows)
        assert log.brick(stream.brick).measured_deg == tuple(emu.program.measured_rows())
    assert servers["r1"].emulator.stats.disconnects == 1
    events = [e.event for e in log.brick("r1").events]
    assert "link lost" in events and "reconnected" in events


def test_wrong_port_is_one_clear_line(tmp_path):
    with pytest.raises(errors.PortOpenError) as info:
        SerialTransport(str(tmp_path / "rfcomm9"))
    assert str(info.value) == f"cannot open {tmp_path / 'rfcomm9'}: no such device"
    regular = tmp_path / "file"
    regular.write_text("x")
    with pytest.raises(errors.PortOpenError) as info:
        SerialTransport(str(regular))
    assert str(info.value).startswith(f"cannot open {regular}: ") and "\n" not in str(info.value)


def test_a_silent_brick_times_out(pty_server):
    server = pty_server("r1", faults=FaultParams(delay_ms=20000))
    with SerialTransport(server.path) as t:
        b = Brick(t, name="r1", policy=RetryPolicy(reply_timeout_s=0.1, retries=1))
        with pytest.raises(errors.LinkTimeoutError, match="brick r1 did not answer "
                                                          r"GET_BATTERY_LEVEL for 0\.\d s \("):
            b.get_battery_level()


def test_cplus_brick_prints_the_path_and_stops_cleanly_on_sigterm():
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "brick", "--name", "r7",
                             "--no-latency", "--time-scale", "5"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        path = proc.stdout.readline().strip()
        assert os.path.islink(path)
        with SerialTransport(path) as t:
            assert Brick(t, policy=POLICY).keep_alive() == 600000
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
        assert not os.path.exists(path)
        assert "r7:" in proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("argv, message", [
    ([], "the following arguments are required: --name"),
    (["--name", "r1", "--drop", "1.5"], "probability must be in [0, 1)"),
    (["--name", "r1", "--delay", "-3"], "must be at least 0 and at most 10000 milliseconds, got '-3'"),
    (["--name", "r1", "--disconnect-after", "0"], "must be >= 1"),
    (["--name", "r1", "--time-scale", "0"], "must be at least 0.001 and at most 1000 times real time"),
    (["--name", "r1", "--bogus"], "unrecognized arguments: --bogus"),
    (["--name", "a/b"], "invalid brick name"),
])
def test_bad_options_are_one_line_and_exit_2(capsys, argv, message):
    assert main(["brick", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("cplus brick: error: ") and message in err
