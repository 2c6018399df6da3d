"""Measure the behaviour protocol against the emulated delivery robot, on the real serial path.

The robot is an in-process :class:`PtyBrickServer` (its own thread, real time) with the
delivery world; the client is :class:`BehaviourClient` on pyserial. Figures, each the
median (and maximum) over ``--runs`` runs, with the Bluetooth latency model and without:

* EXOG poll: one ``poll_events()`` with no event (what the online loop pays per cycle);
* act overhead: wall time of ``act(TRAY_UP)`` minus the behaviour's own duration as the
  brick measured it (ACT, ACK, DONE and the polls between);
* emulator CPU: the server thread's CPU time per second of a FOLLOW (1 m of line
  following), with the compiled ``cplus_legolog.rxe`` on the bytecode interpreter and with
  its Python model.

Usage: ``python bench/bench_behaviour.py [--runs 5]``. Prints a table; nothing is asserted
(speed is measured here, never in the test suite).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nxt_link import Behaviour, BehaviourClient, Brick, delivery_world  # noqa: E402
from nxt_link.emulator.emulator import (  # noqa: E402
    BrickEmulator,
    EmulatorConfig,
    LinkParams,
    compiled_legolog,
)
from nxt_link.emulator.pty_server import PtyBrickServer  # noqa: E402
from nxt_link.wire.serial_transport import SerialTransport  # noqa: E402


def robot(latency: bool, compiled: bool) -> tuple[PtyBrickServer, BehaviourClient]:
    files, symbols = compiled_legolog() if compiled else ({}, {})
    link = LinkParams(stall_probability=0.0) if latency else LinkParams.instant()
    emu = BrickEmulator(EmulatorConfig(name="robot", world=delivery_world(seed=1), link=link,
                                       flash_files=files, symbols=symbols))
    server = PtyBrickServer(emu)
    client = BehaviourClient(Brick(SerialTransport(server.start()), name="robot"))
    client.connect()
    return server, client


def one_run(latency: bool) -> tuple[list[float], list[float]]:
    server, client = robot(latency, compiled=True)
    try:
        polls = []
        for _ in range(20):
            t = time.perf_counter()
            client.poll_events()
            polls.append(time.perf_counter() - t)
        overheads = []
        for b in (Behaviour.TRAY_UP, Behaviour.TRAY_DOWN) * 3:
            t = time.perf_counter()
            r = client.act(b)
            overheads.append(time.perf_counter() - t - r.seconds)
        return polls, overheads
    finally:
        client.close()
        server.stop()


def cpu_per_second(compiled: bool) -> float:
    server, client = robot(False, compiled)
    try:
        cpu0, t0 = server.cpu_s, time.perf_counter()
        client.act(Behaviour.FOLLOW)
        return (server.cpu_s - cpu0) / (time.perf_counter() - t0)
    finally:
        client.close()
        server.stop()


def fmt(values: list[float]) -> str:
    return f"{statistics.median(values) * 1000:6.1f} ms (max {max(values) * 1000:.1f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    print(f"{'link':<26} {'EXOG poll, no event':<28} {'act overhead':<28}")
    for latency in (True, False):
        polls: list[float] = []
        over: list[float] = []
        for _ in range(args.runs):
            p, o = one_run(latency)
            polls += p
            over += o
        name = "Bluetooth latency model" if latency else "no latency"
        print(f"{name:<26} {fmt(polls):<28} {fmt(over):<28}")
    for compiled in (True, False):
        cpu = [cpu_per_second(compiled) for _ in range(args.runs)]
        what = "compiled, interpreter" if compiled else "Python model"
        print(f"emulator CPU while following ({what}): median {statistics.median(cpu) * 100:.1f} %"
              f" of one core (max {max(cpu) * 100:.1f} %)")


if __name__ == "__main__":
    main()
