"""Benchmark the planner on the corpus benchmarks (ferryman, hanoi, blocks world, spacecraft,
traffic) and compare with the peer's wall times recorded in the manifest.

For each benchmark: the wall time of the whole command ``cplus plan FILE --query L`` (what the
peer's figure measures: Cplus2ASP 4 + clingo 5.8, incremental mode, on a machine of this
kind), and an in-process breakdown (load = parse + resolve, grounding, clause templates,
per-step encoding, solving), with the variables and clauses at the final horizon.  Medians
of several runs.

    python bench/bench_planner.py [--runs 5] [--only hanoi] [--skip-slow] [--solver glucose4]
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus"))
SLOW = ("ferryman-30-4",)


def in_process(path: str, label: str, solver: str) -> dict:
    from cplus.ground.theory import ground_program
    from cplus.load import load_program
    from cplus.planner import run_query
    gc.disable()   # as the command does
    t0 = time.perf_counter()
    prog = load_program(path)
    t1 = time.perf_counter()
    theory = ground_program(prog)
    t2 = time.perf_counter()
    r = run_query(theory, prog.query(label), 1, solver)
    t3 = time.perf_counter()
    gc.enable()
    gc.collect()
    return {"load": t1 - t0, "ground": t2 - t1, "templates": r.template_s,
            "encode": sum(s.encode_s for s in r.stats), "solve": sum(s.solve_s for s in r.stats),
            "total": t3 - t0, "length": r.maxstep, "vars": r.stats[-1].variables,
            "clauses": r.stats[-1].clauses}


def command_wall(path: str, label: str, solver: str) -> float:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # as installed: .pyc kept
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", path, "--query", label, "--solver", solver],
                          capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"cplus failed on {path}: {proc.stderr.strip()}")
    return wall


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", default="")
    ap.add_argument("--skip-slow", action="store_true", help=f"skip {', '.join(SLOW)}")
    ap.add_argument("--solver", default="glucose4")
    args = ap.parse_args()
    cases = [c for c in json.loads((CORPUS / "manifest.json").read_text())
             if c.get("timing") and args.only in c["id"]]
    head = (f"{'benchmark':<22} {'len':>3} {'load':>6} {'ground':>6} {'templ':>6} {'encode':>6} "
            f"{'solve':>6} {'in-proc':>7} {'command':>7} {'peer':>6} {'2x peer':>7} {'ok':>3} "
            f"{'vars':>8} {'clauses':>9}")
    print(head)
    print("-" * len(head))
    for c in cases:
        name = c["id"].split("/")[-1].split("-benchmark")[0]
        slow = any(s in c["id"] for s in SLOW)
        if args.skip_slow and slow:
            continue
        runs = 1 if slow else args.runs
        path = str(CORPUS / "domains" / c["path"])
        label = c["query_label"]
        parts = [in_process(path, label, args.solver) for _ in range(runs)]
        walls = [command_wall(path, label, args.solver) for _ in range(runs)]
        med = {k: statistics.median(p[k] for p in parts) for k in parts[0]}
        wall = statistics.median(walls)
        peer = c["timing"]["this_machine"]["cplus2asp4_incremental(default)"]["wall_s_median"]
        ok = "yes" if wall <= 2 * peer else "NO"
        if med["length"] != c["expected"]["plan_length"]:
            ok = "LEN"
        print(f"{name:<22} {int(med['length']):>3} {med['load']:>6.2f} {med['ground']:>6.2f} "
              f"{med['templates']:>6.2f} {med['encode']:>6.2f} {med['solve']:>6.2f} {med['total']:>7.2f} "
              f"{wall:>7.2f} {peer:>6.2f} {2 * peer:>7.2f} {ok:>3} {int(med['vars']):>8} {int(med['clauses']):>9}"
              + ("  (1 run)" if runs == 1 else ""))
    print(f"\nseconds, medians of {args.runs} runs; 'command' is the wall time of `cplus plan FILE --query L` "
          "(Python start-up included), 'in-proc' the same work inside one process; peer: Cplus2ASP 4 + "
          "clingo 5.8 (incremental) on a machine of this kind, from the manifest.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
