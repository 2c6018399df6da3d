"""Benchmark the online loop's decision latency: per cycle, the time from the end of a step to
the next step's actions (state estimate + monitor + re-plan when needed).

* ``delivery``: the delivery domain of ``domains/delivery`` run by the loop on a simulated
  robot whose actions take no time. A button press at cycle 1 and a missed landmark at cycle 5
  force two re-plans. ``delivery-20`` is the same robot on a corridor of 20 landmarks, with
  the letter for the far end;
* ``payload``: the payload arms of ``domains/payload``. A stalled arm is mapped back to the
  grid and the rest is re-planned with the refinement loop from there
  (:func:`cplus.robot.online.payload_monitor.run_arms`, two emulated bricks in memory on a virtual
  clock, robot r1 stalling at several points of the plan).

Medians and maxima over several runs. Grounding happens once per run and is reported apart.
Targets: under 50 ms per cycle on the delivery domain, under 300 ms for a payload re-plan.

    python bench/bench_online.py [--runs 5] [--only delivery]
"""
from __future__ import annotations

import argparse
import gc
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

DELIVERY = ROOT / "domains" / "delivery" / "delivery.cp"


def _delivery_domain(landmarks: int):
    from cplus.api import Domain
    text = DELIVERY.read_text(encoding="utf-8")
    if landmarks != 4:
        text = text.replace("last -> 4.", f"last -> {landmarks}.").replace(
            "letter(3) & [/\\L | L\\=3 ->> -letter(L)]", f"letter({landmarks}) & [/\\L | L\\={landmarks} ->> -letter(L)]")
        text = text.replace("maxstep :: 0..20;", f"maxstep :: 0..{4 * landmarks + 8};")
    return Domain.from_text(text, str(DELIVERY))


def delivery_run(landmarks: int) -> dict:
    """One run: grounding, then per-cycle decision times, re-planning cycles apart."""
    from cplus.robot.online.estimation import OnlineModel, Roles
    from cplus.robot.online.executors import SimulatedExecutor
    from cplus.robot.online.loop import OnlineLoop, OnlineStatus
    from nxt_link.wire.clock import VirtualClock
    t0 = time.perf_counter()
    domain = _delivery_domain(landmarks)
    model = OnlineModel(domain, "deliver", Roles.of(domain, observed=["press"], inferred=["missed"]))
    domain.templates                                   # noqa: B018 - ground and build templates now
    setup = time.perf_counter() - t0
    clock = VirtualClock()
    ex = SimulatedExecutor(model, sensed={"atLandmark": ["follow"]}, events={1: ["press"], 5: ["missed"]},
                           clock=clock)
    result = OnlineLoop(model, ex, clock=clock).run()
    if result.status is not OnlineStatus.GOAL_REACHED:
        raise SystemExit(f"delivery-{landmarks}: {result.status.value}: {result.message}")
    steady = [r.decision_s for r in result.records[1:] if r.replanned is None]
    replans = [r.decision_s for r in result.records[1:] if r.replanned is not None]
    return {"setup": setup, "first": result.records[0].decision_s, "steady": steady, "replan": replans,
            "all": [r.decision_s for r in result.records], "cycles": len(result.records),
            "replans": result.replans}


STALLS = ("B@1.5+1", "B@2+1", "C@3+1", "A@4.5+1")
"""Where robot r1's motors stall in the payload runs (seconds after the motor first turned):
times at which the first plan moves that motor (a motor held while it should stand still is
no fault), so each run re-plans once; a first plan of another shape may need other times."""


def payload_runs(runs: int) -> list[dict]:
    """The payload arms on two emulated bricks in memory (virtual clock), r1 stalling at
    different points of the plan: the time from the fault's stop to the new plan (reading the
    angles, mapping them to the nearest grid state, refining from there)."""
    import cplus.robot.online.payload_monitor as pm
    from cplus.robot import RobotTask
    from cplus.robot.online.loop import OnlineStatus
    from nxt_link import BrickEmulator, EmulatorConfig, LinkParams
    from nxt_link.emulator.memory_transport import MemoryTransport
    from nxt_link.emulator.stall import Stall
    from nxt_link.wire.clock import VirtualClock
    payload = ROOT / "domains" / "payload"
    t0 = time.perf_counter()
    task = RobotTask.load(str(payload / "payload.cp"), str(payload / "scene.toml"))
    task.domain.templates                                  # noqa: B018 - ground and build templates now
    setup = time.perf_counter() - t0
    replans: list[float] = []
    first: list[float] = []
    faults = 0
    for _ in range(runs):
        for spec in STALLS:
            clock = VirtualClock()
            emus = {n: BrickEmulator(EmulatorConfig(name=n, link=LinkParams.instant(),
                                                    stalls=(Stall.parse(spec),) if n == "r1" else ()))
                    for n in ("r1", "r2")}
            ex = pm.ArmsExecutor(["r1", "r2"], transports={n: MemoryTransport(e, clock) for n, e in emus.items()})
            gc.collect()
            result = pm.run_arms(task, "0", ex, clock=clock)
            if result.status is not OnlineStatus.GOAL_REACHED:
                raise SystemExit(f"payload with r1 stalling {spec}: {result.status.value}: {result.message}")
            first.append(result.records[0].decision_s)
            replans.extend(r.decision_s for r in result.records if r.replanned is not None
                           and r.replanned.reason == "fault")
            faults += sum(1 for r in result.records if r.failure)
    return [{"name": "payload", "setup": setup, "first": first, "replan": replans, "replans": faults // runs,
             "cycles": len(STALLS)}]


def _ms(values: list[float]) -> str:
    if not values:
        return "      -         -"
    return f"{statistics.median(values) * 1000:8.2f}  {max(values) * 1000:8.2f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", choices=("delivery", "payload"))
    args = ap.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"online loop decision latency, {args.runs} runs, machine load {load:.1f} "
          f"({os.cpu_count()} cores), ms: median  max")
    print(f"{'case':<14} {'cycles':>6} {'replans':>7} {'setup':>8} {'first':>8}   {'every cycle':>17}   "
          f"{'carry on':>17}   {'re-plan':>17}")
    if args.only in (None, "delivery"):
        for landmarks in (4, 20):
            rows = []
            for _ in range(args.runs):
                gc.collect()
                rows.append(delivery_run(landmarks))
            every = [x for r in rows for x in r["all"]]
            steady = [x for r in rows for x in r["steady"]]
            replan = [x for r in rows for x in r["replan"]]
            name = "delivery" if landmarks == 4 else f"delivery-{landmarks}"
            print(f"{name:<14} {rows[0]['cycles']:>6} {rows[0]['replans']:>7} "
                  f"{statistics.median(r['setup'] for r in rows) * 1000:8.1f} "
                  f"{statistics.median(r['first'] for r in rows) * 1000:8.2f}   {_ms(every)}   {_ms(steady)}   "
                  f"{_ms(replan)}")
    if args.only in (None, "payload"):
        rows = payload_runs(args.runs)
        for r in rows:
            print(f"{r['name']:<14} {r['cycles']:>6} {r['replans']:>7} {r['setup'] * 1000:8.1f} "
                  f"{statistics.median(r['first']) * 1000:8.1f}   {'':>17}   {'':>17}   {_ms(r['replan'])}")
            print(f"{'':<14} (runs of {len(STALLS)} stalls of r1: {', '.join(STALLS)}; 'first' is the first "
                  "refined plan, 're-plan' from the stop to the new refined plan)")
    print("targets: delivery < 50 ms per cycle; payload re-plan < 300 ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
