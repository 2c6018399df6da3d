"""``cplus plan`` sequentially against ``--jobs 2`` with each strategy, and batch throughput.

    python bench/bench_parallel.py [--runs 3] [--only NAME]      # hard instances, side by side
    python bench/bench_parallel.py --corpus [--runs 5]           # corpus benchmarks: sequential vs --jobs auto
    python bench/bench_parallel.py --batch [--jobs 100] [--no-ray]   # 100 small jobs: loop, pool, Ray
    python bench/bench_parallel.py --ceiling [--runs 5] [--only NAME] # what two cores can give at best
    python bench/bench_parallel.py --files bench/data DIR ... [--config "B on 2"]  # these C+ files instead

**Instances.**  Generated here, harder than the corpus: random blocks worlds with one move at a
time (``noconcurrency``: plans two to three times longer than with concurrent moves, and the
proofs that no shorter plan exists get hard near the shortest length), ferryman crossings with
more animals or a smaller boat than the corpus's, Hanoi with more disks.  Each is written to a
temporary folder and run as a user runs it (``cplus plan FILE``, a new process each time).
``--files`` runs C+ files instead (folders: every ``*.cp`` in them; ``bench/data``, or a draw of
``bench/gen_instances.py``), every query of each, and ``--config`` only some configurations
(the sequential one always: it is what the others are compared with).

**Side by side.**  For each instance the configurations run in turn, run after run (so a change
of the machine's load hits all of them alike): sequential, ``--jobs 2`` with strategies
``sequential``, ``A``, ``B`` (γ 0.8), and ``--jobs auto``.  Per configuration the median wall time
and the median processor time (user + system of the command and its workers:
``RUSAGE_CHILDREN`` counts every descendant that was waited for), and the speed-up of the wall
time over sequential, and "idle": the speed-up the processor times say the run would have on
two idle cores (sequential's processor time over the parallel run's longest path: the
parent's own processor time plus its busiest worker's, from ``--stats``).  For the sequential run, where its solving time went: the satisfiable
horizon against the unsatisfiable ones (from ``--stats``), which is what the parallel
strategies can win back.  Every figure is printed with the load average (1 min) measured
around its runs: on a shared machine a parallel speed-up needs a second core that nobody else
is using.

**Batch.**  ``--jobs`` small jobs (the corpus's examples and small benchmarks, repeated) run three
ways: a shell loop of ``cplus plan`` (one process at a time), ``cplus batch`` on the process
pool, and ``cplus batch --ray`` on a local Ray instance (its start-up, measured apart, is part of
the batch's wall time and is reported too).  Jobs per second and the ratio to the loop.

**Ceiling.**  The best any split of one search over two processes can do on this machine: the
same sequential command alone, then two copies of it started at once (no work shared, nothing
to wait for).  ``2 x alone / both`` is the throughput two busy cores give over one; a parallel
strategy's speed-up cannot exceed it (on a guest whose two vCPUs share a physical core, or a
memory bus that two SAT solvers saturate, it is well below 2).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "tests" / "corpus" / "domains"
CONFIGS = [("sequential", []), ("S on 2", ["--jobs", "2", "--strategy", "sequential"]),
           ("A on 2", ["--jobs", "2", "--strategy", "A"]), ("B on 2", ["--jobs", "2", "--strategy", "B"]),
           ("auto", ["--jobs", "auto"])]


# ------------------------------------------------------------------------------------- instances


def _towers(blocks: list[str], rng: random.Random) -> list[list[str]]:
    order = blocks[:]
    rng.shuffle(order)
    out: list[list[str]] = [[]]
    for b in order:
        if out[-1] and rng.random() < 0.35:
            out.append([])
        out[-1].append(b)
    return out


def blocks_world(n: int, seed: int) -> str:
    """Random initial and goal towers of n blocks, one move at a time (the corpus's laws)."""
    rng = random.Random(seed)
    names = [f"b{i}" for i in range(1, n + 1)]

    def state(towers: list[list[str]]) -> str:
        parts = []
        for tower in towers:
            below = "table"
            for b in tower:
                parts.append(f"loc({b}) = {below}")
                below = b
        return " & ".join(parts)
    start, goal = state(_towers(names, rng)), state(_towers(names, rng))
    return f"""% random blocks world: {n} blocks, seed {seed}, one move at a time (bench/bench_parallel.py)
:- sorts location >> block.
:- objects table :: location; {', '.join(names)} :: block.
:- constants loc(block) :: inertialFluent(location); move(block) :: exogenousAction;
  destination(block) :: attribute(location) of move(block).
:- variables B, B1 :: block; L :: location.
move(B) causes loc(B)=L if destination(B)=L.
nonexecutable move(B) if loc(B1)=B.
nonexecutable move(B) if destination(B)=loc(B1) & destination(B)\\=table.
nonexecutable move(B) & move(B1) if destination(B)=B1.
constraint loc(B)=loc(B1) ->> loc(B)=table where B @< B1.
noconcurrency.
:- query maxstep :: 0..200; 0: {start}; maxstep: {goal}.
"""


def _macro(path: Path, **values: int) -> str:
    text = path.read_text()
    for name, v in values.items():
        text, n = re.subn(rf"\b{name}\s*->\s*\d+", f"{name} -> {v}", text)
        assert n == 1, f"{path}: macro {name}"
    return text


def ferryman(num: int, capacity: int) -> str:
    return _macro(CORPUS / "examples/benchmarks/ferryman-10-4/ferryman-10-4-benchmark.cp", NUM=num, CAPACITY=capacity)


def hanoi(disks: int) -> str:
    text = _macro(CORPUS / "examples/benchmarks/hanoi-6-3/hanoi-6-3-benchmark.cp", NUM_DISKS=disks)
    return text.replace("maxstep:: 0..100", f"maxstep:: 0..{2 ** disks + 10}")


INSTANCES = {
    "bw-16-s4": lambda: blocks_world(16, 4),
    "bw-18-s5": lambda: blocks_world(18, 5),
    "bw-16-s1": lambda: blocks_world(16, 1),
    "ferryman-25-4": lambda: ferryman(25, 4),
    "ferryman-30-4": lambda: ferryman(30, 4),
    "hanoi-7": lambda: hanoi(7),
}


# ------------------------------------------------------------------------------------- running


def cplus_cmd() -> list[str]:
    return [sys.executable, "-m", "cplus"]


def env() -> dict:
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), e.get("PYTHONPATH")) if p)
    e.setdefault("OPENBLAS_NUM_THREADS", "1")
    return e


