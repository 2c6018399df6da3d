"""Time to the proved optimum against time to the first plan (``cplus plan --minimize``).

For each instance (the corpus's cost domains, bw-cost, buying and mcp, with the queries
below, and larger blocks worlds with cost: the corpus benchmark bw-15 and bench/data's bw-20
and bw-25), in one process per run: load and ground once, then the first plan
(:func:`cplus.planner.run_query`) and the proved optimum (:func:`run_optimal`) on the same
grounding, each with its own solver (templates, horizons and solving counted in both);
medians of ``--runs`` runs and their ratio, the target being at most 3.

``--strategies`` also compares the ways of finding the optimum (docs/optimization.md):
SAT-UNSAT (``linear``, the default: a clause over the value atoms and the flat count of an
additive fluent's contributions), the same without the flat count (``no-flat``), ``binary``
search over bounds, the bound through pysat's incremental totalizer over the value's order
literals alone (``tot``), and RC2,
pysat's core-guided MaxSAT solver, given the CNF of the shortest horizon (found by the same
first-plan search, counted in its time) with one soft clause per value above the least,
weighted by the difference.

    python bench/bench_optimal.py [--runs 5] [--only NAME] [--strategies] [--solver glucose4]

Timings are noisy on a shared machine: the load average is printed with them.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
ADDITIVE = ROOT / "tests" / "corpus" / "domains" / "examples" / "cplus" / "additive"
BW15 = ROOT / "tests" / "corpus" / "domains" / "examples" / "benchmarks" / "blocks-bench-15" / "bw-15-benchmark.cp"
DATA = ROOT / "bench" / "data"

BW_COST = f""":- maxAdditive :: 12.
:- include '{ADDITIVE / "bw-cost.cp"}'.
:- objects a, b, c, d, e, f :: block.
:- query maxstep :: 0..12;
  0: cost=0 & loc(a)=table & loc(b)=a & loc(c)=b & loc(d)=table & loc(e)=d & loc(f)=e;
  maxstep: loc(c)=table & loc(b)=c & loc(a)=b & loc(f)=a & loc(e)=f & loc(d)=table.
"""

MCP = f""":- maxAdditive :: 3.
:- include '{ADDITIVE / "mcp.cp"}'.
:- query maxstep :: 3..5;
  0: num(mi,bank1)=3 & num(ca,bank1)=3 & num(mi,bank2)=0 & num(ca,bank2)=0 & [/\\V | loc(V)=bank1];
  maxstep: [/\\V | loc(V)=bank2].
