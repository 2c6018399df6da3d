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

**plasp + clingo** (planners ``plasp-seq`` and ``plasp-par``) is no part of cplus and lives
outside the repository: ``plasp translate DOMAIN PROBLEM`` writes the instance as ASP facts and
clingo 5 solves them with plasp's own STRIPS encodings (``encodings/strips/``: ``incmode.lp``,
``preprocess.lp``, ``strips-incremental.lp``) in clingo's incremental mode, the way plasp's
``encodings/strips/README.md`` runs them: horizon 0, 1, 2, ... until the first plan, each step
one action at least.  ``plasp-seq`` is that encoding's sequential variant (one action a step),
``plasp-par`` its ``-c _parallel=1``, forall-step parallel actions (any order of a step's
actions has the same result), the semantics of ``cplus plan``'s default.  The plan is read from
clingo's ``occurs(action(...),T)`` atoms, each step's actions in name order, and validated in the
worker by unified-planning's validator like the others.  ``--plasp DIR`` (or ``$CPLUS_PLASP``)
names the installation: ``DIR/bin/plasp`` (or a source tree's ``build/release/bin/plasp``),
``DIR/encodings/strips/``, and clingo: ``DIR/bin/clingo``, else ``DIR/venv``'s interpreter with
PyPI's ``clingo`` module (clingo's own main loop, which the incremental mode needs), else
``clingo`` on ``PATH``.  To build it::

    git clone --recursive https://github.com/potassco/plasp /opt/plasp/src
    sudo apt-get install -y cmake g++ python3-venv
    bench/build_plasp.sh /opt/plasp/src /opt/plasp      # /opt/plasp/bin/plasp, encodings, venv
    python bench/bench_ipc.py --plasp /opt/plasp --planners cplus,plasp-par,fd FOLDER ...

Without it the bench says so in one line and runs the other planners.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLANNERS = ("cplus", "cplus-seq", "fd", "fd-opt", "plasp-seq", "plasp-par")
PLASP_ENCODINGS = ("incmode.lp", "preprocess.lp", "strips-incremental.lp")
# clingo's own main loop (incremental mode included) from PyPI's module, which installs no program
CLINGO_MAIN = ("import sys\nfrom clingo.application import Application, clingo_main\n"
               "class Clingo(Application):\n    program_name = 'clingo'\n"
               "sys.exit(clingo_main(Clingo(), sys.argv[1:]))\n")


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


def find_plasp(given: str | None) -> tuple[dict | None, str]:
    """plasp's program, encodings and clingo command under ``given`` (or ``$CPLUS_PLASP``):
    (the installation, "") or (None, why not)."""
    root = given or os.environ.get("CPLUS_PLASP")
    if not root:
        return None, "no --plasp DIR and no $CPLUS_PLASP"
    top = Path(root).expanduser()
    plasp = next((p for p in (top / "bin" / "plasp", top / "build" / "release" / "bin" / "plasp", top / "plasp")
                  if p.is_file() and os.access(p, os.X_OK)), None)
    if plasp is None:
        return None, f"no plasp program in {top}/bin"
    encodings = top / "encodings" / "strips"
    missing = [e for e in PLASP_ENCODINGS if not (encodings / e).is_file()]
    if missing:
        return None, f"no {encodings / missing[0]}"
    if (top / "bin" / "clingo").is_file():
        clingo = [str(top / "bin" / "clingo")]
    elif (top / "venv" / "bin" / "python").is_file():
        clingo = [str(top / "venv" / "bin" / "python"), "-c", CLINGO_MAIN]
    elif shutil.which("clingo"):
        clingo = [shutil.which("clingo")]
    else:
        return None, f"no clingo: neither {top}/bin/clingo, {top}/venv (PyPI's clingo) nor clingo on PATH"
    return {"dir": str(top), "plasp": str(plasp), "encodings": [str(encodings / e) for e in PLASP_ENCODINGS],
            "clingo": clingo}, ""


OCCURS = re.compile(r'occurs\(action\((.*)\),(\d+)\)$')


def plasp_steps(atoms: list[str]) -> list[list[tuple[str, ...]]]:
    """The steps of clingo's ``occurs(action(("name",constant("a"),...)),T)`` atoms (an action
    without parameters is ``action("name")``): for each step 1, 2, ... its actions as (name,
    argument, ...) tuples in name order."""
    by_step: dict[int, list[tuple[str, ...]]] = {}
    for atom in atoms:
        match = OCCURS.match(atom)
        if match is None:
            continue
        names = tuple(re.findall(r'"((?:[^"\\]|\\.)*)"', match.group(1)))
        by_step.setdefault(int(match.group(2)), []).append(names)
    return [sorted(by_step[t]) for t in sorted(by_step)]