def timed(argv: list[str], stdin=None) -> tuple[float, float, str, int]:
    """Wall and processor time (this command and every process it waited for) of one run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(["nice", "-n", "5", *argv], capture_output=True, text=True, env=env(), stdin=stdin)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stderr, proc.returncode


def split(stderr: str) -> tuple[float, float, int]:
    """Solving time in satisfiable and unsatisfiable horizons, and the plan length, from --stats."""
    sat = unsat = 0.0
    length = -1
    for m, s, verdict in re.findall(r"% maxstep (\d+): .* solve ([\d.]+) s: (solution|no solution)", stderr):
        if verdict == "solution":
            sat += float(s)
            length = int(m)
        else:
            unsat += float(s)
    return sat, unsat, length


def critical_cpu(stderr: str, total_cpu: float) -> float:
    """Processor time on the longest path: the parent's own (the total less the workers') plus
    the busiest worker's, from ``--stats``: the wall time the run would take on idle cores."""
    per: dict[str, float] = {}
    for w, cpu in re.findall(r"% worker (\d+), maxstep \d+: .*\(processor ([\d.]+) s in all", stderr):
        per[w] = per.get(w, 0.0) + float(cpu)
    if not per:
        return total_cpu
    return total_cpu - sum(per.values()) + max(per.values())


def load() -> float:
    return os.getloadavg()[0]


