"""IPC benchmarks side by side: ``cplus plan DOMAIN PROBLEM`` (forall-step, and ``--sequential``)
against Fast Downward through unified-planning (the ``up-fast-downward`` package's engines
``fast-downward``, LAMA's first iteration, and ``fast-downward-opt``).

The benchmark files are not in the repository: point the bench at a copy of an IPC collection
fetched outside it, a domain folder at a time, for example potassco/pddl-instances
(``git clone https://github.com/potassco/pddl-instances``)::

    pip install up-fast-downward        # the Fast Downward engines of unified-planning
    python bench/bench_ipc.py ~/pddl-instances/ipc-1998/domains/gripper-round-1-strips \\
        ~/pddl-instances/ipc-2000/domains/logistics-strips-typed --max-instances 5 --time-limit 60

A domain folder is read in the layouts of the usual collections: ``domain.pddl`` beside the
problems or an ``instances/`` folder of them (potassco), ``domains/domain-N.pddl`` for each
``instances/instance-N.pddl`` (potassco, one domain per problem), ``pNN-domain.pddl`` or
``domain_pNN.pddl`` beside ``pNN.pddl`` (Fast Downward's benchmarks).  ``--pair D P`` adds one
domain and problem.  Every run is a process of its own with a wall-clock limit (``--time-limit``)
and every plan is checked by unified-planning's validator in that process.  It prints one line
per instance and planner (status, seconds, actions, steps) and a summary (solved, and the
geometric mean of the time ratio to cplus on the instances both solved), with the load average:
timings are noisy on a shared machine.  ``--json OUT`` keeps the rows.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLANNERS = ("cplus", "cplus-seq", "fd", "fd-opt")


def _number(path: Path) -> tuple:
    return tuple(int(x) if x.isdigit() else x for x in re.split(r"(\d+)", path.name))


def instances(folder: Path) -> list[tuple[Path, Path]]:
    """(domain, problem) pairs of a domain folder, in the problems' numeric order."""
    if (folder / "instances").is_dir():
        problems = sorted((folder / "instances").glob("*.pddl"), key=_number)
    else:
        problems = sorted((p for p in folder.glob("*.pddl") if "domain" not in p.name), key=_number)
    pairs = []
    for p in problems:
        stem = p.stem
        number = re.sub(r"\D", "", stem)
        for d in (folder / "domains" / f"domain-{number}.pddl", folder / f"{stem}-domain.pddl",
                  folder / f"domain_{stem}.pddl", folder / "domain.pddl"):
            if d.is_file():
                pairs.append((d, p))
                break
        else:
            print(f"% {p}: no domain file found beside it; skipped", file=sys.stderr)
    return pairs


def worker(planner: str, domain: str, problem: str) -> dict:
    """Run one planner on one instance in this process; the row's fields."""
    if planner.startswith("cplus"):
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
        argv = [sys.executable, "-m", "cplus", "plan", domain, problem, "--json"]
        if planner == "cplus-seq":
            argv.append("--sequential")
        done = subprocess.run(argv, capture_output=True, text=True, env=env)
        if done.returncode not in (0, 1, 3, 10):
            return {"status": "error", "reason": (done.stderr.strip().splitlines() or ["?"])[0]}
        doc = json.loads(done.stdout)
        if doc["status"] != "found":
            return {"status": doc["status"]}
        return {"status": "solved", "actions": len(doc["plan"]), "steps": len(doc["steps"]), "cost": doc["cost"]}
    import unified_planning.shortcuts as up
    from unified_planning.engines import SequentialPlanValidator, ValidationResultStatus
    from unified_planning.io import PDDLReader
    up.get_environment().credits_stream = None
    task = PDDLReader().parse_problem(domain, problem)
    name = {"fd": "fast-downward", "fd-opt": "fast-downward-opt"}[planner]
    with up.OneshotPlanner(name=name) as engine:
        result = engine.solve(task)
    if result.plan is None:
        return {"status": result.status.name.lower()}
    with SequentialPlanValidator() as validator:
        if validator.validate(task, result.plan).status is not ValidationResultStatus.VALID:
            return {"status": "invalid plan"}
    return {"status": "solved", "actions": len(result.plan.actions)}


def run_one(planner: str, domain: Path, problem: Path, limit: float) -> dict:
    t0 = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, __file__, "--worker", planner, str(domain), str(problem)],
                              capture_output=True, text=True, timeout=limit)
    except subprocess.TimeoutExpired:
        return {"status": "timeout", "seconds": limit}
    seconds = time.perf_counter() - t0
    try:
        row = json.loads(done.stdout.strip().splitlines()[-1])
    except (IndexError, ValueError):
        row = {"status": "error", "reason": (done.stderr.strip().splitlines() or ["?"])[-1]}
    row["seconds"] = round(seconds, 3)
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="*", type=Path, help="IPC domain folders")
    ap.add_argument("--pair", nargs=2, action="append", default=[], metavar=("DOMAIN", "PROBLEM"))
    ap.add_argument("--planners", default="cplus,cplus-seq,fd", help=f"comma-separated, of {', '.join(PLANNERS)}")
    ap.add_argument("--max-instances", type=int, default=5, help="the first N problems of each folder")
    ap.add_argument("--time-limit", type=float, default=60.0, help="seconds per run (wall clock)")
    ap.add_argument("--json", type=Path, metavar="OUT", help="write the rows as JSON")
    ap.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(*args.worker)))
        return 0
    planners = [p for p in args.planners.split(",") if p]
    unknown = [p for p in planners if p not in PLANNERS]
    if unknown:
        ap.error(f"unknown planner {unknown[0]!r} (choose from {', '.join(PLANNERS)})")
    pairs = [(Path(d), Path(p)) for d, p in args.pair]
    for folder in args.folders:
        pairs += instances(folder)[:args.max_instances]
    if not pairs:
        ap.error("no instances: give domain folders or --pair DOMAIN PROBLEM")
    print(f"% load average {os.getloadavg()[0]:.2f}; {len(pairs)} instances; limit {args.time_limit:g} s")
    rows = []
    for domain, problem in pairs:
        label = f"{problem.parent.parent.name if problem.parent.name == 'instances' else problem.parent.name}/{problem.stem}"
        for planner in planners:
            row = {"instance": label, "planner": planner, **run_one(planner, domain, problem, args.time_limit)}
            rows.append(row)
            extra = "".join(f" {k}={row[k]}" for k in ("actions", "steps", "cost", "reason") if k in row)
            print(f"{label:40} {planner:10} {row['status']:20} {row['seconds']:8.2f} s{extra}", flush=True)
    print(f"% load average {os.getloadavg()[0]:.2f}")
    for planner in planners:
        mine = {r["instance"]: r for r in rows if r["planner"] == planner}
        solved = sum(r["status"] == "solved" for r in mine.values())
        line = f"% {planner}: {solved}/{len(mine)} solved"
        if planner != "cplus" and "cplus" in planners:
            base = {r["instance"]: r for r in rows if r["planner"] == "cplus"}
            both = [i for i in mine if mine[i]["status"] == "solved" and base[i]["status"] == "solved"]
            if both:
                ratio = math.exp(sum(math.log(mine[i]["seconds"] / base[i]["seconds"]) for i in both) / len(both))
                line += f"; time / cplus's, geometric mean over {len(both)} solved by both: {ratio:.2f}"
        print(line)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
