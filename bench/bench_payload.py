"""Benchmark the payload task's refinement: position nogoods against the paper's form, side by side.

For each scene (the shipped task, the island, the raised wall) and each algorithm (position
nogoods with the default pre-check, which is what `cplus plan` does; the paper's form, which
forbids the executed actions where the bodies are, one violation per plan, the previous
default), in the same process: iterations, nogoods learned, the status, the solver's size at
the last horizon, and the time of the refinement (its solving part apart), as medians of
several runs. Then the whole `cplus plan domains/payload/payload.cp` command, in a fresh
process each time, with where its time goes: start-up (the interpreter; the imports, numpy and
shapely apart), loading the scene and the domain, grounding, the clause templates, the
refinement (the pre-check, encoding each step, solving, checking and learning), printing
(processor time, which a loaded machine disturbs less than wall time).

Every command is measured as a user runs it, with Python's bytecode cache: the environment
variable PYTHONDONTWRITEBYTECODE, if set (some sandboxes set it), is removed for the measured
processes, since without a cache every process compiles every module again (0.1 to 0.2 s more
per command, which no user pays twice).

The paper's figures, for comparison: CCALC grounded in 48.5 s and solved 9 iterations in 6.8 s
(1.66 GHz Celeron), with 12,491 variables and 271,782 clauses at the final horizon.

    python bench/bench_payload.py [--runs 5] [--quick]

``--quick`` leaves out the paper's form on the raised wall (about three minutes: hundreds of
iterations before its proof). ``--paths K`` runs the position nogoods on each scene K more
times, each with 1..K satisfiable two-literal clauses over fresh variables added first: the
task is the same, only the solver's path through it changes, and the spread of the times
(median, lowest, highest) says how much of a difference between two versions is the
solver's luck (the island's refinement: 0.8 to 1.3 s of processor time).
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENES = {"shipped task": ROOT / "domains" / "payload" / "scene.toml",
          "island": ROOT / "domains" / "payload" / "scenes" / "island.toml",
          "raised wall": ROOT / "domains" / "payload" / "scenes" / "raised-wall.toml"}
FORMS = {"positions": "position nogoods", "actions": "paper's form"}


def refine_once(scene: Path, form: str, pad: int = 0) -> dict:
    """One refinement as `cplus plan` runs it; ``pad`` binary clauses over fresh variables
    first (satisfiable, unrelated to the task) change nothing but the solver's path."""
    from cplus.robot import RobotTask, refine
    from cplus.robot.offline.refine import DEFAULT_MAX_HORIZON, REFINE_SOLVER
    from cplus.sat.horizon import QuerySession
    task = RobotTask.load(str(DOMAIN), str(scene))
    _ = task.domain.theory
    gc.collect()
    gc.disable()
    t0, c0 = time.perf_counter(), time.process_time()
    session = None
    if pad:
        query = task.domain.query("0")
        session = QuerySession(task.domain.theory, query, REFINE_SOLVER,
                               max_horizon=None if query.hi is not None else DEFAULT_MAX_HORIZON)
        h = session.horizon
        for _ in range(pad):
            h.solver.add_clause([h.new_var(), h.new_var()])
    result = refine(task, "0", nogoods=form, session=session)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    gc.enable()
    last = result.stats[-1]
    pre = result.precheck
    return {"status": result.status.value, "length": result.history.maxstep if result.history else None,
            "iterations": len(result.iterations), "learned": result.learned,
            "precheck": (pre.points + pre.motions, pre.length_pairs) if pre else None,
            "variables": last.variables, "clauses": last.clauses, "horizon": last.maxstep,
            "wall": wall, "cpu": cpu, "solve": sum(s.solve_s for s in result.stats)}


_PHASES = r"""
import gc, os, sys, time, json
gc.disable()        # as the command does (cplus.cli.main)
cpu = time.process_time
t0 = cpu()
from cplus.cli import _one_blas_thread
_one_blas_thread(os.environ)      # as the command does (cplus.cli.run)
import numpy, shapely
t1 = cpu()
from cplus.cli import plan
from cplus.robot import RobotTask, refine
from cplus.robot.offline.refine import DEFAULT_MAX_HORIZON, REFINE_SOLVER
from cplus.sat.horizon import QuerySession
import trajectory
t2 = cpu()
task = RobotTask.load(sys.argv[1], sys.argv[2])
t3 = cpu()
theory = task.domain.theory
t4 = cpu()
query = task.domain.query("0")
session = QuerySession(theory, query, REFINE_SOLVER, DEFAULT_MAX_HORIZON if query.hi is None else None)
t5 = cpu()
wall, time.perf_counter = time.perf_counter, cpu   # the loop's own timers: processor time here
result = refine(task, "0", session=session)
time.perf_counter = wall
t6 = cpu()
from cplus.output import Display, format_result
text = format_result(Display(task.domain.program), result.no_solution_with_maxstep, [result.history], False)
t7 = cpu()
encode = sum(s.encode_s for s in result.stats)
solve = sum(s.solve_s for s in result.stats)
pre = result.precheck.seconds if result.precheck else 0.0
print(json.dumps({"numpy+shapely": t1 - t0, "imports": t2 - t1, "load": t3 - t2, "ground": t4 - t3,
                  "templates": t5 - t4, "refine": t6 - t5, "precheck": pre, "encode": encode, "solve": solve,
                  "check": max(t6 - t5 - pre - encode - solve, 0.0), "print": t7 - t6}))
"""


