"""The behaviour client on the real serial path: pyserial on the emulator's pty, and
``cplus brick --world`` as a separate process."""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from cplus.cli import main
from nxt_link import Behaviour, BehaviourClient, Brick, BrickEvent, delivery_world
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.emulator.pty_server import PtyBrickServer
from nxt_link.host.brick import RetryPolicy
from nxt_link.wire.clock import SimClock
from nxt_link.wire.serial_transport import SerialTransport

pytestmark = pytest.mark.slow   # processes and ptys, in real time

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "domains" / "delivery" / "world.toml"
POLICY = RetryPolicy(reply_timeout_s=0.25, retries=3, quiet_s=0.02, reconnect_timeout_s=3.0)
# a `cplus brick` process keeps the wall clock: at real time a slow machine has the brick's
# whole 10.5 s to answer its requests for more time (at 4x it had 2.6 s, which six CPU-bound
# processes on two cores took away)
SCALE = 1.0


def poll_until_some(client: BehaviourClient, polls: int = 100) -> list[BrickEvent]:
    """Poll until an event arrives (a bound against hanging, not a timing assertion)."""
    for _ in range(polls):
        got = client.poll_events()
        if got:
            return got
        client.brick.clock.sleep(0.05)
    return []


def test_client_over_a_pty_with_dropped_frames_runs_each_action_once():
    """On simulated time: the brick, the link and this thread share a SimClock, so however
    slow the machine, the PC answers the brick's requests for more time in (simulated) time."""
    emu = BrickEmulator(EmulatorConfig(
        name="robot", world=delivery_world(seed=8), link=LinkParams.instant(),
        faults=FaultParams(drop=0.05, seed=8)))
    clock = SimClock()
    with clock.participant("test"), PtyBrickServer(emu, clock=clock) as server:
        client = BehaviourClient(Brick(SerialTransport(server.path, clock=clock), name="robot",
                                       policy=POLICY))
        try:
            client.connect()
            first = client.act(Behaviour.FOLLOW)
            client.act(Behaviour.TURN)
            back = client.act(Behaviour.FOLLOW)
            assert (first.sensing["landmark"], back.sensing["landmark"]) == (2, 1)
            assert emu.world is not None
            emu.world.press(0.3)
            events = poll_until_some(client)
        finally:
            client.close()
        assert events == [BrickEvent("button")]
        program = emu.legolog
        assert program is not None
        assert program.started == [(1, Behaviour.FOLLOW), (2, Behaviour.TURN),
                                   (3, Behaviour.FOLLOW)]
        assert emu.stats.dropped_in + emu.stats.dropped_out > 0
        assert server.error is None


def test_cplus_brick_with_a_world_serves_the_delivery_robot_through_faults():
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "brick", "--name", "robot",
                             "--world", str(WORLD), "--no-latency", "--time-scale", str(SCALE),
                             "--drop", "0.1", "--corrupt", "0.05", "--delay", "10",
                             "--seed", "3"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stdin is not None
        path = proc.stdout.readline().strip()
        assert os.path.islink(path)
        client = BehaviourClient(Brick(SerialTransport(path), name="robot", policy=POLICY))
        client.connect()
        r = client.act(Behaviour.FOLLOW)
        assert r.sensing["landmark"] == 2
        # the world file presses the button 4 s (simulated) after power-on: on the way
        assert client.poll_events() == [BrickEvent("button")]
        proc.stdin.write("press\n")  # an interactive press
        proc.stdin.flush()
        assert poll_until_some(client) == [BrickEvent("button")]
        client.close()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 0
        err = proc.stderr.read() if proc.stderr else ""
        assert "(landmark 2)" in err and "2 press(es)" in err
        dropped = re.search(r"dropped (\d+)/(\d+), corrupted (\d+)/(\d+)", err)
        assert dropped is not None and sum(map(int, dropped.groups())) > 0
        # the compiled cplus_legolog.rxe ran on the bytecode interpreter, not the model
        assert "Python model" not in err and "aborted" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_a_bad_world_file_is_a_located_error(tmp_path, capsys):
    bad = tmp_path / "world.toml"
    bad.write_text('format = "cplus.world/1"\n[track]\npoints = [[0, 0], [1000, 0]]\n'
                   '[start]\nat_mm = 100\n[ports]\nlight = 2\n')
    assert main(["brick", "--name", "robot", "--world", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:7:1: error: ports.light: the brick program cplus_legolog.rxe "
                          "uses port 3 for it")
    assert main(["brick", "--name", "robot", "--world", str(tmp_path / "none.toml")]) == 2
    assert "cannot read world file" in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["--stall", "D@1"], "expected PORT@SECONDS[+DURATION] with PORT in A, B, C"),
    (["--stall", "A@x"], "expected PORT@SECONDS"),
    (["--stall", "A@1+0"], "a stall's duration must be > 0 s"),
    (["--stall", "A@1", "--stall", "A@2"], "two stalls on one port"),
])
def test_bad_stalls_are_one_line_and_exit_2(capsys, argv, message):
    assert main(["brick", "--name", "r1", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("cplus brick: error: ") and message in err