"""

# name, file text or path, query label, term, over lengths
INSTANCES = [
    ("bw-cost-6", BW_COST, "0", "cost", False),
    ("bw-cost-6-over", BW_COST, "0", "cost", True),
    ("buying-1", ADDITIVE / "buying.query", "1", "has(seller,money) + has(buyer,money)", False),
    ("mcp-left", MCP, "0", "num(mi,bank1) + num(ca,bank1)", False),
    ("mcp-left-over", MCP, "0", "num(mi,bank1) + num(ca,bank1)", True),
    ("bw-15", BW15, "0", "cost", False),
    ("bw-20", DATA / "bw-20.cp", "0", "cost", False),
    ("bw-25", DATA / "bw-25.cp", "0", "cost", False),
]

STRATEGIES = [  # name, run_optimal's options (None: RC2)
    ("linear", {}),
    ("no-flat", {"flat": False}),
    ("binary", {"strategy": "binary"}),
    ("tot", {"totalizer": True, "flat": False}),
    ("rc2", None),
]


def path_of(source, tmp: Path, name: str) -> str:
    if isinstance(source, Path):
        return str(source)
    p = tmp / f"{name}.cp"
    p.write_text(source)
    return str(p)


def one_run(path: str, label: str, term: str, over: bool, solver: str, strategies: bool) -> dict:
    import gc

    from cplus.api import Domain
    from cplus.planner import run_query
    from cplus.sat.optimize import Objective, run_optimal
    gc.disable()
    t0 = time.perf_counter()
    domain = Domain.load(path)
    query = domain.query(label)
    theory = domain.theory_for(query)
    obj = Objective.parse(term, domain.program.signature)
    out: dict = {"ground": time.perf_counter() - t0}
    if query.hi is None or query.hi - query.lo < 30:
        run_query(theory, query, 1, solver)            # warm up: lazy imports, first-call costs
    t1 = time.perf_counter()
    first = run_query(theory, query, 1, solver)
    out["first"] = time.perf_counter() - t1
    out["first_cost"] = obj.value(first.histories[0])
    out["length"] = first.maxstep
    for key, options in (STRATEGIES if strategies else STRATEGIES[:1]):
        if options is None and over:          # RC2 sees one horizon: not the same question
            out[key], out[key + "_value"] = float("nan"), -1
            continue
        t2 = time.perf_counter()
        if options is None:
            value, length = rc2_optimum(theory, query, obj, solver)
        else:
            r = run_optimal(theory, query, obj, 1, solver, over_lengths=over, **options)
            assert r.optimum is not None and r.optimum.proved
            value, length = r.optimum.value, r.maxstep
        out[key] = time.perf_counter() - t2
        out[key + "_value"] = value
        out["optimal_length"] = length
    gc.enable()
    return out


def rc2_optimum(theory, query, obj, solver: str) -> tuple[int, int]:
    """RC2 on the shortest horizon's CNF (found by the first-plan search, timed with it)."""
    from pysat.examples.rc2 import RC2
    from pysat.formula import WCNF

    from cplus.planner import run_query
    from cplus.sat.dimacs import ClauseCollector
    from cplus.sat.horizon import QuerySession
    m = run_query(theory, query, 1, solver).maxstep
    session = QuerySession(theory, query, solver_factory=ClauseCollector)
    session.horizon.extend_to(m, query.loc)
    session.assert_items(m)
    h = session.horizon
    wcnf = WCNF()
    for c in h.solver.clauses:
        wcnf.append(c)
    low = 0
    for gc in obj.constants:
        pairs = sorted((int(v), h.var(aid, m)) for aid, v in session.atoms.head_lits(gc))
        low += pairs[0][0]
        for v, x in pairs[1:]:
            wcnf.append([-x], weight=v - pairs[0][0])
    with RC2(wcnf, solver={"glucose4": "g4", "minisat22": "m22", "cadical195": "cd19"}.get(solver, "g4")) as rc2:
        assert rc2.compute() is not None
        return low + rc2.cost, m


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", default=None)
    ap.add_argument("--strategies", action="store_true", help="also compare the search strategies and RC2")
    ap.add_argument("--solver", default="glucose4")
    args = ap.parse_args()
    print(f"# load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} on {os.cpu_count()} cores; "
          f"medians of {args.runs} runs; seconds after grounding")
    keys = [k for k, _ in (STRATEGIES if args.strategies else STRATEGIES[:1])]
    head = f"{'instance':<16} {'len':>3} {'opt len':>7} {'first':>7} {'cost':>5} {'optimum':>8} {'value':>5} {'ratio':>6}"
    if args.strategies:
        head += "  " + "  ".join(f"{k:>14}" for k in keys[1:])
    print(head)
    with tempfile.TemporaryDirectory() as tmp:
        for name, source, label, term, over in INSTANCES:
            if args.only and args.only not in name:
                continue
            path = path_of(source, Path(tmp), name)
            runs = [one_run(path, label, term, over, args.solver, args.strategies) for _ in range(args.runs)]
            med = {k: statistics.median(r[k] for r in runs) for k in runs[0]
                   if not k.endswith("_value") and k not in ("length", "optimal_length", "first_cost")}
            first, best = med["first"], med["linear"]
            line = (f"{name:<16} {runs[0]['length']:>3} {runs[0]['optimal_length']:>7} {first:>7.3f} "
                    f"{runs[0]['first_cost']:>5} {best:>8.3f} {runs[0]['linear_value']:>5} "
                    f"{best / first:>6.2f}")
            if args.strategies:
                line += "  " + "  ".join(f"{med[k]:>8.3f} ({runs[0][k + '_value']:>2})" for k in keys[1:])
            print(line, flush=True)


if __name__ == "__main__":
    main()