def _run(argv: list[str]) -> tuple[float, float, subprocess.CompletedProcess]:
    """Run a fresh process as a user would (bytecode cache on): its wall and processor time."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)   # microseconds, not os.times()'s ticks
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return wall, cpu, proc


def command() -> tuple[float, float, dict]:
    """The command's wall and processor time, and its phases' processor time."""
    _run([sys.executable, "-c", "pass"])     # the cache warm, in case this tree has none yet
    wall, cpu, proc = _run([sys.executable, "-m", "cplus", "plan", str(DOMAIN)])
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    _, interpreter, _ = _run([sys.executable, "-c", "pass"])
    _, _, phases = _run([sys.executable, "-c", _PHASES, str(DOMAIN), str(SCENES["shipped task"])])
    if phases.returncode != 0:
        raise SystemExit(phases.stderr)
    return wall, cpu, {"interpreter": interpreter, **json.loads(phases.stdout)}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="leave out the paper's form on the raised wall")
    ap.add_argument("--paths", type=int, default=0, metavar="K",
                    help="also run the position nogoods along K other solver paths per scene")
    args = ap.parse_args()
    print(f"refinement, medians of {args.runs} runs (the paper's form on the raised wall: one run)")
    print(f"  {'scene':<13} {'algorithm':<17} {'status':<13} {'len':>3} {'iter':>4} {'learned':>7} "
          f"{'pre-check':>10} {'vars':>6} {'clauses':>8} {'refine s':>8} {'cpu s':>6} {'solve s':>7}")
    for scene_name, scene in SCENES.items():
        for form, form_name in FORMS.items():
            slow = scene_name == "raised wall" and form == "actions"
            if slow and args.quick:
                continue
            runs = [refine_once(scene, form) for _ in range(1 if slow else args.runs)]
            r = runs[0]
            med = {k: statistics.median(x[k] for x in runs) for k in ("wall", "cpu", "solve")}
            pre = f"{r['precheck'][0]}+{r['precheck'][1]}" if r["precheck"] else "-"
            print(f"  {scene_name:<13} {form_name:<17} {r['status']:<13} {r['length'] or '-':>3} "
                  f"{r['iterations']:>4} {r['learned']:>7} {pre:>10} {r['variables']:>6} {r['clauses']:>8} "
                  f"{med['wall']:>8.3f} {med['cpu']:>6.3f} {med['solve']:>7.3f}", flush=True)
    print("  (pre-check: single-body motions + payload turns handed to the solver up front; refine s: wall,\n"
          "   cpu s: processor time of the refinement, solve s: the SAT solver's part of the wall time)")
    if args.paths:
        print(f"\nposition nogoods along {args.paths} other solver paths (processor time of the refinement):")
        for scene_name, scene in SCENES.items():
            runs = [refine_once(scene, "positions", pad) for pad in range(1, args.paths + 1)]
            cpus = sorted(r["cpu"] for r in runs)
            its = sorted(r["iterations"] for r in runs)
            print(f"  {scene_name:<13} {runs[0]['status']:<13} iterations {its[0]}..{its[-1]}  "
                  f"cpu median {statistics.median(cpus):.3f} s, lowest {cpus[0]:.3f}, highest {cpus[-1]:.3f}",
                  flush=True)
    walls, cpus, phases = zip(*(command() for _ in range(args.runs)))
    print(f"\n`cplus plan domains/payload/payload.cp`: {statistics.median(walls):.3f} s wall, "
          f"{statistics.median(cpus):.3f} s processor time (medians of {args.runs} fresh processes, "
          "bytecode cached); processor time by phase:")
    for key, what in (("interpreter", "Python start-up alone (python -c pass)"),
                      ("numpy+shapely", "imports: numpy and shapely (the geometry)"),
                      ("imports", "imports: the rest (cplus CLI, robot, trajectory)"),
                      ("load", "load: scene and domain (parse, resolve)"),
                      ("ground", "grounding (the collision/4 external included)"),
                      ("templates", "clause templates"),
                      ("refine", "refinement, of which:"),
                      ("precheck", "  the pre-check"),
                      ("encode", "  encoding each step and the query"),
                      ("solve", "  solving"),
                      ("check", "  checking plans and learning nogoods"),
                      ("print", "formatting the plan")):
        print(f"  {what:<70} {statistics.median(p[key] for p in phases):.3f} s")
    print(f"\nmachine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
