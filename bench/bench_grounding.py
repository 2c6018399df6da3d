"""Processor time of the planner's phases on instances outside its own tuning.

For each instance: loading (parse + resolve), grounding (what ``cplus plan`` grounds for the
query: only what its initial state can reach), the clause templates, the per-step encoding
and the solving, as processor time (``time.process_time``: the machine is shared, and wall
time there is mostly other people's work), medians over ``--runs`` runs in this process,
each from a fresh load.  The encoding and solving split is the one ``cplus plan --stats``
prints, measured here with the processor clock instead of the wall clock.

    python bench/bench_grounding.py [--runs 5] [--only NAME] [FILE.cp ...]

Instances: spacecraft-15-8, ferryman-30-4 and hanoi-8-4 of the corpus, ``bench/data``'s
car-300 and bw-20, and ``bw-20-random``: the laws of bw-20 with initial and goal towers
drawn from a fixed seed (:func:`random_blocks`), a blocks world nobody tuned for.  Files
given on the command line (a fresh draw of ``bench/gen_instances.py``, say) are measured
instead, with their first query.  ``startup`` is the processor time of ``import cplus.api``
in a fresh interpreter (median of the runs), the fixed cost every command pays first.
"""
from __future__ import annotations

import argparse
import os
import random
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CORPUS = ROOT / "tests" / "corpus" / "domains" / "examples" / "benchmarks"
DATA = ROOT / "bench" / "data"
INSTANCES = {
    "spacecraft-15-8": CORPUS / "spacecraft-15-8" / "spacecraft-15-8-benchmark.cp",
    "car-300": DATA / "car-300.cp",
    "bw-20": DATA / "bw-20.cp",
    "bw-20-random": None,
    "ferryman-30-4": CORPUS / "ferryman-etc" / "ferryman-30-4-benchmark.cp",
    "hanoi-8-4": CORPUS / "hanoi-8-4" / "hanoi-8-4-benchmark.cp",
}
PHASES = ("load", "ground", "templates", "encode", "solve", "total")


def towers(blocks: list[str], rng: random.Random) -> list[list[str]]:
    """The blocks in a random order, cut into towers of random heights."""
    order = blocks[:]
    rng.shuffle(order)
    out: list[list[str]] = []
    while order:
        k = rng.randint(1, min(6, len(order)))
        out.append(order[:k])
        order = order[k:]
    return out


def state(ts: list[list[str]]) -> list[str]:
    return [f"loc({t[i]}) = {'table' if i == 0 else t[i - 1]}" for t in ts for i in range(len(t))]


def random_blocks(seed: int = 20) -> str:
    """bw-20's laws and blocks, with initial and goal towers drawn from ``seed``."""
    text = (DATA / "bw-20.cp").read_text()
    laws = text[:text.index(":- query")]
    blocks = list("abcdefghijklmnopqrst")
    rng = random.Random(seed)
    start, goal = state(towers(blocks, rng)), state(towers(blocks, rng))
    return (laws + ":- query\nmaxstep :: 0..100;\n0: (cost = 0 & " + " & ".join(start) + ");\n"
            "maxstep: ([\\/N| cost = N & N=<maxCost] & " + " & ".join(goal) + ").\n")


def run_once(name: str) -> dict[str, float]:
    from cplus.api import Domain
    from cplus.planner import PlanStatus, run_query
    from cplus.sat import horizon
    horizon.time.perf_counter = time.process_time    # type: ignore[attr-defined]  # --stats, on the CPU clock
    path = INSTANCES[name] if name in INSTANCES else Path(name)
    t0 = time.process_time()
    domain = Domain.from_text(random_blocks()) if path is None else Domain.load(str(path))
    query = domain.query(domain.labels[0])
    t1 = time.process_time()
    theory = domain.theory_for(query)
    t2 = time.process_time()
    result = run_query(theory, query)
    t3 = time.process_time()
    assert result.status is PlanStatus.FOUND, name
    return {"load": t1 - t0, "ground": t2 - t1, "templates": result.template_s,
            "encode": sum(s.encode_s for s in result.stats), "solve": sum(s.solve_s for s in result.stats),
            "total": t3 - t0,
            "maxstep": result.maxstep, "clauses": result.stats[-1].clauses}


def startup() -> float:
    """Processor time of ``import cplus.api`` in a fresh interpreter (itself and its children)."""
    import resource
    import subprocess
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}   # as installed: .pyc kept
    subprocess.run([sys.executable, "-c", "import cplus.api"], check=True, cwd=ROOT, env=env)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", help="one instance: " + ", ".join(INSTANCES))
    ap.add_argument("files", nargs="*", help="C+ files to measure instead of the built-in instances")
    args = ap.parse_args()
    names = [args.only] if args.only else args.files or list(INSTANCES)
    for n in names:
        if n not in INSTANCES and not (n in args.files and Path(n).is_file()):
            print(f"bench_grounding: no instance '{n}' (known: {', '.join(INSTANCES)}, or a file)", file=sys.stderr)
            return 2
    print(f"startup (import cplus.api): {statistics.median(startup() for _ in range(args.runs)):.3f} CPU s")
    print(f"{'instance':16} {'len':>3} {'clauses':>8} " + " ".join(f"{p:>9}" for p in PHASES)
          + f"   (CPU s, median of {args.runs})")
    for n in names:
        runs = [run_once(n) for _ in range(args.runs)]
        med = {p: statistics.median(r[p] for r in runs) for p in PHASES}
        print(f"{Path(n).stem[:16]:16} {runs[0]['maxstep']:>3} {runs[0]['clauses']:>8} " + " ".join(f"{med[p]:9.3f}" for p in PHASES),
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
