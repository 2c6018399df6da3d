"""Side-by-side benchmark of ``cplus plan`` and the peer, Cplus2ASP 4 + clingo 5.

For each benchmark (the corpus benchmarks of ``tests/corpus/manifest.json``, and the larger
instances and arithmetic-heavy domains in ``bench/data/``): the wall time of the whole command
``cplus plan FILE --query L`` and of the peer's ``cplus2asp4 FILE query=L 1 -auto``
(its default incremental mode), alternating run by run, medians; their ratio; for our
command the split measured in a fresh process (import, load = parse + resolve, grounding,
clause templates, per-step encoding, solving), the plan length and the sizes at the final
horizon; and the *bare solve*: the same solver on the CNF of the final horizon alone
(what ``cplus ground --dimacs`` writes), loaded beforehand, which is the limit of what any
front end could reach.

    python bench/bench_planner.py [--runs 3] [--only NAME] [--skip-slow] [--solver glucose4]
                                  [--no-peer] [--record]
    python bench/bench_planner.py --startup [--runs 10]

``--startup`` measures the start-up floor instead: the processor time (user + system, which a
loaded machine disturbs less than wall time) of the whole ``cplus plan`` on the smallest
corpus benchmark, hanoi-8-4, next to a bare interpreter's (``python -c pass``), medians.

The peer runs when it is installed: ``$CPLUS2ASP`` names its ``cplus2asp4`` program, else
``cplus2asp4`` is looked up on ``PATH``; its tool chain finds ``f2lp``, ``clingo3to4`` and
``clingo`` on ``PATH``.  Without it the table compares with recorded figures (marked
``rec``): the manifest's Cplus2ASP 4 + clingo 5.8 timings for the corpus, and
``bench/data/peer_recorded.json`` (written by ``--record``) for our own instances.

Building the peer: follow the upstream project's own instructions (the README and
``INSTALL.txt`` of https://github.com/azreasoners/Cplus2ASP: its ``bootstrap.sh``, then
``make`` and ``make install``, with autoconf, automake, libtool, Boost, flex, bison and re2c
installed, and ``f2lp`` compiled from ``externals/f2lp``).  For clingo take the PyPI package
``clingo`` (5.8) in a virtual environment of its own.  Two things stand between the
tool chain and clingo 5, and the peer's ``clingo`` command must take care of both:

* the PyPI package installs no ``clingo`` program, and ``python -m clingo`` grounds the base
  program once and solves it, ignoring ``#include <incmode>``; the peer needs clingo's own
  main loop (an ``Application`` without a ``main`` method handed to
  ``clingo.application.clingo_main`` provides it), which grounds ``base`` and ``check(0)``,
  then ``step(t)`` and ``check(t)`` for t = 1, 2, ... until a model is found;
* the program the tool chain writes is still gringo-3 style in two places: an additive
  sum ``#sum{V: contrib(...,ACTION,V,...)}`` must become ``#sum{V,ACTION: ...}`` (clingo 5
  sums a *set* of tuples, so two actions contributing the same amount would count once),
  and ``#show`` lines whose patterns have unbound variables must be commented out.

The peer's translator rejects `` , `` as a conjunction, which CCALC accepts (ferryman-10-4,
hanoi-8-4): it is given a copy of those files with ``&`` instead.

Timings are noisy on a shared machine: say so when quoting them, and use several runs.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus"))
DATA = ROOT / "bench" / "data"
RECORDED = DATA / "peer_recorded.json"
SLOW = ("ferryman-30-4",)
HARD_SOLVE = 0.5      # seconds of solving at which a benchmark counts as hard (the 2x-bare target)

# Our own instances: (name, file under bench/data, query label, expected plan length)
OWN = [
    ("bw-20", "bw-20.cp", "0", 8),
    ("bw-25", "bw-25.cp", "0", 9),
    ("spacecraft-20-10", "spacecraft-20-10.cp", "0", 4),
    ("spacecraft-25-12", "spacecraft-25-12.cp", "0", 4),
    ("car-300", "car-300.cp", "0", 9),
    ("tanks-200", "tanks-200.cp", "0", 7),
]


# --------------------------------------------------------------------------- our side


def split(path: str, label: str, solver: str) -> dict:
    """Run in a fresh process: where the time goes, then the bare solve of the final CNF."""
    import gc
    t0 = time.perf_counter()
    from cplus.api import Domain
    from cplus.planner import run_query
    t1 = time.perf_counter()
    gc.disable()   # as the command does
    domain = Domain.load(path)
    t2 = time.perf_counter()
    query = domain.query(label)
    theory = domain.theory_for(query)     # as the command grounds it
    t3 = time.perf_counter()
    r = run_query(theory, query, 1, solver)
    t4 = time.perf_counter()
    out = {"import": t1 - t0, "load": t2 - t1, "ground": t3 - t2, "templates": r.template_s,
           "encode": sum(s.encode_s for s in r.stats), "solve": sum(s.solve_s for s in r.stats),
           "total": t4 - t0, "length": r.maxstep, "vars": r.stats[-1].variables if r.stats else 0,
           "clauses": r.stats[-1].clauses if r.stats else 0, "rules": theory.rule_count}
    if r.maxstep is not None:
        out["bare"] = bare_solve(theory, query, r.maxstep, solver)
    return out


def bare_solve(theory, query, maxstep: int, solver: str) -> float:
    """Seconds the solver alone takes on the CNF of the final horizon (already loaded)."""
    from cplus.sat.dimacs import horizon_cnf
    from cplus.sat.solver import SatSolver
    _, clauses, _ = horizon_cnf(theory, maxstep, query)
    s = SatSolver(solver)
    s.add_clauses(clauses)
    t0 = time.perf_counter()
    ok = s.solve()
    dt = time.perf_counter() - t0
    assert ok, "the final horizon has a plan"
    return dt


def split_in_fresh_process(path: str, label: str, solver: str) -> dict:
    code = (f"import sys, json; sys.path.insert(0, {str(ROOT / 'bench')!r}); import bench_planner; "
            f"print(json.dumps(bench_planner.split({path!r}, {label!r}, {solver!r})))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env())
    if proc.returncode != 0:
        raise SystemExit(f"cplus failed on {path}: {proc.stderr.strip()[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _env() -> dict:
    return {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # as installed: .pyc kept


def our_wall(path: str, label: str, solver: str) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "cplus", "plan", path, "--query", label, "--solver", solver],
                          capture_output=True, text=True, env=_env())
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"cplus failed on {path}: {proc.stderr.strip()}")
    return wall


# --------------------------------------------------------------------------- the peer


def find_peer() -> str | None:
    return os.environ.get("CPLUS2ASP") or shutil.which("cplus2asp4")


def peer_input(path: str, workdir: str) -> str:
    """The file as the peer can read it: `` , `` as a conjunction becomes ``&``."""
    text = Path(path).read_text()
    fixed = "\n".join(line if line.lstrip().startswith("%") else re.sub(r"\s+,\s+", " & ", line)
                      for line in text.split("\n"))
    if fixed == text:
        return path
    out = Path(workdir) / Path(path).name
    out.write_text(fixed)
    return str(out)


def peer_wall(peer: str, path: str, label: str, workdir: str) -> tuple[float, int | None]:
    """Wall time of the peer's default (incremental) mode and the plan length it printed."""
    t0 = time.perf_counter()
    proc = subprocess.run([peer, path, f"query={label}", "1", "-auto"], capture_output=True, text=True,
                          cwd=workdir, timeout=600)
    wall = time.perf_counter() - t0
    steps = [int(m.group(1)) for m in re.finditer(r"^\s*(\d+):", proc.stdout, re.M)]
    if proc.returncode not in (0, 10, 30) or not steps:
        raise SystemExit(f"the peer failed on {path}: {(proc.stderr or proc.stdout).strip()[-1500:]}")
    return wall, max(steps)