def run_plasp(planner: str, domain: str, problem: str) -> dict:
    """plasp translate + clingo on one instance; the row's fields, the plan validated here."""
    found, why = find_plasp(None)
    if found is None:
        return {"status": "error", "reason": why}
    facts = subprocess.run([found["plasp"], "translate", domain, problem], capture_output=True, text=True)
    if facts.returncode != 0:
        return {"status": "error", "reason": "plasp: " + ((facts.stderr.strip().splitlines() or ["?"])[0])}
    argv = [*found["clingo"], "-", *found["encodings"], "--outf=2", "--warn=none"]
    if planner == "plasp-par":
        argv += ["-c", "_parallel=1"]
    done = subprocess.run(argv, input=facts.stdout, capture_output=True, text=True)
    try:
        doc = json.loads(done.stdout)
    except ValueError:
        return {"status": "error", "reason": "clingo: " + ((done.stderr.strip().splitlines() or ["?"])[-1])}
    if doc.get("Result") != "SATISFIABLE":
        return {"status": {"UNSATISFIABLE": "no_plan"}.get(doc.get("Result"), str(doc.get("Result")).lower())}
    atoms = doc["Call"][-1]["Witnesses"][-1]["Value"]
    steps = plasp_steps(atoms)
    task = read_task(domain, problem)
    try:
        plan = plasp_plan(task, steps)
    except KeyError as e:
        return {"status": "error", "reason": e.args[0]}
    if not valid(task, plan):
        return {"status": "invalid plan"}
    return {"status": "solved", "actions": len(plan.actions), "steps": len(steps)}


def read_task(domain: str, problem: str):
    """The instance as unified-planning's reader gives it, read as cplus reads it (a name used
    twice allowed: IPC 2000's freecell has a type and a predicate ``suit``), its engines quiet."""
    import unified_planning.shortcuts as up
    from unified_planning.io import PDDLReader
    env = up.get_environment()
    env.credits_stream = None
    env.error_used_name = False
    return PDDLReader().parse_problem(domain, problem)


def valid(task, plan) -> bool:
    """Whether unified-planning's validator accepts ``plan`` for ``task``."""
    from unified_planning.engines import SequentialPlanValidator, ValidationResultStatus
    with SequentialPlanValidator() as validator:
        return validator.validate(task, plan).status is ValidationResultStatus.VALID


def plasp_plan(task, steps: list[list[tuple[str, ...]]]):
    """The steps linearized as a unified-planning ``SequentialPlan`` of ``task`` (plasp writes
    names in lower case; a name the problem does not have is a KeyError)."""
    import unified_planning.shortcuts as up
    from unified_planning.plans import ActionInstance, SequentialPlan
    actions = {a.name.lower(): a for a in task.actions}
    objects = {o.name.lower(): o for o in task.all_objects}
    plan = []
    for step in steps:
        for name, *args in step:
            if name.lower() not in actions or any(a.lower() not in objects for a in args):
                raise KeyError(f"plasp's action ({' '.join([name, *args])}) is not the problem's")
            plan.append(ActionInstance(actions[name.lower()], tuple(up.ObjectExp(objects[a.lower()]) for a in args)))
    return SequentialPlan(plan)


def worker(planner: str, domain: str, problem: str) -> dict:
    """Run one planner on one instance in this process; the row's fields."""
    if planner.startswith("plasp"):
        return run_plasp(planner, domain, problem)
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
    task = read_task(domain, problem)
    name = {"fd": "fast-downward", "fd-opt": "fast-downward-opt"}[planner]
    with up.OneshotPlanner(name=name) as engine:
        result = engine.solve(task)
    if result.plan is None:
        return {"status": result.status.name.lower()}
    if not valid(task, result.plan):
        return {"status": "invalid plan"}
    return {"status": "solved", "actions": len(result.plan.actions)}


