"""Measure bricks emulated in-process on simulated time (issue 19).

The payload execution of ``cplus run`` (two bricks behind real ptys, pyserial, one
:class:`nxt_link.SimClock`; 91 ticks of 100 ms, three motors each) with the brick program's
Python model and with the compiled ``cplus_follow.rxe`` on the bytecode interpreter, with and
without the Bluetooth latency model. Per configuration, medians of ``--runs`` runs: wall
time, simulated time, baton passes of the clock, CPU of each brick's thread; and whether
every run gave the same log (it must: simulated time depends on nothing but the inputs).

``--busy N`` adds N CPU-bound processes for the duration (killed at the end), to see what a
loaded machine does to the wall time (and that it does nothing to the log).

Usage: ``python bench/bench_simtime.py [--runs 3] [--busy 6]``. Prints a table; nothing is
asserted.
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import nxt_link  # noqa: E402
from nxt_link.emulator.inprocess import EmulatedBricks  # noqa: E402


def rows(n: int) -> tuple[tuple[int, ...], ...]:
    return tuple(tuple(int(round(a * math.sin(2 * math.pi * k / (40 * (1 + 0.5 * j)))))
                       for j, a in enumerate((200, 100, 50))) for k in range(n))


def run(latency: bool, compiled: bool) -> tuple[float, float, int, float, str]:
    t0 = time.monotonic()
    with EmulatedBricks(seed=0, compiled=compiled) as emu:
        link = nxt_link.LinkParams() if latency else nxt_link.LinkParams.instant()
        bricks = {n: nxt_link.Brick(emu.add(nxt_link.EmulatorConfig(name=n, link=link)), name=n)
                  for n in ("r1", "r2")}
        streams = [nxt_link.SetpointStream(n, ("A", "B", "C"), 100, rows(91)) for n in bricks]
        log = nxt_link.execute_streams(streams, bricks, session_ids=emu.session_ids(bricks))
        cpu = max(s.cpu_s for s in emu.servers.values())
    clock = emu.clock
    assert isinstance(clock, nxt_link.SimClock)
    return time.monotonic() - t0, clock.now(), clock.switches, cpu, log.dumps()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--busy", type=int, default=0, help="CPU-bound processes to add meanwhile")
    args = ap.parse_args()
    burners = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(args.busy)]
    try:
        time.sleep(1 if burners else 0)
        print(f"load average before: {os.getloadavg()[0]:.2f}; {args.busy} busy process(es)")
        print("| program | latency | wall s (min-max) | simulated s | baton passes | brick CPU s | same log |")
        print("|---|---|---|---|---|---|---|")
        for latency in (False, True):
            for compiled in (False, True):
                results = [run(latency, compiled) for _ in range(args.runs)]
                walls = [r[0] for r in results]
                print(f"| {'compiled (VM)' if compiled else 'Python model'} | {'yes' if latency else 'no'} | "
                      f"{statistics.median(walls):.2f} ({min(walls):.2f}-{max(walls):.2f}) | {results[0][1]:.2f} | "
                      f"{results[0][2]} | {statistics.median(r[3] for r in results):.2f} | "
                      f"{'yes' if len({r[4] for r in results}) == 1 else 'NO'} |", flush=True)
        print(f"load average after: {os.getloadavg()[0]:.2f}")
    finally:
        for p in burners:
            p.kill()
        for p in burners:
            p.wait()


if __name__ == "__main__":
    main()
