"""Soak the NXT link: many executions of the payload trajectory over a bad radio link.

Each run executes the planned payload trajectory (9 steps, 91 ticks of 100 ms, 3 motors per
robot) on two emulated bricks that drop 20 % of the frames in each direction and damage 10 %
of them (``cplus brick --drop 0.2 --corrupt 0.1``), each brick and run with its own seed, and
checks the outcome independently of the client: every setpoint the brick stored equals the
trajectory's, and every measured row in the log equals what the brick measured.

Two ways to host the bricks:

* ``--bricks pty`` (default): each brick is a ``PtyBrickServer`` on a pseudo-terminal in this
  process (what ``cplus execute`` does without ``--brick``), the client talks to it through
  pyserial, in real time (or ``--time-scale X`` faster); about 45 s per run at 1x;
* ``--bricks memory``: the in-memory transport on a virtual clock, the same client code and the
  same emulator, a run in about a second of CPU; the "time" column is then simulated time.

Per run it prints: success (the execution completed and the bricks did not certainly start more
than a tick apart, which ``cplus execute`` would fail), whether every setpoint is exact, the
retries (commands sent again after a timeout or an untrusted reply, plus protocol messages sent
again), the reconnects, the damaged replies seen, the start skew measured from the log and the
time. Then the successes and the median time. Target: 20 of 20
succeed with every setpoint exact.

Usage: ``python bench/bench_soak.py [--runs 20] [--bricks pty|memory] [--time-scale 1]
[--drop 0.2] [--corrupt 0.1] [--disconnect-after N] [--seed 0]``. Nothing is asserted (the
test suite has deterministic tests of each kind of damage); the exit code is 0 when every run
succeeded with exact setpoints, 1 otherwise.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import nxt_link  # noqa: E402
import trajectory  # noqa: E402
from nxt_link.wire.clock import VirtualClock  # noqa: E402
from nxt_link.wire.errors import ExecutionFailed, LinkError  # noqa: E402

DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENE = ROOT / "domains" / "payload" / "scene.toml"


def payload_trajectory() -> trajectory.Trajectory:
    """Plan the payload task (with refinement) and build its trajectory, as ``cplus plan`` does."""
    from cplus.robot import RefineStatus, RobotTask, export_plan, refine

    task = RobotTask.load(str(DOMAIN), str(SCENE))
    result = refine(task, "0")
    if result.status is not RefineStatus.FOUND or result.states is None:
        raise SystemExit(f"bench_soak: the payload task was not planned: {result.reason}")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "trajectory.json")
        export_plan(task, result.states, None, domain_path=str(DOMAIN), trajectory_json=path)
        return trajectory.load_trajectory(path)


@dataclass
class Outcome:
    ok: bool
    exact: bool
    retries: int
    reconnects: int
    damaged: int
    seconds: float
    error: str = ""
    skew_ms: float | None = None


def _emulator(name: str, seed: int, args: argparse.Namespace) -> nxt_link.BrickEmulator:
    faults = nxt_link.FaultParams(drop=args.drop, corrupt=args.corrupt, seed=seed,
                                  disconnect_after=args.disconnect_after)
    return nxt_link.BrickEmulator(nxt_link.EmulatorConfig(
        name=name, faults=faults, stale_frame_ms=250.0 * args.time_scale))


def one_run(k: int, traj: trajectory.Trajectory, streams, args: argparse.Namespace) -> Outcome:
    names = [s.brick for s in streams]
    emulators = {n: _emulator(n, args.seed + 2 * k + 1 + i, args) for i, n in enumerate(names)}
    servers = []
    bricks: dict[str, nxt_link.Brick] = {}
    options = nxt_link.ExecutionOptions()
    if args.bricks == "memory":
        clock = VirtualClock()
        for n in names:
            bricks[n] = nxt_link.Brick(nxt_link.MemoryTransport(emulators[n], clock), name=n)
        now = clock.now
    else:
        options = nxt_link.ExecutionOptions(time_scale=args.time_scale)
        for n in names:
            server = nxt_link.PtyBrickServer(emulators[n], time_scale=args.time_scale)
            server.start()
            servers.append(server)
            bricks[n] = nxt_link.Brick(nxt_link.SerialTransport(server.path), name=n)
        now = time.monotonic
    start = now()
    error = ""
    try:
        log = nxt_link.execute_streams(streams, bricks, options=options)
    except ExecutionFailed as exc:
        log, error = exc.log, str(exc)  # type: ignore[assignment]
    except LinkError as exc:
        log, error = None, str(exc)
    finally:
        seconds = now() - start
        for b in bricks.values():
            b.close()
        for s in servers:
            s.stop()
    exact = all(emulators[s.brick].program.reference_rows() == list(s.rows) for s in streams)
    skew = log.start_skew() if log is not None else None
    tick_s = streams[0].tick_ms / 1000.0
    if skew is not None and skew.min > tick_s and not error:
        error = (f"the bricks started {skew.estimate * 1000:.0f} ms apart (at least "
                 f"{skew.min * 1000:.0f} ms), more than one tick")
    if log is not None and not error:
        exact = exact and all(log.brick(s.brick).measured_deg
                              == tuple(emulators[s.brick].program.measured_rows()) for s in streams)
    events: Counter[str] = Counter()
    if log is not None:
        for b in log.bricks:
            events.update(e.event for e in b.events)
    resent = sum(b.stats["attempts"] - b.stats["requests"] for b in bricks.values())
    return Outcome(not error, exact, resent + _resent_messages(log),
                   sum(b.stats["reconnects"] for b in bricks.values()),
                   sum(b.stats["damaged"] for b in bricks.values()) + events["damaged response"],
                   seconds, error, None if skew is None else skew.estimate * 1000)


def _resent_messages(log) -> int:
    """Protocol messages sent again (the session's count in its last 'log read' event)."""
    total = 0
    for b in (log.bricks if log is not None else ()):
        reads = [e for e in b.events if e.event == "log read" and "sent again" in e.detail]
        if reads:
            total += int(reads[-1].detail.split("; ", 1)[1].split()[0])
    return total


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--bricks", choices=("pty", "memory"), default="pty")
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--drop", type=float, default=0.2)
    ap.add_argument("--corrupt", type=float, default=0.1)
    ap.add_argument("--disconnect-after", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0, help="run k uses seeds seed+2k+1, seed+2k+2")
    args = ap.parse_args()
    traj = payload_trajectory()
    from cplus.robot.execution import streams_from_trajectory

    streams = streams_from_trajectory(traj, trajectory.load_scene(str(SCENE)))
    where = ("in memory (virtual clock; time = simulated seconds)" if args.bricks == "memory" else
             f"on ptys through pyserial, {args.time_scale:g}x real time")
    print(f"payload trajectory: {traj.ticks} ticks x {traj.tick_ms} ms, {len(streams)} bricks "
          f"{where}; drop {args.drop:g}, corrupt {args.corrupt:g}"
          + (f", disconnect after {args.disconnect_after} frames" if args.disconnect_after else ""),
          flush=True)
    print(f"{'run':>4} {'result':<7} {'exact':<6} {'retries':>8} {'reconnects':>10} "
          f"{'damaged':>8} {'skew ms':>8} {'time s':>8}", flush=True)
    outcomes = []
    for k in range(args.runs):
        o = one_run(k, traj, streams, args)
        outcomes.append(o)
        print(f"{k:>4} {'ok' if o.ok else 'FAILED':<7} {'yes' if o.exact else 'NO':<6} "
              f"{o.retries:>8} {o.reconnects:>10} {o.damaged:>8} "
              f"{'-' if o.skew_ms is None else format(o.skew_ms, '.0f'):>8} {o.seconds:>8.1f}"
              + (f"  {o.error}" if o.error else ""), flush=True)
    good = sum(o.ok and o.exact for o in outcomes)
    times = [o.seconds for o in outcomes]
    skews = [o.skew_ms for o in outcomes if o.skew_ms is not None]
    print(f"{good} of {len(outcomes)} succeeded with every setpoint exact (and the bricks started "
          f"within a tick: skew median {statistics.median(skews) if skews else 0:.0f} ms, max "
          f"{max(skews) if skews else 0:.0f} ms); time per run: median "
          f"{statistics.median(times):.1f} s (min {min(times):.1f}, max {max(times):.1f}); "
          f"retries median {statistics.median(o.retries for o in outcomes):.0f}; "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    return 0 if good == len(outcomes) else 1


if __name__ == "__main__":
    raise SystemExit(main())