def run_one(planner: str, domain: Path, problem: Path, limit: float) -> dict:
    t0 = time.perf_counter()
    # a session of its own: at the limit the worker and what it started (cplus, clingo, Fast
    # Downward) are ended together, so no run goes on loading the machine under the next one
    child = subprocess.Popen([sys.executable, __file__, "--worker", planner, str(domain), str(problem)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        stdout, stderr = child.communicate(timeout=limit)
    except subprocess.TimeoutExpired:
        os.killpg(child.pid, signal.SIGKILL)
        child.communicate()
        return {"status": "timeout", "seconds": limit}
    seconds = time.perf_counter() - t0
    done = subprocess.CompletedProcess(child.args, child.returncode, stdout, stderr)
    try:
        row = json.loads(done.stdout.strip().splitlines()[-1])
    except (IndexError, ValueError):
        row = {"status": "error", "reason": (done.stderr.strip().splitlines() or ["?"])[-1]}
    row["seconds"] = round(seconds, 3)
    return row


def table(rows: list[dict], planners: list[str]) -> str:
    """The summary by domain, in Markdown: per planner the instances solved and the median time
    to the first plan over them; the parallel steps of cplus and plasp-par where both solved."""
    domains = list(dict.fromkeys(r["instance"].split("/")[0] for r in rows))
    steps = "cplus" in planners and "plasp-par" in planners
    head = ["domain", "n", *planners] + (["steps cplus : plasp-par"] if steps else [])
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for domain in domains:
        mine = [r for r in rows if r["instance"].split("/")[0] == domain]
        n = len({r["instance"] for r in mine})
        cells = [domain, str(n)]
        for planner in planners:
            solved = sorted(r["seconds"] for r in mine if r["planner"] == planner and r["status"] == "solved")
            invalid = sum(r["planner"] == planner and r["status"] == "invalid plan" for r in mine)
            cell = f"{len(solved)}" + (f" ({solved[(len(solved) - 1) // 2]:.1f} s)" if solved else "")
            cells.append(cell + (f", {invalid} invalid" if invalid else ""))
        if steps:
            by = {(r["instance"], r["planner"]): r for r in mine}
            both = [i for i in dict.fromkeys(r["instance"] for r in mine)
                    if by.get((i, "cplus"), {}).get("status") == "solved" == by.get((i, "plasp-par"), {}).get("status")]
            ours = sum(by[(i, "cplus")]["steps"] for i in both)
            theirs = sum(by[(i, "plasp-par")]["steps"] for i in both)
            cells.append(f"{ours} : {theirs} ({len(both)})" if both else "-")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="*", type=Path, help="IPC domain folders")
    ap.add_argument("--pair", nargs=2, action="append", default=[], metavar=("DOMAIN", "PROBLEM"))
    ap.add_argument("--planners", default="cplus,cplus-seq,fd,plasp-seq,plasp-par",
                    help=f"comma-separated, of {', '.join(PLANNERS)}")
    ap.add_argument("--plasp", metavar="DIR", help="plasp + clingo's installation (default $CPLUS_PLASP)")
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
    if any(p.startswith("plasp") for p in planners):
        found, why = find_plasp(args.plasp)
        if found is None:
            print(f"% plasp + clingo not found ({why}): plasp-seq and plasp-par are not run; "
                  "build it with bench/build_plasp.sh and pass --plasp DIR (see --help)")
            planners = [p for p in planners if not p.startswith("plasp")]
        else:
            os.environ["CPLUS_PLASP"] = found["dir"]      # the workers' environment
    pairs = [(Path(d), Path(p)) for d, p in args.pair]
    for folder in args.folders:
        pairs += instances(folder)[:args.max_instances]
    if not pairs:
        ap.error("no instances: give domain folders or --pair DOMAIN PROBLEM")
    print(f"% load average {os.getloadavg()[0]:.2f}; {len(pairs)} instances; limit {args.time_limit:g} s")
    rows = []
    loads = []
    for domain, problem in pairs:
        label = f"{problem.parent.parent.name if problem.parent.name == 'instances' else problem.parent.name}/{problem.stem}"
        for planner in planners:
            loads.append(os.getloadavg()[0])
            row = {"instance": label, "planner": planner, **run_one(planner, domain, problem, args.time_limit)}
            rows.append(row)
            extra = "".join(f" {k}={row[k]}" for k in ("actions", "steps", "cost", "reason") if k in row)
            print(f"{label:40} {planner:10} {row['status']:20} {row['seconds']:8.2f} s{extra}", flush=True)
    if not rows:
        return 0
    print(f"% load average {os.getloadavg()[0]:.2f}; over the runs {min(loads):.2f} to {max(loads):.2f}, "
          f"mean {sum(loads) / len(loads):.2f}")
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
        if planner == "plasp-par" and "cplus" in planners:
            base = {r["instance"]: r for r in rows if r["planner"] == "cplus"}
            both = [i for i in mine if mine[i]["status"] == "solved" and base[i]["status"] == "solved"]
            fewer = sum(base[i]["steps"] < mine[i]["steps"] for i in both)
            more = sum(base[i]["steps"] > mine[i]["steps"] for i in both)
            line += (f"; parallel steps against cplus's on {len(both)} solved by both: "
                     f"{len(both) - fewer - more} equal, cplus fewer on {fewer}, more on {more}")
        print(line)
    invalid = [r for r in rows if r["status"] == "invalid plan"]
    print(f"% invalid plans: {len(invalid)}" + "".join(f"; {r['planner']} on {r['instance']}" for r in invalid))
    print()
    print(table(rows, planners))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
