"""`cplus brick`'s fault options do what they say, seen from a client over the real pty.

Each test starts ``cplus brick`` as a process (``--no-latency``, a fixed ``--seed``) and
talks to it with our client (:class:`~nxt_link.Brick` over :class:`~nxt_link.SerialTransport`)
the way ``cplus execute`` does: the faults must show up as the client's retries,
damaged-reply resyncs and reconnects, and every answer that comes back must be right.
Timing enters only as lower bounds (a frame delayed by D arrives no sooner than D), which a
loaded machine cannot break.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from walltime import wall

from nxt_link import Brick, LinkTimeoutError, RetryPolicy, SerialTransport, SetpointStream, execute_streams
from nxt_link.emulator.pty_server import MAX_LAG_S

pytestmark = pytest.mark.slow          # real processes on real ptys, in real time

ROOT = Path(__file__).resolve().parents[2]
BATTERY_MV = 7777


class BrickProcesses:
    """``cplus brick`` processes: ``start`` returns the pty to open, ``stop`` ends one and
    returns what it said on standard error (its frame counts come last)."""

    def __init__(self) -> None:
        self.procs: dict[str, subprocess.Popen] = {}

    def __call__(self, *options: str) -> str:
        proc = subprocess.Popen([sys.executable, "-m", "cplus", "brick", "--name", "r1", "--no-latency",
                                 "--seed", "7", "--battery-mv", str(BATTERY_MV), *options],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                                env={**os.environ, "PYTHONUNBUFFERED": "1"})
        path = proc.stdout.readline().strip()   # type: ignore[union-attr]
        assert path, proc.stderr.read()         # type: ignore[union-attr]
        self.procs[path] = proc
        return path

    def stop(self, path: str) -> str:
        proc = self.procs.pop(path)
        proc.send_signal(signal.SIGTERM)
        try:
            _, err = proc.communicate(timeout=wall(20))
        except subprocess.TimeoutExpired:     # pragma: no cover - only if it hangs
            proc.kill()
            _, err = proc.communicate()
        return err


@pytest.fixture
def brick_process():
    bricks = BrickProcesses()
    yield bricks
    for path in list(bricks.procs):
        bricks.stop(path)


def client(path: str, events: list, **policy) -> Brick:
    return Brick(SerialTransport(path), name="r1", on_event=events.append,
                 policy=RetryPolicy(**{"reply_timeout_s": 0.25, "retries": 12, "quiet_s": 0.02,
                                       "reconnect_timeout_s": 10.0, **policy}))


def kinds(events) -> set[str]:
    return {e.event for e in events}


def test_without_faults_nothing_is_retried(brick_process):
    events: list = []
    with client(brick_process(), events, reply_timeout_s=5.0) as b:
        assert [b.get_battery_level() for _ in range(20)] == [BATTERY_MV] * 20
    assert events == []


def test_drop_loses_frames_and_the_client_retries(brick_process):
    events: list = []
    # half of all attempts fail (a frame either way lost); 30 retries make giving up a 1e-9 event
    with client(brick_process("--drop", "0.3"), events, reply_timeout_s=0.25, retries=30) as b:
        assert [b.get_battery_level() for _ in range(10)] == [BATTERY_MV] * 10
    assert "timeout" in kinds(events)


def test_corrupt_damages_replies_that_the_client_sees(brick_process):
    """Direct commands have no checksum: a flipped byte in a reply is caught when it breaks
    the telegram (retried like a lost reply), or comes back as a wrong value; either way the
    client sees it."""
    events: list = []
    path = brick_process("--corrupt", "0.3")
    with client(path, events, reply_timeout_s=0.3, retries=30) as b:
        values = [b.get_battery_level() for _ in range(30)]
    counts = re.search(r"corrupted (\d+)/(\d+)", brick_process.stop(path))
    assert counts is not None and int(counts[2]) > 0           # replies were corrupted
    assert events or set(values) != {BATTERY_MV}


def test_corrupt_never_gets_past_the_streaming_protocol(brick_process, wave):
    """Setpoints and the log travel in CRC-checked mailbox messages: under corruption the
    brick still holds exactly what was sent (its checksum said so before GO).

    The brick runs in real time, as a real one does (about 5 s here). A ``cplus brick``
    process cannot share the test's simulated clock, and at ten times real time its
    emulation needs a fifth of a core: at load 24 it gets less, falls further behind with
    every step, and the client rightly reports a brick silent for 10 s. In real time it
    needs 2 % of a core."""
    path = brick_process("--corrupt", "0.1")
    rows = wave(40, (120, -60))
    events: list = []
    with client(path, events, reply_timeout_s=0.5) as b:
        log = execute_streams([SetpointStream("r1", ("A", "B"), 50, rows)], {"r1": b})
    got = log.brick("r1")
    assert got.reference_deg == rows and len(got.measured_deg) == len(rows)
    counts = re.search(r"corrupted (\d+)/(\d+)", brick_process.stop(path))
    assert counts is not None and int(counts[1]) + int(counts[2]) > 0       # it did happen


def test_delay_holds_every_frame_back(brick_process):
    path = brick_process("--delay", "400")
    events: list = []
    with client(path, events, reply_timeout_s=0.2, retries=0) as b:
        with pytest.raises(LinkTimeoutError):
            b.keep_alive()                    # the answer needs 2 x 400 ms
    with client(path, events, reply_timeout_s=10.0, retries=0) as b:
        b.get_battery_level()                 # the late KEEPALIVE reply is skipped as stale
        t0 = time.monotonic()
        assert b.get_battery_level() == BATTERY_MV
        # there and back, 400 ms each way of the brick's clock, which may lag real time by up
        # to MAX_LAG_S on a loaded machine and then catch up (a run at load 12 measured
        # 0.795 s); one delayed direction alone would take about 0.4 s
        assert time.monotonic() - t0 >= 0.8 - MAX_LAG_S


def test_disconnect_after_drops_the_link_once_and_the_client_reconnects(brick_process):
    events: list = []
    with client(brick_process("--disconnect-after", "10"), events, reply_timeout_s=2.0) as b:
        assert [b.get_battery_level() for _ in range(25)] == [BATTERY_MV] * 25
    assert [e.event for e in events if e.event == "reconnected"] == ["reconnected"]
