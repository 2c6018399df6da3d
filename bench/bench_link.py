"""Measure the NXT link against the emulator, through the real serial path.

Each emulated brick runs as its own ``cplus brick`` process on a pty (so the
client and the emulator do not share an interpreter), and the client uses
pyserial exactly as it would on ``/dev/rfcomm0``. Three figures, each the
median of ``--runs`` runs, with and without the Bluetooth latency model:

* round trips per second of a reply-required direct command (GETBATTERYLEVEL);
* setpoints per second uploaded with the streaming protocol (sequence numbers,
  acknowledgements, CRC, go-back-N window of 4), 2 ports x 600 ticks;
* CPU use of one emulator process per simulated brick while it executes a
  trajectory in real time (firmware, brick program and motor physics at 1 kHz),
  from /proc/<pid>/stat.

Usage: ``python bench/bench_link.py [--runs 5] [--quick]``. Prints a table;
nothing is asserted (speed is measured here, never in the test suite).
"""
from __future__ import annotations

import argparse
import math
import os
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nxt_link.host.brick import Brick, RetryPolicy  # noqa: E402
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams  # noqa: E402
from nxt_link.host.session import BrickSession  # noqa: E402
from nxt_link.wire.serial_transport import SerialTransport  # noqa: E402

CLK_TCK = os.sysconf("SC_CLK_TCK")


class BrickProcess:
    """``cplus brick`` in a subprocess; .path is its pty."""

    def __init__(self, name: str, latency: bool) -> None:
        args = [sys.executable, "-m", "cplus", "brick", "--name", name, "--seed", "1"]
        if not latency:
            args.append("--no-latency")
        self.proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True)
        self.path = self.proc.stdout.readline().strip()
        if not self.path:
            raise RuntimeError("cplus brick did not start")

    def cpu_s(self) -> float:
        with open(f"/proc/{self.proc.pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / CLK_TCK

    def close(self) -> None:
        self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def round_trips(latency: bool, seconds: float) -> float:
    bp = BrickProcess("b1", latency)
    try:
        with SerialTransport(bp.path) as t:
            brick = Brick(t, policy=RetryPolicy(reply_timeout_s=3.0))
            brick.get_battery_level()
            n, start = 0, time.monotonic()
            while time.monotonic() - start < seconds:
                brick.get_battery_level()
                n += 1
            return n / (time.monotonic() - start)
    finally:
        bp.close()


def rows(n: int) -> tuple[tuple[int, int], ...]:
    return tuple((int(200 * math.sin(k / 30)), int(90 * math.sin(k / 45))) for k in range(n))


def upload_rate(latency: bool, n_rows: int) -> float:
    bp = BrickProcess("b1", latency)
    try:
        with SerialTransport(bp.path) as t:
            brick = Brick(t, name="b1")
            session = BrickSession(brick, ("A", "B"), 50, rows(n_rows), ((-3600, 3600),) * 2)
            session.open()
            start = time.monotonic()
            session.upload()
            return n_rows * 2 / (time.monotonic() - start)
    finally:
        bp.close()


def emulator_cpu(latency: bool, n_rows: int) -> float:
    """CPU % of one brick process over an execution on two bricks (real time)."""
    procs = [BrickProcess(n, latency) for n in ("b1", "b2")]
    try:
        bricks = {f"b{i + 1}": Brick(SerialTransport(p.path), name=f"b{i + 1}")
                  for i, p in enumerate(procs)}
        streams = [SetpointStream(n, ("A", "B"), 50, rows(n_rows)) for n in bricks]
        cpu0 = [p.cpu_s() for p in procs]
        wall0 = time.monotonic()
        execute_streams(streams, bricks, options=ExecutionOptions())
        wall = time.monotonic() - wall0
        cpu = [p.cpu_s() - c for p, c in zip(procs, cpu0)]
        for b in bricks.values():
            b.close()
        return 100.0 * statistics.mean(cpu) / wall
    finally:
        for p in procs:
            p.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="shorter runs")
    args = ap.parse_args()
    rt_s = 1.0 if args.quick else 3.0
    up_rows = 300 if args.quick else 600
    run_rows = 60 if args.quick else 200
    results = []
    for latency in (True, False):
        label = "BT latency model" if latency else "no latency"
        rt = [round_trips(latency, rt_s) for _ in range(args.runs)]
        up = [upload_rate(latency, up_rows) for _ in range(args.runs)]
        cpu = [emulator_cpu(latency, run_rows) for _ in range(max(1, args.runs // 2))]
        results.append((label, statistics.median(rt), statistics.median(up),
                        statistics.median(cpu)))
    print(f"{'link':<18} {'round trips/s':>14} {'setpoints/s (acked)':>20} "
          f"{'emulator CPU %/brick':>21}")
    for label, rt, up, cpu in results:
        print(f"{label:<18} {rt:>14.1f} {up:>20.0f} {cpu:>21.1f}")
    print(f"(median of {args.runs} runs; CPU over an execution of {run_rows} ticks x 50 ms on "
          f"two bricks; {os.cpu_count()} CPUs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
