"""Benchmark the payload task's refinement: position nogoods against the paper's form, side by side.

For each scene (the shipped task, the island, the raised wall) and each algorithm (position
nogoods with the default pre-check, which is what `cplus plan` does; the paper's form, which
forbids the executed actions where the bodies are, one violation per plan, the previous
default), in the same process: iterations, nogoods learned, the status, the solver's size at
the last horizon, and the time of the refinement (its solving part apart), as medians of
several runs. Then the whole `cplus plan domains/payload/payload.cp` command, in a fresh
process each time, with where its time goes: start-up (the interpreter and the imports),
loading the scene and the domain, grounding, refinement, printing (processor time, which a
loaded machine disturbs less than wall time).

The paper's figures, for comparison: CCALC grounded in 48.5 s and solved 9 iterations in 6.8 s
(1.66 GHz Celeron), with 12,491 variables and 271,782 clauses at the final horizon.

    python bench/bench_payload.py [--runs 5] [--quick]

``--quick`` leaves out the paper's form on the raised wall (about three minutes: hundreds of
iterations before its proof).
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
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENES = {"shipped task": ROOT / "domains" / "payload" / "scene.toml",
          "island": ROOT / "domains" / "payload" / "scenes" / "island.toml",
          "raised wall": ROOT / "domains" / "payload" / "scenes" / "raised-wall.toml"}
FORMS = {"positions": "position nogoods", "actions": "paper's form"}


def refine_once(scene: Path, form: str) -> dict:
    from cplus.robot import RobotTask, refine
    task = RobotTask.load(str(DOMAIN), str(scene))
    _ = task.domain.theory
    gc.collect()
    gc.disable()
    t0, c0 = time.perf_counter(), time.process_time()
    result = refine(task, "0", nogoods=form)
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
import sys, time, json
t0 = time.process_time()
from cplus.cli import plan
from cplus.robot import RobotTask, refine
import trajectory
t1 = time.process_time()
task = RobotTask.load(sys.argv[1], sys.argv[2])
t2 = time.process_time()
theory = task.domain.theory
t3 = time.process_time()
result = refine(task, "0")
t4 = time.process_time()
from cplus.output import Display, format_result
text = format_result(Display(task.domain.program), result.no_solution_with_maxstep, [result.history], False)
t5 = time.process_time()
print(json.dumps({"imports": t1 - t0, "load": t2 - t1, "ground": t3 - t2, "refine": t4 - t3, "print": t5 - t4}))
"""


def _children_cpu() -> float:
    t = os.times()
    return t.children_user + t.children_system


def command() -> tuple[float, float, dict]:
    """The command's wall and processor time, and its phases' processor time."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    t0, c0 = time.perf_counter(), _children_cpu()
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", str(DOMAIN)], capture_output=True, text=True,
                          env=env)
    wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    c0 = _children_cpu()
    subprocess.run([sys.executable, "-c", "pass"], check=True, env=env)
    interpreter = _children_cpu() - c0
    phases = subprocess.run([sys.executable, "-c", _PHASES, str(DOMAIN), str(SCENES["shipped task"])],
                            capture_output=True, text=True, env=env, check=True)
    return wall, cpu, {"interpreter": interpreter, **json.loads(phases.stdout)}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="leave out the paper's form on the raised wall")
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
    walls, cpus, phases = zip(*(command() for _ in range(args.runs)))
    print(f"\n`cplus plan domains/payload/payload.cp`: {statistics.median(walls):.3f} s wall, "
          f"{statistics.median(cpus):.3f} s processor time (medians of {args.runs} fresh processes); "
          "processor time by phase:")
    for key, what in (("interpreter", "Python start-up alone (python -c pass)"),
                      ("imports", "imports (cplus CLI, robot, trajectory: numpy, shapely, pysat, lark)"),
                      ("load", "load: scene and domain (parse, resolve)"),
                      ("ground", "grounding"), ("refine", "refinement (templates, pre-check, loop)"),
                      ("print", "formatting the plan")):
        print(f"  {what:<70} {statistics.median(p[key] for p in phases):.3f} s")
    print(f"\nmachine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