# --------------------------------------------------------------------------- the table


def cases(only: str, skip_slow: bool) -> list[dict]:
    out = []
    for c in json.loads((CORPUS / "manifest.json").read_text()):
        if not c.get("timing"):
            continue
        name = c["id"].split("/")[-1].split("-benchmark")[0]
        rec = c["timing"]["this_machine"]["cplus2asp4_incremental(default)"]["wall_s_median"]
        out.append({"name": name, "path": str(CORPUS / "domains" / c["path"]), "label": c["query_label"],
                    "length": c["expected"]["plan_length"], "recorded": rec})
    recorded = json.loads(RECORDED.read_text()) if RECORDED.is_file() else {}
    for name, file, label, length in OWN:
        out.append({"name": name, "path": str(DATA / file), "label": label, "length": length,
                    "recorded": recorded.get(name)})
    return [c for c in out if only in c["name"] and not (skip_slow and c["name"] in SLOW)]


def processor_time(cmd: list[str]) -> float:
    """User + system seconds of one run of ``cmd`` (its output discarded)."""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=_env())
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-2000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def startup(runs: int, solver: str) -> int:
    (case,) = [c for c in cases("hanoi-8-4", False) if c["name"] == "hanoi-8-4"]
    plan = [sys.executable, "-m", "cplus", "plan", case["path"], "--query", case["label"], "--solver", solver]
    processor_time(plan)                    # bytecode and parse tables cached, as a user runs it
    bare, ours = [], []
    for _ in range(runs):
        bare.append(processor_time([sys.executable, "-c", "pass"]))
        ours.append(processor_time(plan))
    print(f"processor time, medians of {runs} runs: bare interpreter {statistics.median(bare) * 1000:.1f} ms; "
          f"cplus plan hanoi-8-4 {statistics.median(ours) * 1000:.1f} ms "
          f"(min {min(ours) * 1000:.1f})")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", default="", help="benchmarks whose name contains this")
    ap.add_argument("--skip-slow", action="store_true", help=f"skip {', '.join(SLOW)}")
    ap.add_argument("--solver", default="glucose4")
    ap.add_argument("--no-peer", action="store_true", help="compare with the recorded figures only")
    ap.add_argument("--record", action="store_true", help=f"store the peer's medians for our instances in {RECORDED}")
    ap.add_argument("--startup", action="store_true",
                    help="measure the processor time of a tiny domain's whole command instead (default 10 runs)")
    args = ap.parse_args()
    if args.startup:
        return startup(args.runs if "--runs" in sys.argv else 10, args.solver)
    peer = None if args.no_peer else find_peer()
    print(f"peer: {peer or 'not installed: recorded figures (rec)'}; solver {args.solver}; "
          f"medians of {args.runs} runs, ours and the peer's alternating\n")
    head = (f"{'benchmark':<18} {'len':>3} {'ours':>6} {'peer':>6} {'':3} {'ratio':>5} | {'import':>6} {'load':>5} "
            f"{'ground':>6} {'templ':>5} {'encode':>6} {'solve':>5} | {'bare':>5} {'/bare':>5} | "
            f"{'vars':>7} {'clauses':>8}")
    print(head)
    print("-" * len(head))
    ratios = []
    recorded_now = json.loads(RECORDED.read_text()) if RECORDED.is_file() else {}
    hard = []
    with tempfile.TemporaryDirectory() as work:
        for c in cases(args.only, args.skip_slow):
            runs = 1 if c["name"] in SLOW else args.runs
            parts = [split_in_fresh_process(c["path"], c["label"], args.solver) for _ in range(runs)]
            walls, peers = [], []
            peer_path = peer_input(c["path"], work) if peer else None
            peer_len = None
            for _ in range(runs):
                walls.append(our_wall(c["path"], c["label"], args.solver))
                if peer:
                    w, peer_len = peer_wall(peer, peer_path, c["label"], work)  # type: ignore[arg-type]
                    peers.append(w)
            med = {k: statistics.median(p[k] for p in parts if k in p) for k in parts[0]}
            ours = statistics.median(walls)
            if peers:
                theirs, mark = statistics.median(peers), ""
                if c["name"] in dict((n, 0) for n, *_ in OWN):
                    recorded_now[c["name"]] = round(theirs, 3)
            else:
                theirs, mark = c["recorded"], "rec"
            length = int(med["length"])
            flag = ""
            if c["length"] is not None and length != c["length"]:
                flag = f"  LENGTH {length} != {c['length']}"
            if peer_len is not None and peer_len != length:
                flag += f"  peer length {peer_len}"
            ratio = ours / theirs if theirs else float("nan")
            if theirs:
                ratios.append(ratio)
            bare = med.get("bare", float("nan"))
            if med["solve"] >= HARD_SOLVE:
                hard.append((c["name"], ours / bare if bare else float("nan")))
            shown = f"{theirs:>6.2f}" if theirs else f"{'-':>6}"
            print(f"{c['name']:<18} {length:>3} {ours:>6.2f} {shown} {mark:3} {ratio:>5.2f} | {med['import']:>6.3f} "
                  f"{med['load']:>5.2f} {med['ground']:>6.2f} {med['templates']:>5.2f} {med['encode']:>6.2f} "
                  f"{med['solve']:>5.2f} | {bare:>5.2f} {ours / bare if bare else float('nan'):>5.1f} | "
                  f"{int(med['vars']):>7} {int(med['clauses']):>8}" + flag + ("  (1 run)" if runs == 1 else ""),
                  flush=True)
    if ratios:
        geo = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
        print(f"\nratio = ours / peer (wall times of the whole commands); geometric mean {geo:.2f} over "
              f"{len(ratios)} benchmarks; {sum(r <= 1.0 for r in ratios)} at or below 1.0")
    if hard:
        shown = ", ".join(f"{n} {x:.1f}x" for n, x in hard)
        print(f"hard benchmarks (>= {HARD_SOLVE:.1f} s solving), ours / bare solve: {shown}")
    print("columns: seconds; the split is measured in a fresh process (import = our modules), "
          "'bare' = the solver alone on the final horizon's CNF")
    if args.record and peer:
        RECORDED.write_text(json.dumps(recorded_now, indent=1, sort_keys=True) + "\n")
        print(f"recorded the peer's medians in {RECORDED}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
