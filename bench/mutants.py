"""Mutation testing of one module against its own test files, in bounded time (cosmic-ray).

    nice -n 10 python bench/mutants.py nxt_link/wire/framing.py              # the tests pyproject.toml names
    nice -n 10 python bench/mutants.py cplus/sat/cnf.py --sample 60 --seed 1
    python bench/mutants.py cplus/sat/cnf.py --report                   # the last run's survivors again

The module's test files and the settings come from ``[tool.cosmic-ray]`` in pyproject.toml
(``tests`` maps a module or a package folder to its test files). Every mutant is applied to
the file in this work tree (the tests import it through ``PYTHONPATH``, subprocesses too) and
the test files run once per mutant, one mutant at a time (one worker), each under the
configured time limit; ``--sample N`` runs N mutants drawn with ``--seed``, so a run takes at
most about N times the slowest run of the tests. Its state (cosmic-ray's config and session,
Hypothesis's examples) lives in ``.mutants/`` (git-ignored). The module must have no
uncommitted changes: it is put back from git when the run ends, however it ends.
Prints the score (killed / (killed + survived); a timeout counts as killed, a mutant that does
not even import as incompetent) and each survivor as a diff. See docs/testing.md.
"""
from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STATE = ROOT / ".mutants"


def settings() -> dict:
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)["tool"]["cosmic-ray"]


def tests_for(module: str, table: dict[str, list[str]]) -> list[str]:
    """The test files of ``module``: its own entry, or its package folder's."""
    path = Path(module)
    for key in [str(path), *(str(p) for p in path.parents if str(p) != ".")]:
        if key in table:
            return table[key]
    raise SystemExit(f"mutants: no test files for {module} in [tool.cosmic-ray.tests] of pyproject.toml")


def toml_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(v)


def write_config(module: str, tests: list[str], cfg: dict, timeout: float, path: Path) -> None:
    command = cfg["test-command"].format(tests=" ".join(tests), timeout=int(timeout))
    lines = ["[cosmic-ray]",
             f"module-path = {toml_value(module)}",
             f"timeout = {toml_value(float(timeout))}",
             "excluded-modules = []",
             f"test-command = {toml_value(command)}",
             "[cosmic-ray.distributor]",
             'name = "local"',
             "[cosmic-ray.filters.operators-filter]",
             f"exclude-operators = {toml_value(cfg.get('exclude-operators', []))}"]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def run(*args: str) -> None:
    proc = subprocess.run(args, cwd=ROOT)
    if proc.returncode != 0:
        raise SystemExit(f"mutants: {' '.join(args)} exited with {proc.returncode}")


def sample(session: Path, n: int, seed: int) -> int:
    """Leave ``n`` pending mutants drawn with ``seed``; mark the others skipped. Returns how
    many there were."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult
    with use_db(str(session), mode=WorkDB.Mode.open) as db:
        # in source order (job ids are random), so that a seed draws the same mutants every run
        pending = [item.job_id for item in sorted(db.pending_work_items, key=lambda i: (
            str(i.mutations[0].module_path), tuple(i.mutations[0].start_pos), i.mutations[0].operator_name,
            i.mutations[0].occurrence))]
        keep = set(random.Random(seed).sample(pending, min(n, len(pending)))) if n else set(pending)
        for job in pending:
            if job not in keep:
                db.set_result(job, WorkResult(output="not sampled", worker_outcome=WorkerOutcome.SKIPPED))
        return len(pending)


def annotation_spans(path: Path) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Where the module's annotations are, if it has ``from __future__ import annotations``
    (then no annotation is ever evaluated, so a mutant inside one is equivalent)."""
    import ast
    tree = ast.parse(path.read_text(encoding="utf-8"))
    if not any(isinstance(n, ast.ImportFrom) and n.module == "__future__" and
               any(a.name == "annotations" for a in n.names) for n in tree.body):
        return []
    spans = []
    for node in ast.walk(tree):
        notes = []
        if isinstance(node, ast.arg) and node.annotation is not None:
            notes.append(node.annotation)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.returns is not None:
            notes.append(node.returns)
        elif isinstance(node, ast.AnnAssign):
            notes.append(node.annotation)
        spans += [((n.lineno, n.col_offset), (n.end_lineno, n.end_col_offset)) for n in notes]  # type: ignore[misc]
    return spans


