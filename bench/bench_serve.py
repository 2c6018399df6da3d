"""Benchmark ``cplus serve``'s reaction latency: from a request's arrival at the server to the
first action of the plan made with it (the state estimate with its events, and the re-plan).

* ``mailbot``: the paper's domain (``domains/mailbot/mailbot.cp``: four offices, three
  packages on board, three requests in flight at most): the Table I scenario, then a stream
  of requests with random offices, one arriving whenever fewer than three are in flight, and
  one request in five cancelled two cycles after it arrived;
* ``corridor20``: the scaled variant (``corridor20.cp``: twenty offices, ten requests in
  flight): ten requests at once, then a new one whenever one is done, and one in five
  cancelled two cycles later.

Requests arrive from the Python API (:meth:`GoalBoard.submit`) while the loop runs, on a
simulated robot whose actions take no time, so the numbers are the server's own work: wall
time, and the process's processor time next to it (what the work costs when other programs
share the machine's cores). Each
run grounds the domain once (reported apart, with the first plan). Medians and maxima over
every request of several runs; how each re-plan was found (the shortest plan for every goal
within the budget, or the oldest goal first) and the plans' lengths are counted too.
Targets: under 20 ms on the paper's domain, under 200 ms on the scaled one.

    python bench/bench_serve.py [--runs 5] [--requests 40] [--only corridor20] [--budget N]
"""
from __future__ import annotations

import argparse
import gc
import os
import random
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

MAILBOT = ROOT / "domains" / "mailbot"
SCENARIOS = {"mailbot": ("mailbot.cp", 4, 3, None), "corridor20": ("corridor20.cp", 20, 10, 40)}


class Stream:
    """Keeps ``in_flight`` requests going: a new one whenever fewer are open, until ``total``
    have been sent; every fifth one is cancelled two cycles after it arrived."""

    def __init__(self, server, offices: int, in_flight: int, total: int, seed: int) -> None:
        self.server = server
        self.offices = offices
        self.in_flight = in_flight
        self.total = total
        self.rng = random.Random(seed)
        self.sent = 0
        self.cancel_at: dict[int, list[int]] = {}
        self.how: dict[str, int] = {}
        self.lengths: list[int] = []
        self.replan_ms: list[float] = []
        self.live = True
        server.board.open_channel()           # a live source: the run waits for its requests
        self.cpu_submitted: dict[int, float] = {}
        self.cpu_reaction: dict[int, float] = {}

    def request(self) -> str:
        a, b = self.rng.sample(range(1, self.offices + 1), 2)
        return f"deliver(office{a},office{b})"

    def top_up(self, cycle: int) -> None:
        board = self.server.board
        open_ = sum(1 for g in board.goals.values() if not g.final)
        while open_ < self.in_flight and self.sent < self.total:
            goal = board.submit(self.request())
            self.cpu_submitted[goal.id] = time.process_time()
            self.sent += 1
            open_ += 1
            if self.sent % 5 == 0:
                self.cancel_at.setdefault(cycle + 2, []).append(goal.id)
        for gid in self.cancel_at.pop(cycle, []):
            board.cancel(gid)
        if self.sent >= self.total and open_ == 0 and self.live:
            self.live = False
            board.close_channel()             # the run ends when the robot is idle

    # the loop's observer
    def on_start(self, loop) -> None:
        return None

    def on_act(self, record) -> None:
        now = time.process_time()
        for g in self.server.board.goals.values():
            if g.reaction_s is not None and g.id in self.cpu_submitted and g.id not in self.cpu_reaction:
                self.cpu_reaction[g.id] = (now - self.cpu_submitted[g.id]) * 1000
        if record.replanned is not None and record.cycle > 0:
            st = self.server.model.planner.stats
            self.how[st.how] = self.how.get(st.how, 0) + 1
            self.lengths.append(st.length)
            self.replan_ms.append(record.decision_s * 1000)
            if os.environ.get("BENCH_DEBUG"):
                print(round(record.decision_s * 1000, 1), st, file=sys.stderr)
        self.top_up(record.cycle + 1)       # arrives during this cycle's step (or idle wait)

    def on_cycle(self, record) -> None:
        return None

    def on_end(self, result) -> None:
        return None


