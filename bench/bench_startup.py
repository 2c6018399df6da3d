"""Start-up of the ``cplus`` command in several installs, side by side.

    python bench/bench_startup.py VENV [VENV ...] [--runs 9] [--file F] [--keep-env]

Each VENV is a virtual environment with cplus installed (``pip install .`` in one,
``pip install -e .`` in another, ...): its ``bin/cplus plan FILE`` (default: the corpus's
hanoi-8-4, the smallest benchmark, so that the figure is almost all start-up) runs in turn
with the others', run after run, and the median wall time and processor time (user + system,
``RUSAGE_CHILDREN`` deltas, which a loaded machine disturbs less) are printed per install.

The runs are made as a user's shell makes them: ``PYTHONDONTWRITEBYTECODE`` and ``PYTHONPATH``
are removed from the environment (``--keep-env`` keeps them), since without a bytecode cache
every run compiles the package again, which is most of the difference between an editable and
a regular install.  One run per install first fills the caches.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HANOI = ROOT / "tests/corpus/domains/examples/benchmarks/hanoi-8-4/hanoi-8-4-benchmark.cp"


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and processor seconds of one run of ``cmd`` (its output discarded)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {proc.returncode}): {proc.stderr.strip()[-1500:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("venvs", nargs="+", type=Path, help="virtual environments with cplus installed")
    ap.add_argument("--runs", type=int, default=9)
    ap.add_argument("--file", type=Path, default=HANOI, help="the C+ file to plan (default: hanoi-8-4)")
    ap.add_argument("--keep-env", action="store_true", help="keep PYTHONDONTWRITEBYTECODE and PYTHONPATH")
    args = ap.parse_args(argv)
    env = dict(os.environ)
    if not args.keep_env:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env.pop("PYTHONPATH", None)
    cmds = {}
    for venv in args.venvs:
        exe = venv / "bin" / "cplus"
        if not exe.is_file():
            print(f"bench_startup: {exe} not found: install cplus into {venv} first", file=sys.stderr)
            return 2
        cmds[str(venv)] = [str(exe), "plan", str(args.file)]
    bare = [sys.executable, "-c", "pass"]
    for cmd in cmds.values():
        timed(cmd, env)                      # bytecode and grammar caches filled, as a user runs it
    walls: dict[str, list[float]] = {k: [] for k in [*cmds, "python -c pass"]}
    cpus: dict[str, list[float]] = {k: [] for k in walls}
    for _ in range(args.runs):
        for name, cmd in [*cmds.items(), ("python -c pass", bare)]:
            w, c = timed(cmd, env)
            walls[name].append(w)
            cpus[name].append(c)
    print(f"cplus plan {args.file.name}: medians of {args.runs} runs, alternating; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    width = max(map(len, walls))
    print(f"{'install':<{width}}  {'wall s':>7}  {'cpu s':>6}")
    for name in walls:
        print(f"{name:<{width}}  {statistics.median(walls[name]):>7.3f}  {statistics.median(cpus[name]):>6.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
