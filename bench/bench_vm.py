"""Measure the NXT bytecode interpreter.

Each figure is the median of ``--runs`` runs (one process), wall-clock and, in
brackets, per CPU second of this process (what the machine's load does not
change much; on a quiet machine the two agree):

* instructions per second of a compute-bound NXC program (CRC-16 table
  building and integer loops, the follower program's own ``crc_init`` and
  ``crc16``), on an infinitely fast emulated CPU so that only the interpreter
  is timed: with fused blocks (the default) and one instruction at a time;
* the follower program's run relative to real time: a whole execution
  (connect, upload of 3 motors x 200 ticks, homing, run, log read) on an
  in-memory emulated brick running the compiled ``cplus_follow.rxe`` with the
  default time slice, motors and link model included: simulated milliseconds
  per wall-clock millisecond (targets: at least 30x on a quiet machine, 20x
  under load);
* the same with the Python model instead of the compiled program, for scale;
* a busy-wait (``while (CurrentTick() < t);``) on an infinitely fast brick:
  simulated milliseconds per wall-clock millisecond, and how many of the
  instructions counted were really run (the rest are skipped whole cycles).

The load average before and after is printed: on a shared machine the
wall-clock figures drop with the load, the CPU figures much less.

Usage: ``python bench/bench_vm.py [--runs 5]``. Prints a table; nothing is
asserted (speed is measured here, never in the test suite).
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from nxt_link.emulator.emulator import (  # noqa: E402
    BrickEmulator,
    EmulatorConfig,
    LinkParams,
    compiled_follower,
)
from nxt_link.emulator.firmware import Firmware, FirmwareParams  # noqa: E402
from nxt_link.emulator.memory_transport import MemoryTransport  # noqa: E402
from nxt_link.emulator.vm import compile_nxc  # noqa: E402
from nxt_link.host.brick import Brick, RetryPolicy  # noqa: E402
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams  # noqa: E402
from nxt_link.wire.clock import VirtualClock  # noqa: E402

COMPUTE = """
unsigned int tab[];
long crc_byte(long crc, long b) {
  long idx = ((crc / 256) ^ b) & 0xFF;
  return ((crc * 256) & 0xFFFF) ^ tab[idx];
}
task main() {
  long total = 0;
  for (int round = 0; round < 20; round++) {
    ArrayInit(tab, 0, 256);
    for (int i = 0; i < 256; i++) {
      long c = i * 256;
      for (int k = 0; k < 8; k++) {
        if (c & 0x8000) c = ((c * 2) ^ 0x1021) & 0xFFFF; else c = (c * 2) & 0xFFFF;
      }
      tab[i] = c;
    }
    long crc = 0xFFFF;
    for (int j = 0; j < 2000; j++) crc = crc_byte(crc, j & 0xFF);
    total += crc;
  }
  string s = NumToStr(total);
  SendMessage(0, s);
}
"""


BUSY_WAIT = """
task main() {
  while (true) {
    unsigned long t = CurrentTick() + 10;
    while (CurrentTick() < t) ;
  }
}
"""


def instructions_per_second(rxe: bytes, fused: bool = True) -> tuple[float, float, int]:
    """(instructions per wall second, per CPU second, instructions)."""
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=None, vm_fused=fused),
                  flash_files={"b.rxe": rxe})
    fw.start_program_now("b.rxe")
    program = fw.program
    t0, c0 = time.perf_counter(), time.process_time()
    while fw.program is not None:
        fw.tick()
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    n = program.vm.instructions  # type: ignore[union-attr]
    return n / dt, n / dc, n


def busy_wait(rxe: bytes, ms: int = 200) -> tuple[float, float, float]:
    """(simulated ms per wall ms, per CPU ms, share of the counted instructions run)."""
    fw = Firmware(FirmwareParams(vm_instructions_per_ms=None), flash_files={"w.rxe": rxe})
    fw.start_program_now("w.rxe")
    vm = fw.program.vm  # type: ignore[union-attr]
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(ms):
        fw.tick()
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    return ms / (dt * 1000.0), ms / (dc * 1000.0), 1.0 - vm.skipped / vm.instructions


def follower_run(files: dict[str, bytes], symbols: dict[str, str]
                 ) -> tuple[float, float, float, int]:
    """(simulated ms per wall ms, per CPU ms, simulated seconds, interpreted instructions)."""
    clock = VirtualClock()
    emu = BrickEmulator(EmulatorConfig(name="r1", link=LinkParams(stall_probability=0.0),
                                       flash_files=files, symbols=symbols))
    brick = Brick(MemoryTransport(emu, clock), name="r1",
                  policy=RetryPolicy(reply_timeout_s=0.5, retries=3, quiet_s=0.05))
    rows = tuple(tuple(int(round(a * math.sin(2 * math.pi * k / 80))) for a in (90, -60, 30))
                 for k in range(200))
    stream = SetpointStream("r1", ("A", "B", "C"), 50, rows)
    t0, c0 = time.perf_counter(), time.process_time()
    execute_streams([stream], {"r1": brick}, options=ExecutionOptions())
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    vm = emu.vm_program
    return (emu.now_ms / (wall * 1000.0), emu.now_ms / (cpu * 1000.0), emu.now_ms / 1000.0,
            vm.vm.instructions if vm else 0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "compute.nxc"
        src.write_text(COMPUTE)
        rxe = compile_nxc(src).rxe
        src = Path(tmp) / "wait.nxc"
        src.write_text(BUSY_WAIT)
        wait_rxe = compile_nxc(src).rxe
    files, symbols = compiled_follower()
    load_before = os.getloadavg()[0]
    ips = [instructions_per_second(rxe) for _ in range(args.runs)]
    plain = [instructions_per_second(rxe, fused=False) for _ in range(args.runs)]
    vm_runs = [follower_run(files, symbols) for _ in range(args.runs)]
    model_runs = [follower_run({}, {}) for _ in range(args.runs)]
    waits = [busy_wait(wait_rxe) for _ in range(args.runs)]
    load_after = os.getloadavg()[0]
    med = statistics.median

    def pair(runs: list, scale: float = 1.0, fmt: str = ".0f") -> str:
        return (f"{med(r[0] for r in runs) / scale:{fmt}} "
                f"({med(r[1] for r in runs) / scale:{fmt}} per CPU s)")

    print(f"bench_vm: median of {args.runs} runs; {os.cpu_count()} CPUs, load average "
          f"{load_before:.1f} before, {load_after:.1f} after")
    print(f"  interpreter, compute-bound NXC: {pair(ips, 1e6, '.2f')} M instructions/s "
          f"({ips[0][2]} instructions)")
    print(f"    one instruction at a time:    {pair(plain, 1e6, '.2f')} M instructions/s")
    print(f"  cplus_follow.rxe, whole execution: {pair(vm_runs)} x real time "
          f"({vm_runs[0][2]:.1f} s simulated, {vm_runs[0][3]} instructions)")
    print(f"  Python model, same execution:      {pair(model_runs)} x real time")
    print(f"  busy-wait, infinitely fast brick:  {pair(waits)} x real time, "
          f"{100 * med(r[2] for r in waits):.2f} % of the counted instructions run")
    return 0


if __name__ == "__main__":
    sys.exit(main())
