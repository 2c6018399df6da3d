"""``cplus plan`` against the peer (Cplus2ASP 4 + clingo 5) on a fresh draw of random instances.

    python bench/bench_peer.py [--count 30] [--seed S] [--runs 3] [--family blocks,car,...]
                               [--peer-bin PATH] [--no-peer] [--keep DIR] [--timeout 120]

Every run draws new instances (``bench/gen_instances.py``: blocks worlds of 15 to 40 blocks,
spacecraft, ferryman, Hanoi, a car with integer arithmetic) from a fresh seed, printed first;
``--seed`` draws the same ones again.  Instances nobody tuned either planner for: the point is
the speed on what a user writes, not on the benchmarks the planners were measured on.

For each instance both commands run as a user runs them, alternating, ``--runs`` times each:
``cplus plan FILE`` and the peer's ``cplus2asp4 FILE query=0 1 -auto`` (its default
incremental mode).  Per command the median wall time and the median processor time (user +
system of the command and everything it waited for: ``RUSAGE_CHILDREN`` deltas; on a machine
others load, the processor time is the steadier figure).  Both must print a plan of the same
length (and the shortest length, where the generator knows it); a disagreement is flagged and
makes the exit code 1.  At the end the geometric mean and the worst of the ratios cplus/peer.

**The peer** is no part of cplus and lives outside the repository.  ``--peer-bin`` (or
``$CPLUS_PEER``, or ``$CPLUS2ASP`` as ``bench/bench_planner.py`` reads it, or ``cplus2asp4`` on
``PATH``) names its ``cplus2asp4`` program; ``f2lp``, ``clingo3to4``, ``as2transition`` and
``clingo`` are looked up beside it, then on ``PATH``.  To build it::

    git clone https://github.com/azreasoners/Cplus2ASP /opt/peer/src
    sudo apt-get install -y autoconf automake libtool make g++ libboost-all-dev flex bison re2c
    bench/build_peer.sh /opt/peer/src /opt/peer       # installs /opt/peer/bin/cplus2asp4

(``build_peer.sh`` runs the upstream ``bootstrap.sh``, ``make`` and ``make install``, compiles
``f2lp``, makes a virtual environment with PyPI's ``clingo`` and installs
``bench/peer_clingo.py`` as the ``clingo`` command the tool chain calls.)  Without the peer the
script says so and stops, unless ``--no-peer`` asks for cplus's figures alone.
"""
from __future__ import annotations

import argparse
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gen_instances  # noqa: E402  (a sibling script, not a package)

PEER_HOWTO = ("the peer (Cplus2ASP 4 + clingo 5) is not installed: build it with bench/build_peer.sh "
              "(see `python bench/bench_peer.py --help`) and pass --peer-bin PATH/cplus2asp4 or set CPLUS_PEER; "
              "--no-peer runs cplus alone")
STEP = re.compile(r"^\s*(\d+):", re.M)


@dataclass
class Runs:
    walls: list[float] = field(default_factory=list)
    cpus: list[float] = field(default_factory=list)
    lengths: set[int | None] = field(default_factory=set)
    failure: str = ""

    def wall(self) -> float:
        return statistics.median(self.walls) if self.walls else math.nan

    def cpu(self) -> float:
        return statistics.median(self.cpus) if self.cpus else math.nan


def find_peer(given: str | None) -> str | None:
    """The peer's ``cplus2asp4``: the option, ``$CPLUS_PEER``, ``$CPLUS2ASP``, then ``PATH``."""
    for candidate in (given, os.environ.get("CPLUS_PEER"), os.environ.get("CPLUS2ASP")):
        if candidate:
            found = shutil.which(candidate)
            if found is None:
                print(f"bench_peer: {candidate}: no such program; {PEER_HOWTO}", file=sys.stderr)
                raise SystemExit(2)
            return found
    return shutil.which("cplus2asp4")


def peer_env(peer: str) -> dict[str, str]:
    """The environment the peer runs in: its own folder first on ``PATH`` (its tools and clingo)."""
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(peer).parent), env.get("PATH", "")])
    return env


def cplus_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # a user keeps .pyc
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    return env


def default_cplus() -> list[str]:
    """The ``cplus`` command installed beside this interpreter, as a user types it (else ``-m cplus``)."""
    script = Path(sys.executable).parent / "cplus"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "cplus"]