def run(name: str, total: int, seed: int, budget: int | None, solver: str | None = None) -> dict:
    from cplus.api import Domain
    from cplus.robot.serving.reactive import Server, ServerSettings
    from cplus.robot.serving.standing import DEFAULT_BUDGET
    from cplus.robot.serving.vocabulary import load_requests
    from nxt_link.clock import VirtualClock
    file, offices, in_flight, horizon = SCENARIOS[name]
    t0 = time.perf_counter()
    domain = Domain.load(str(MAILBOT / file))
    vocabulary = load_requests(str(MAILBOT / "requests.toml"), domain)
    server = Server(domain, vocabulary, ServerSettings(clock=VirtualClock(), horizon=horizon, solver=solver,
                                                       budget=DEFAULT_BUDGET if budget is None else budget))
    setup = time.perf_counter() - t0
    stream = Stream(server, offices, in_flight, total, seed)
    server.loop.observers.append(stream)
    if name == "mailbot":                      # Table I first: requests 1 and 2, a cancellation
        script = [(1, "deliver(office3,office2)"), (3, 1), (4, "deliver(office3,office4)")]
        from cplus.robot.serving.channels import RequestScript, ScriptEntry
        server.add_script(RequestScript([ScriptEntry(c, x if isinstance(x, str) else None,
                                                     x if isinstance(x, int) else None, i)
                                         for i, (c, x) in enumerate(script, 1)]))
        stream.sent, stream.total = 0, total
        stream.top_up = _after(stream.top_up, 8)      # the stream starts once Table I is done
    else:
        stream.top_up(1)
    result = server.run()
    goals = list(server.board.goals.values())
    reactions = [g.reaction_s * 1000 for g in goals if g.reaction_s is not None]
    done = {s: sum(1 for g in goals if g.status.value == s) for s in ("succeeded", "preempted", "recalled")}
    return {"setup_s": setup, "status": result.status.value, "reactions": reactions, "cycles": len(result.records),
            "cpu": list(stream.cpu_reaction.values()),
            "how": stream.how, "lengths": stream.lengths, "replan_ms": stream.replan_ms, "done": done}


def _after(fn, first_cycle: int):
    def wrapped(cycle: int) -> None:
        if cycle >= first_cycle:
            fn(cycle)
    return wrapped


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--requests", type=int, default=40, help="requests per run (default 40)")
    p.add_argument("--only", choices=sorted(SCENARIOS))
    p.add_argument("--budget", type=int, default=None, help="the planner's budget in propagations (default: the server's)")
    p.add_argument("--solver", default=None, help="SAT solver (default: the server's)")
    args = p.parse_args()
    gc.disable()
    print(f"# {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the start; "
          f"{args.runs} runs of {args.requests} requests each")
    for name in SCENARIOS:
        if args.only and name != args.only:
            continue
        runs = [run(name, args.requests, seed, args.budget, args.solver) for seed in range(args.runs)]
        reactions = [x for r in runs for x in r["reactions"]]
        replans = [x for r in runs for x in r["replan_ms"]]
        lengths = [x for r in runs for x in r["lengths"]]
        how: dict[str, int] = {}
        for r in runs:
            for k, v in r["how"].items():
                how[k] = how.get(k, 0) + v
        done: dict[str, int] = {}
        for r in runs:
            for k, v in r["done"].items():
                done[k] = done.get(k, 0) + v
        print(f"{name}: setup (parse, ground, first encoding) median {statistics.median(r['setup_s'] for r in runs):.2f} s; "
              f"status {', '.join(sorted({r['status'] for r in runs}))}; goals {done}")
        cpu = [x for r in runs for x in r["cpu"]]
        print(f"  reaction latency over {len(reactions)} requests: median {statistics.median(reactions):.1f} ms, "
              f"max {max(reactions):.1f} ms (processor time: median {statistics.median(cpu):.1f} ms, "
              f"max {max(cpu):.1f} ms)")
        print(f"  re-plans: {len(replans)}, median {statistics.median(replans):.1f} ms, max {max(replans):.1f} ms; "
              f"found as {how}; plan length median {statistics.median(lengths):.0f}, max {max(lengths)}")


if __name__ == "__main__":
    main()