def side_by_side(names: list[str], runs: int, files: list[Path] | None = None, only: list[str] | None = None) -> None:
    """The generated instances ``names``, then the C+ files ``files`` (first query), run with
    every configuration (or those named in ``only``) in turn."""
    configs = [(c, extra) for c, extra in CONFIGS if not only or c in only]
    if "sequential" not in {c for c, _ in configs}:
        configs.insert(0, CONFIGS[0])
    texts = [(name, INSTANCES[name]) for name in names] + [(f.stem, f.read_text) for f in files or []]
    folder = Path(tempfile.mkdtemp(prefix="cplus-bench-parallel-"))
    print(f"# cplus plan sequentially vs --jobs 2, {runs} runs each, medians; {os.cpu_count()} cores; "
          f"load average (1 min) per instance")
    head = "| instance | length | seq: sat / unsat solving | " + " | ".join(
        f"{c}: wall / cpu s (×)" for c, _ in configs) + " | load |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    try:
        for name, text in texts:
            path = folder / f"{name}.cp"
            path.write_text(text())
            walls: dict[str, list[float]] = {c: [] for c, _ in configs}
            cpus: dict[str, list[float]] = {c: [] for c, _ in configs}
            paths: dict[str, list[float]] = {c: [] for c, _ in configs}
            loads = []
            sat_unsat = []
            for _ in range(runs):
                for c, extra in configs:
                    loads.append(load())
                    wall, cpu, err, code = timed([*cplus_cmd(), "plan", str(path), "--stats", *extra])
                    if code not in (0, 1, 3):
                        raise SystemExit(f"{name} ({c}) failed with exit code {code}:\n{err[-2000:]}")
                    walls[c].append(wall)
                    cpus[c].append(cpu)
                    paths[c].append(critical_cpu(err, cpu))
                    if c == "sequential":
                        sat_unsat.append(split(err))
            sat = statistics.median(s for s, _, _ in sat_unsat)
            unsat = statistics.median(u for _, u, _ in sat_unsat)
            length = sat_unsat[0][2]
            seq = statistics.median(walls["sequential"])
            share = unsat / seq if seq else 0.0
            cells = []
            seq_cpu = statistics.median(cpus["sequential"])
            for c, _ in configs:
                w, p, path = statistics.median(walls[c]), statistics.median(cpus[c]), statistics.median(paths[c])
                cells.append(f"{w:.2f} / {p:.2f} ({seq / w:.2f}×; idle {seq_cpu / path:.2f}×)")
            print(f"| {name} | {length} | {sat:.2f} / {unsat:.2f} s ({share:.0%} of wall in unsat) | "
                  + " | ".join(cells) + f" | {statistics.median(loads):.1f} |", flush=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def corpus(runs: int) -> None:
    """Sequential against ``--jobs auto`` on every corpus benchmark, run after run, both with
    ``--stats`` (auto's to see whether it went parallel; the sequential run's so that both do
    the same work). Wall times, and processor times (this command and its workers), which a
    shared machine's load changes far less: the ratio to read where the load is high."""
    manifest = json.loads((ROOT / "tests/corpus/manifest.json").read_text())
    cases = [c for c in manifest if c["path"].startswith("examples/benchmarks/")]
    print(f"# corpus benchmarks: sequential vs --jobs auto, {runs} runs each (alternating), medians")
    print("| benchmark | sequential: wall / cpu | --jobs auto: wall / cpu | auto / sequential: wall, cpu | went parallel | load |")
    print("|---|---|---|---|---|---|")
    ratios = []
    for c in cases:
        path = str(CORPUS / c["path"])
        seq, auto, seq_cpu, auto_cpu, loads, went = [], [], [], [], [], False
        for _ in range(runs):
            loads.append(load())
            wall, cpu, _, _ = timed([*cplus_cmd(), "plan", path, "--query", c["query_label"], "--stats"])
            seq.append(wall)
            seq_cpu.append(cpu)
            wall, cpu, err, _ = timed([*cplus_cmd(), "plan", path, "--query", c["query_label"], "--jobs", "auto",
                                       "--stats"])
            auto.append(wall)
            auto_cpu.append(cpu)
            went = went or "% worker" in err
        s, a = statistics.median(seq), statistics.median(auto)
        sc, ac = statistics.median(seq_cpu), statistics.median(auto_cpu)
        ratios.append(ac / sc)
        print(f"| {Path(c['path']).stem} | {s:.3f} / {sc:.3f} s | {a:.3f} / {ac:.3f} s | {a / s:.3f}, {ac / sc:.3f} | "
              f"{'yes' if went else 'no'} | {statistics.median(loads):.1f} |", flush=True)
    print(f"# processor time auto / sequential: worst {max(ratios):.3f}, geometric mean "
          f"{statistics.geometric_mean(ratios):.3f}")


SMALL = ["examples/benchmarks/hanoi-8-4/hanoi-8-4-benchmark.cp", "examples/benchmarks/blocks-bench-15/bw-15-benchmark.cp",
         "examples/benchmarks/ferryman-10-4/ferryman-10-4-benchmark.cp",
         "examples/benchmarks/spacecraft-15-8/spacecraft-15-8-benchmark.cp"]


def batch(n: int, ray: bool, workers: int) -> None:
    folder = Path(tempfile.mkdtemp(prefix="cplus-bench-batch-"))
    try:
        files = []
        for k in range(n):
            src = CORPUS / SMALL[k % len(SMALL)]
            dst = folder / f"job{k:03d}.cp"
            dst.write_text(src.read_text())
            files.append(dst)
        jobs = folder / "jobs.jsonl"
        jobs.write_text("".join(json.dumps({"domain": f.name}) + "\n" for f in files))
        print(f"# {n} small jobs ({', '.join(Path(s).stem for s in SMALL)}, in turn); {workers} workers")
        print("| how | wall | jobs/s | × the loop | load |")
        print("|---|---|---|---|---|")
        script = "; ".join(f"{' '.join(cplus_cmd())} plan {f} > /dev/null" for f in files)
        ld = load()
        loop, _, _, _ = timed(["bash", "-c", script])
        print(f"| shell loop of cplus plan | {loop:.1f} s | {n / loop:.1f} | 1.00 | {ld:.1f} |", flush=True)
        ld = load()
        wall, _, err, code = timed([*cplus_cmd(), "batch", str(jobs), "--fresh", "--quiet", "--workers", str(workers)])
        assert code == 0, err
        print(f"| cplus batch (process pool) | {wall:.1f} s | {n / wall:.1f} | {loop / wall:.2f} | {ld:.1f} |",
              flush=True)
        if ray:
            ld = load()
            start = timed([sys.executable, "-c", "import ray; ray.init(num_cpus=2, include_dashboard=False, "
                           "_node_ip_address='127.0.0.1', logging_level='ERROR'); ray.shutdown()"])[0]
            wall, _, err, code = timed([*cplus_cmd(), "batch", str(jobs), "--fresh", "--quiet", "--ray",
                                        "--workers", str(workers)])
            assert code == 0, err
            print(f"| cplus batch --ray (local) | {wall:.1f} s (of which Ray's start and stop about {start:.1f} s) | "
                  f"{n / wall:.1f} | {loop / wall:.2f} | {ld:.1f} |", flush=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def ceiling(names: list[str], runs: int) -> None:
    folder = Path(tempfile.mkdtemp(prefix="cplus-bench-ceiling-"))
    print(f"# one sequential run alone vs two copies at once, {runs} runs each, medians; {os.cpu_count()} cores")
    print("| instance | alone: wall s | two at once: wall s (slower of the two) | ceiling 2 x alone / both | load |")
    print("|---|---|---|---|---|")
    try:
        for name in names:
            path = folder / f"{name}.cp"
            path.write_text(INSTANCES[name]())
            argv = [*cplus_cmd(), "plan", str(path)]
            alone, both, loads = [], [], []
            for _ in range(runs):
                loads.append(load())
                alone.append(timed(argv)[0])
                t0 = time.perf_counter()
                procs = [subprocess.Popen(["nice", "-n", "5", *argv], stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, env=env()) for _ in range(2)]
                for p in procs:
                    p.wait()
                both.append(time.perf_counter() - t0)
            a, b = statistics.median(alone), statistics.median(both)
            print(f"| {name} | {a:.2f} | {b:.2f} | {2 * a / b:.2f}x | {statistics.median(loads):.1f} |", flush=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", action="append", choices=sorted(INSTANCES))
    ap.add_argument("--corpus", action="store_true")
    ap.add_argument("--batch", action="store_true")
    ap.add_argument("--jobs", type=int, default=100, help="jobs of --batch")
    ap.add_argument("--workers", type=int, default=2, help="workers of --batch")
    ap.add_argument("--no-ray", action="store_true")
    ap.add_argument("--ceiling", action="store_true", help="one run alone vs two copies at once")
    ap.add_argument("--files", nargs="+", type=Path, default=None,
                    help="C+ files or folders of them (bench/data, gen_instances.py's output) instead of the generated instances")
    ap.add_argument("--config", action="append", choices=[c for c, _ in CONFIGS],
                    help="only these configurations (sequential is always run: it is the baseline)")
    a = ap.parse_args()
    if a.ceiling:
        ceiling(a.only or list(INSTANCES), a.runs)
    elif a.corpus:
        corpus(a.runs)
    elif a.batch:
        batch(a.jobs, not a.no_ray, a.workers)
    else:
        files = sorted(f for p in a.files for f in (p.glob("*.cp") if p.is_dir() else [p])) if a.files else None
        side_by_side(a.only or ([] if files else list(INSTANCES)), a.runs, files, a.config)


if __name__ == "__main__":
    main()
