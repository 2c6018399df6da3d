"""Timings of the trajectory package on the payload scene (median of several runs).

Run: ``python bench/bench_trajectory.py [--runs N]``. Prints a table; asserts nothing.

* scene load: parse and validate ``domains/payload/scene.toml``;
* collision, table build: the first call on a fresh scene (tabulates every pair of grid points);
* collision, grid call: one call with integer grid arguments (what the grounder does);
* collision, off-grid call: a call the table cannot answer (shapely, then the LRU cache);
* collision, off-grid cached: the same call again;
* checker per step: `all_violations` on a 9-step plan, divided by its motions;
* build_trajectory: the same plan, 10 points per step, with its check.
"""

from __future__ import annotations

import argparse
import itertools
import random
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from trajectory import StepState, all_violations, build_trajectory, load_scene  # noqa: E402

SCENE = ROOT / "domains" / "payload" / "scene.toml"
PLAN = [
    ((0, 0), (0, 5)), ((0, 0), (0, 5)), ((1, 1), (1, 6)), ((2, 2), (2, 7)), ((6, 2), (5, 7)),
    ((7, 1), (6, 6)), ((8, 0), (7, 5)), ((9, -1), (8, 4)), ((10, 0), (9, 5)), ((10, 0), (10, 5)),
]


def states() -> list[StepState]:
    return [StepState({"r1": p, "r2": q}, {"pl1": p, "pl2": q}, {"pl1": "r1", "pl2": "r2"})
            for p, q in PLAN]


def median_time(run: Callable[[], int], runs: int) -> float:
    """Median over ``runs`` of (elapsed seconds / operations reported by ``run``)."""
    samples = []
    for _ in range(runs):
        start = time.perf_counter()
        n = run()
        samples.append((time.perf_counter() - start) / n)
    return statistics.median(samples)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args(argv)
    runs = args.runs

    scene = load_scene(SCENE)
    g = scene.grid
    points = list(itertools.product(range(g.x_min, g.x_max + 1), range(g.y_min, g.y_max + 1)))
    pairs = [(a, b) for a in points for b in points]
    rng = random.Random(1)
    off_grid = [(rng.uniform(-3, 15), rng.uniform(-3, 9), rng.uniform(-3, 15), rng.uniform(-3, 9))
                for _ in range(2000)]
    plan_states = states()
    motions = len(plan_states) - 1

    def load() -> int:
        load_scene(SCENE)
        return 1

    def cold() -> int:
        fresh = load_scene(SCENE)
        start = time.perf_counter()
        fresh.collision(0, 0, 1, 1)
        cold.elapsed = time.perf_counter() - start  # type: ignore[attr-defined]
        return 1

    def grid_calls() -> int:
        c = scene.collision
        for (x1, y1), (x2, y2) in pairs:
            c(x1, y1, x2, y2)
        return len(pairs)

    def off_grid_calls() -> int:
        fresh = load_scene(SCENE)
        c = fresh.collision
        for args_ in off_grid:
            c(*args_)
        off_grid_calls.scene = fresh  # type: ignore[attr-defined]
        return len(off_grid)

    def off_grid_cached() -> int:
        c = off_grid_calls.scene.collision  # type: ignore[attr-defined]
        for args_ in off_grid:
            c(*args_)
        return len(off_grid)

    def checker() -> int:
        all_violations(scene, plan_states)
        return motions

    def build() -> int:
        build_trajectory(scene, plan_states, points_per_step=10, step_time_s=1.0)
        return 1

    cold_samples = []
    for _ in range(runs):
        cold()
        cold_samples.append(cold.elapsed)  # type: ignore[attr-defined]
    grid_calls()  # warm the table
    rows = [
        ("scene load", median_time(load, runs), "per file"),
        ("collision, table build", statistics.median(cold_samples),
         f"first call, {len(points)} grid points"),
        ("collision, grid call", median_time(grid_calls, runs), f"per call, {len(pairs)} calls"),
        ("collision, off-grid call", median_time(off_grid_calls, runs), "per call, shapely + cache fill"),
        ("collision, off-grid cached", median_time(off_grid_cached, runs), "per call, LRU hit"),
        ("checker (all_violations)", median_time(checker, runs), f"per step, {motions}-step plan"),
        ("build_trajectory", median_time(build, runs), f"per plan, {motions} steps x 10 points"),
    ]
    print(f"trajectory benchmarks, median of {runs} runs")
    print(f"{'what':28} {'time':>12}  note")
    for name, seconds, note in rows:
        value = f"{seconds * 1e6:.2f} us" if seconds < 1e-3 else f"{seconds * 1e3:.2f} ms"
        print(f"{name:28} {value:>12}  {note}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