def skip_annotations(session: Path) -> int:
    """Mark the mutants inside annotations skipped (equivalent); returns how many."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import WorkerOutcome, WorkResult
    skipped = 0
    spans: dict[str, list] = {}
    with use_db(str(session), mode=WorkDB.Mode.open) as db:
        for item in db.pending_work_items:
            m = item.mutations[0]
            where = spans.setdefault(str(m.module_path), annotation_spans(ROOT / m.module_path))
            start = tuple(m.start_pos)
            if any(lo <= start < hi for lo, hi in where):
                db.set_result(item.job_id, WorkResult(output="equivalent: inside an annotation",
                                                      worker_outcome=WorkerOutcome.SKIPPED))
                skipped += 1
    return skipped


def report(session: Path) -> tuple[int, int, int]:
    """Print every survivor as a diff and the score; returns (killed, survived, incompetent)."""
    from cosmic_ray.work_db import WorkDB, use_db
    from cosmic_ray.work_item import TestOutcome, WorkerOutcome
    killed = survived = incompetent = 0
    with use_db(str(session), mode=WorkDB.Mode.open) as db:
        for item, result in db.completed_work_items:
            if result.worker_outcome == WorkerOutcome.SKIPPED:
                continue
            if result.test_outcome == TestOutcome.INCOMPETENT or result.worker_outcome != WorkerOutcome.NORMAL:
                incompetent += 1
            elif result.test_outcome == TestOutcome.KILLED:
                killed += 1
            else:
                survived += 1
                m = item.mutations[0]
                print(f"--- survived: {m.operator_name} #{m.occurrence} at {m.module_path}:{m.start_pos[0]}")
                print(result.diff or "")
        pending = sum(1 for _ in db.pending_work_items)
    total = killed + survived
    score = f"{100 * killed / total:.0f} %" if total else "n/a"
    print(f"mutants: {killed} killed, {survived} survived, {incompetent} incompetent, {pending} not run: "
          f"score {score}")
    return killed, survived, incompetent


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("module", help="a module's path, e.g. cplus/sat/cnf.py (a package folder: all its modules)")
    p.add_argument("--tests", nargs="+", help="test files to run instead of pyproject.toml's")
    p.add_argument("--sample", type=int, default=None, help="run only N mutants (default: [tool.cosmic-ray] sample)")
    p.add_argument("--seed", type=int, default=0, help="which N (default 0)")
    p.add_argument("--timeout", type=float, default=None, help="seconds per mutant (default: pyproject.toml's)")
    p.add_argument("--report", action="store_true", help="print the last run's survivors and score again")
    args = p.parse_args(argv)
    cfg = settings()
    module = os.path.relpath(os.path.abspath(args.module), ROOT)
    slug = module.replace("/", "_").removesuffix(".py")
    STATE.mkdir(exist_ok=True)
    config, session = STATE / f"{slug}.toml", STATE / f"{slug}.sqlite"
    if args.report:
        report(session)
        return 0
    dirty = subprocess.run(["git", "status", "--porcelain", "--", module], cwd=ROOT, capture_output=True,
                           text=True).stdout.strip()
    if dirty:
        raise SystemExit(f"mutants: {module} has uncommitted changes; commit or stash them first "
                         "(the run puts the module back from git)")
    tests = args.tests or tests_for(module, cfg["tests"])
    timeout = args.timeout or float(cfg.get("timeout", 300))
    write_config(module, tests, cfg, timeout, config)
    os.environ["PYTHONPATH"] = str(ROOT)  # the tests, and what they start, import this tree
    # cosmic-ray's commands and the test command's `python` are this interpreter's (a venv not
    # activated, only named, runs them too)
    os.environ["PATH"] = os.pathsep.join([os.path.dirname(sys.executable), os.environ.get("PATH", "")])
    os.environ["HYPOTHESIS_STORAGE_DIRECTORY"] = str(STATE / "hypothesis")  # mutants' examples stay here
    try:
        run("cosmic-ray", "init", str(config), str(session), "--force")
        run("cr-filter-operators", str(session), str(config))
        run("cr-filter-pragma", str(session))
        print(f"mutants: {skip_annotations(session)} inside annotations set aside (equivalent)", flush=True)
        n = cfg.get("sample", 0) if args.sample is None else args.sample
        total = sample(session, n, args.seed)
        print(f"mutants: {module}: {total} mutants, running {min(n, total) if n else total} against "
              f"{' '.join(tests)}", flush=True)
        run("cosmic-ray", "baseline", str(config))
        run("cosmic-ray", "exec", str(config), str(session))
    finally:
        subprocess.run(["git", "checkout", "--", module], cwd=ROOT)
    killed, survived, _ = report(session)
    return 0


if __name__ == "__main__":
    sys.exit(main())