def timed(cmd: list[str], env: dict[str, str], cwd: str, timeout: float) -> tuple[float, float, str, int]:
    """Wall and processor seconds of one run (with every process it waited for), its output and exit code."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd, timeout=timeout)
        out, code = proc.stdout + proc.stderr, proc.returncode
    except subprocess.TimeoutExpired:
        out, code = f"timed out after {timeout:g} s", -1
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out, code


def plan_length(output: str) -> int | None:
    """The last step of the printed plan (both print ``N:  fluents`` lines), None without one."""
    steps = [int(m) for m in STEP.findall(output)]
    return max(steps) if steps else None


def run_once(into: Runs, cmd: list[str], env: dict[str, str], cwd: str, timeout: float, ok: tuple[int, ...]) -> None:
    if into.failure:
        return
    wall, cpu, out, code = timed(cmd, env, cwd, timeout)
    if code not in ok:
        into.failure = f"exit {code}: {out.strip().splitlines()[-1] if out.strip() else 'no output'}"
        return
    into.walls.append(wall)
    into.cpus.append(cpu)
    into.lengths.add(plan_length(out))


def geo(xs: list[float]) -> float:
    return math.exp(sum(map(math.log, xs)) / len(xs)) if xs else math.nan


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=30, help="instances to draw (default 30)")
    ap.add_argument("--seed", type=int, default=None, help="draw these instances again (default: a fresh seed)")
    ap.add_argument("--runs", type=int, default=3, help="runs of each command per instance (default 3)")
    ap.add_argument("--family", default=",".join(gen_instances.FAMILIES),
                    help=f"comma-separated, of {', '.join(gen_instances.FAMILIES)}")
    ap.add_argument("--peer-bin", default=None, help="the peer's cplus2asp4 (default $CPLUS_PEER, then PATH)")
    ap.add_argument("--no-peer", action="store_true", help="run cplus alone")
    ap.add_argument("--cplus", default=None,
                    help="the cplus command (default: the `cplus` beside this interpreter)")
    ap.add_argument("--keep", type=Path, default=None, help="write the instances into this folder and keep them")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per run before it counts as failed")
    args = ap.parse_args(argv)
    peer = None if args.no_peer else find_peer(args.peer_bin)
    if peer is None and not args.no_peer:
        print(f"bench_peer: {PEER_HOWTO}", file=sys.stderr)
        return 2
    seed = gen_instances.fresh_seed() if args.seed is None else args.seed
    try:
        instances = gen_instances.draw(seed, args.count, [f for f in args.family.split(",") if f])
    except ValueError as e:
        print(f"bench_peer: {e}", file=sys.stderr)
        return 2
    cplus = args.cplus.split() if args.cplus else default_cplus()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="cplus-bench-peer-"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"seed {seed} (--seed {seed} draws these again); {len(instances)} instances; {args.runs} runs each, "
          f"alternating; medians; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    print(f"cplus: {' '.join(cplus)} plan FILE; peer: {peer + ' FILE query=0 1 -auto' if peer else 'not run'}\n")
    head = (f"{'instance':<26} {'len':>7} | {'cplus wall':>10} {'cpu':>6} | {'peer wall':>9} {'cpu':>6} | "
            f"{'wall x':>6} {'cpu x':>6}")
    print(head)
    print("-" * len(head))
    wall_ratios: dict[str, float] = {}
    cpu_ratios: dict[str, float] = {}
    bad = 0
    try:
        for inst in instances:
            path = str(inst.write(folder))
            ours, theirs = Runs(), Runs()
            for _ in range(args.runs):
                run_once(ours, [*cplus, "plan", path], cplus_env(), str(folder), args.timeout, (0,))
                if peer:
                    run_once(theirs, [peer, path, "query=0", "1", "-auto"], peer_env(peer), str(folder),
                             args.timeout, (0, 10, 30))
            flags = []
            for who, r in (("cplus", ours), ("peer", theirs)):
                if r.failure:
                    flags.append(f"{who} {r.failure}")
                elif len(r.lengths) > 1:
                    flags.append(f"{who} lengths {sorted(r.lengths, key=str)} differ between runs")
            mine = next(iter(ours.lengths), None)
            other = next(iter(theirs.lengths), None) if peer else mine
            if not ours.failure and mine is None:
                flags.append("cplus printed no plan")
            if peer and not theirs.failure and other != mine:
                flags.append(f"peer length {other}")
            if inst.length is not None and mine is not None and mine != inst.length:
                flags.append(f"shortest is {inst.length}")
            if mine is not None and mine > inst.walk:
                flags.append(f"longer than the walk {inst.walk}")
            bad += bool(flags)
            shown_len = "-" if mine is None else str(mine)
            if inst.length is not None:
                shown_len += "="          # the generator searched the whole space: this is the shortest
            line = f"{inst.name:<26} {shown_len:>7} | {ours.wall():>10.3f} {ours.cpu():>6.3f} | "
            if peer and theirs.walls and ours.walls:
                wall_ratios[inst.name] = ours.wall() / theirs.wall()
                cpu_ratios[inst.name] = ours.cpu() / theirs.cpu()
                line += (f"{theirs.wall():>9.3f} {theirs.cpu():>6.3f} | {wall_ratios[inst.name]:>6.2f} "
                         f"{cpu_ratios[inst.name]:>6.2f}")
            else:
                line += f"{'-':>9} {'-':>6} | {'-':>6} {'-':>6}"
            print(line + ("  ! " + "; ".join(flags) if flags else ""), flush=True)
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)
    print()
    if cpu_ratios:
        worst_cpu = max(cpu_ratios, key=cpu_ratios.__getitem__)
        worst_wall = max(wall_ratios, key=wall_ratios.__getitem__)
        print(f"ratio cplus/peer over {len(cpu_ratios)} instances: processor time geometric mean "
              f"{geo(list(cpu_ratios.values())):.2f}, worst {cpu_ratios[worst_cpu]:.2f} ({worst_cpu}); "
              f"wall time geometric mean {geo(list(wall_ratios.values())):.2f}, worst "
              f"{wall_ratios[worst_wall]:.2f} ({worst_wall}); {sum(r <= 1 for r in cpu_ratios.values())} "
              f"at or below 1.0 in processor time")
    print("len: the plan length both printed ('=': the generator proved it the shortest); seconds, medians; "
          "x: cplus / peer")
    if bad:
        print(f"{bad} instance(s) flagged (!): a failure or a disagreement", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
