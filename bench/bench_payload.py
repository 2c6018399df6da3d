"""Benchmark the payload task: loading the scene and domain, grounding, every refinement
iteration (the paper's Algorithm 1), the whole refinement, and the sizes at the final horizon.

The paper's figures, for comparison: CCALC grounded in 48.5 s and solved 9 iterations in 6.8 s
(1.66 GHz Celeron), with 12,491 variables and 271,782 clauses at the final horizon.

    python bench/bench_payload.py [--runs 5]
"""
from __future__ import annotations

import argparse
import gc
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENE = ROOT / "domains" / "payload" / "scene.toml"


def once() -> dict:
    from cplus.robot import RobotTask, refine
    gc.disable()
    t0 = time.perf_counter()
    task = RobotTask.load(str(DOMAIN), str(SCENE))
    t1 = time.perf_counter()
    theory = task.domain.theory
    t2 = time.perf_counter()
    result = refine(task, "0")
    t3 = time.perf_counter()
    gc.enable()
    last = result.session.stats[-1]
    return {"load": t1 - t0, "ground": t2 - t1, "refine": t3 - t2, "total": t3 - t0,
            "iterations": [it.seconds for it in result.iterations], "length": result.history.maxstep,
            "first_length": result.first_history.maxstep, "vars": last.variables, "clauses": last.clauses,
            "rules": theory.rule_count, "horizons": len(result.session.stats)}


def command() -> float:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", str(DOMAIN)], capture_output=True,
                          text=True, env=env)
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    runs = [once() for _ in range(args.runs)]
    walls = [command() for _ in range(args.runs)]
    med = lambda k: statistics.median(r[k] for r in runs)  # noqa: E731
    its = runs[0]["iterations"]
    print(f"payload task: first plan of length {runs[0]['first_length']}, collision-free plan of length "
          f"{runs[0]['length']} after {len(its)} iterations ({runs[0]['horizons']} horizons solved)")
    print(f"  load (scene + domain)   {med('load'):.3f} s")
    print(f"  grounding               {med('ground'):.3f} s   ({runs[0]['rules']} ground rules)")
    print(f"  whole refinement        {med('refine'):.3f} s   (plan, check, forbid, re-plan; all iterations)")
    print(f"  load to final plan      {med('total'):.3f} s")
    print(f"  `cplus plan` command    {statistics.median(walls):.3f} s wall (start-up, printing included)")
    print(f"  final horizon           {runs[0]['vars']} variables, {runs[0]['clauses']} clauses")
    per_iter = [statistics.median(r["iterations"][i] for r in runs) for i in range(len(its))]
    print("  per iteration (s)       " + " ".join(f"{t:.3f}" for t in per_iter))
    print(f"\nmedians of {args.runs} runs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
