"""``cplus plan`` with each SAT solver pysat offers, on the kept benchmarks and a fresh draw.

    python bench/bench_solvers.py [--solvers glucose4,cadical195,...] [--runs 3] [--count 30]
                                  [--seed S] [--only NAME] [--no-builtin] [--timeout 120]
                                  [--cplus CMD] [--keep DIR]

What it measures: the processor time (user + system of the command and everything it waited
for: ``RUSAGE_CHILDREN`` deltas) of the whole ``cplus plan FILE --query L --solver S``, run as
a user runs it (a fresh process, the bytecode cache kept: ``PYTHONDONTWRITEBYTECODE`` is
removed from its environment), for every solver on every instance.  Per instance the solvers
take turns, run by run, each run starting from the next solver, ``--runs`` times; the table
shows the median per solver and the last lines the geometric mean of each solver's time over
glucose4's (the default today), its worst instance, and how many instances it loses by more
than 1.5x.  The processor time is the measure because the machine is shared (the load
average is printed first and last); the median wall time is summed per solver at the end.

Instances: ``bench/data/*.cp`` (the held-out instances: bw-20, bw-25, car-300, the spacecraft
and tanks), the corpus benchmarks that ``bench/bench_planner.py`` times (those of
``tests/corpus/manifest.json`` with a timing: bw-15, ferryman-10/15/30-4, hanoi-6-3 and 8-4,
spacecraft-15-8, traffic-altmerge), then ``--count`` instances drawn by
``bench/gen_instances.py`` from a fresh seed (printed; ``--seed`` draws the same again).
``--no-builtin`` keeps the draw alone, ``--count 0`` the built-in instances alone.

Every solver must print a plan of the same length (and the known shortest, where the manifest,
``bench_planner.py`` or the generator knows it); a disagreement, a failure or a timeout is
flagged (``!``) and makes the exit code 1.  A run that takes longer than ``--timeout`` seconds
counts as the timeout (``>`` before the figure) and the solver's other runs on that instance
are skipped (they would count the same).

``cplus`` is this checkout's: ``python -m cplus`` with the checkout first on ``PYTHONPATH``;
``--cplus`` names another command (its solver names are then passed as given).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
import gen_instances  # noqa: E402  (sibling scripts, not a package)
from bench_peer import geo, plan_length, timed  # noqa: E402

CORPUS = ROOT / "tests" / "corpus"
DATA = ROOT / "bench" / "data"
BASE = "glucose4"
SOLVERS = ("glucose4", "glucose3", "cadical195", "maplechrono", "maplecm", "lingeling", "minisat22")
# bench_planner.py's lengths for bench/data (the query is label 0 in each)
DATA_LENGTHS = {"bw-20": 8, "bw-25": 9, "spacecraft-20-10": 4, "spacecraft-25-12": 4, "car-300": 9, "tanks-200": 7}


@dataclass
class Case:
    name: str
    path: str
    label: str = "0"
    length: int | None = None       # the known shortest plan, when someone knows it


@dataclass
class Runs:
    cpus: list[float] = field(default_factory=list)
    walls: list[float] = field(default_factory=list)
    lengths: set[int | None] = field(default_factory=set)
    timed_out: bool = False
    failure: str = ""

    def cpu(self) -> float:
        return statistics.median(self.cpus) if self.cpus else math.nan

    def wall(self) -> float:
        return statistics.median(self.walls) if self.walls else math.nan


def builtin_cases() -> list[Case]:
    out = [Case(p.stem, str(p), "0", DATA_LENGTHS.get(p.stem)) for p in sorted(DATA.glob("*.cp"))]
    for c in json.loads((CORPUS / "manifest.json").read_text()):
        if c.get("timing"):
            name = c["id"].split("/")[-1].split("-benchmark")[0]
            out.append(Case(name, str(CORPUS / "domains" / c["path"]), c["query_label"],
                            c["expected"]["plan_length"]))
    return out


def offered() -> set[str]:
    """The solver names the installed pysat accepts."""
    sys.path.insert(0, str(ROOT))
    from cplus.sat.solver import solver_names
    return set(solver_names())


def env_for(cplus_given: bool) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # a user keeps .pyc
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    if not cplus_given:     # this checkout's cplus, whatever the installed one points at
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    return env


def measure(case: Case, solvers: list[str], runs: int, cplus: list[str], env: dict[str, str],
            cwd: str, timeout: float) -> dict[str, Runs]:
    got = {s: Runs() for s in solvers}
    for r in range(runs):
        for s in solvers[r % len(solvers):] + solvers[:r % len(solvers)]:     # each run starts elsewhere
            into = got[s]
            if into.failure or into.timed_out:
                continue
            wall, cpu, out, code = timed([*cplus, "plan", case.path, "--query", case.label, "--solver", s],
                                         env, cwd, timeout)
            if code == -1 and out.startswith("timed out"):
                into.timed_out = True
                into.cpus[:] = [timeout] * runs            # the timeout, for every run
                into.walls[:] = [timeout] * runs
            elif code != 0:
                into.failure = f"exit {code}: {out.strip().splitlines()[-1] if out.strip() else 'no output'}"
            else:
                into.cpus.append(cpu)
                into.walls.append(wall)
                into.lengths.add(plan_length(out))
    return got


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solvers", default=",".join(SOLVERS),
                    help=f"comma-separated pysat names (default {','.join(SOLVERS)}: those the installed pysat has)")
    ap.add_argument("--runs", type=int, default=3, help="runs of each solver per instance (default 3)")
    ap.add_argument("--count", type=int, default=30, help="instances to draw (default 30; 0: none)")
    ap.add_argument("--seed", type=int, default=None, help="draw these instances again (default: a fresh seed)")
    ap.add_argument("--only", default="", help="instances whose name contains this")
    ap.add_argument("--no-builtin", action="store_true", help="the fresh draw alone")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per run; longer counts as this (default 120)")
    ap.add_argument("--cplus", default=None, help="the cplus command (default: python -m cplus of this checkout)")
    ap.add_argument("--keep", type=Path, default=None, help="write the drawn instances into this folder and keep them")
    args = ap.parse_args(argv)

    asked = [s for s in args.solvers.split(",") if s]
    have = offered() if args.cplus is None else set(asked)     # another command may know other names
    solvers = [s for s in asked if s in have]
    if BASE not in solvers:
        solvers.insert(0, BASE)
    missing = [s for s in asked if s not in have]
    seed = gen_instances.fresh_seed() if args.seed is None else args.seed
    folder = args.keep or Path(tempfile.mkdtemp(prefix="cplus-bench-solvers-"))
    folder.mkdir(parents=True, exist_ok=True)
    cases = [] if args.no_builtin else builtin_cases()
    for inst in gen_instances.draw(seed, args.count) if args.count > 0 else []:
        cases.append(Case(inst.name, str(inst.write(folder)), "0", inst.length))
    cases = [c for c in cases if args.only in c.name]
    cplus = args.cplus.split() if args.cplus else [sys.executable, "-m", "cplus"]
    env = env_for(args.cplus is not None)

    drew = f"seed {seed} (--seed {seed} draws these again); " if args.count > 0 else ""
    print(f"{drew}{len(cases)} instances; solvers {', '.join(solvers)}"
          + (f" (not in this pysat: {', '.join(missing)})" if missing else ""))
    print(f"{args.runs} runs each, solvers alternating; medians of processor time; timeout {args.timeout:g} s; "
          f"{os.cpu_count()} cores, load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}\n")
    width = {s: max(10, len(s)) for s in solvers}
    head = f"{'instance':<24} {'len':>4} | " + " ".join(f"{s:>{width[s]}}" for s in solvers)
    print(head)
    print("-" * len(head))
    ratios: dict[str, dict[str, float]] = {s: {} for s in solvers}
    walls: dict[str, float] = dict.fromkeys(solvers, 0.0)
    bad = 0
    try:
        for case in cases:
            got = measure(case, solvers, args.runs, cplus, env, str(folder), args.timeout)
            flags = []
            lengths = {s: next(iter(r.lengths)) for s, r in got.items() if len(r.lengths) == 1}
            for s, r in got.items():
                if r.failure:
                    flags.append(f"{s} {r.failure}")
                elif r.timed_out:
                    flags.append(f"{s} timed out")
                elif len(r.lengths) != 1:
                    flags.append(f"{s} lengths {sorted(r.lengths, key=str)} differ between runs")
            found = sorted(set(lengths.values()), key=str)
            if len(found) > 1:
                flags.append("lengths differ: " + ", ".join(f"{s} {n}" for s, n in lengths.items()))
            if case.length is not None and found and found != [case.length]:
                flags.append(f"shortest is {case.length}")
            bad += bool(flags)
            base = got[BASE].cpu()
            cells = []
            for s in solvers:
                r = got[s]
                w = width[s]
                cells.append(f"{'>' if r.timed_out else '':>1}{r.cpu():>{w - 1}.2f}" if r.cpus else f"{'fail':>{w}}")
                if r.cpus and not math.isnan(base):
                    ratios[s][case.name] = r.cpu() / base
                    walls[s] += r.wall()
            shown = "-" if len(found) != 1 or found[0] is None else str(found[0])
            print(f"{case.name:<24} {shown:>4} | " + " ".join(cells) + ("  ! " + "; ".join(flags) if flags else ""),
                  flush=True)
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)

    print(f"\nprocessor seconds, medians ('>': timed out, counted as {args.timeout:g} s); load average "
          f"{' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(f"\n{'solver':<12} {'geo mean x':>10} {'worst x':>8}  {'worst instance':<24} {'>1.5x':>5} {'<0.67x':>6} "
          f"{'wall sum s':>10}")
    drawn = {c.name for c in cases if c.name.rpartition('-s')[2].isdigit()}
    for s in solvers:
        rs = ratios[s]
        if not rs:
            print(f"{s:<12} {'-':>10}")
            continue
        worst = max(rs, key=rs.__getitem__)
        print(f"{s:<12} {geo(list(rs.values())):>10.2f} {rs[worst]:>8.2f}  {worst:<24} "
              f"{sum(x > 1.5 for x in rs.values()):>5} {sum(x < 1 / 1.5 for x in rs.values()):>6} {walls[s]:>10.1f}")
    if drawn and len(drawn) < len(cases):
        print("\ngeometric mean over glucose4, built-in instances / fresh draw: " + "; ".join(
            f"{s} {geo([x for n, x in ratios[s].items() if n not in drawn]):.2f} / "
            f"{geo([x for n, x in ratios[s].items() if n in drawn]):.2f}" for s in solvers if s != BASE))
    if bad:
        print(f"{bad} instance(s) flagged (!): a failure, a timeout or a disagreement", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
