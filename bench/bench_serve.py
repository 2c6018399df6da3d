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

The server's own figure does not see what happens between it and a client (Nagle's algorithm
held every second answer of the socket 40 ms, unseen). So two more are measured by clients,
against ``cplus serve`` as a process on the paper's domain (a simulated robot whose actions
take ``--action-time``, default 0.05 s):

* ``socket``: a TCP client sends a request, then another in the same write (the second of two
  lines is where Nagle bit), then cancels one: from the write to the acknowledgement line, to
  the first feedback line, and to the cancel's answer;
* ``ros``: an ``actionlib.SimpleActionClient`` (Debian's Python, a roscore on loopback): from
  ``send_goal`` to the goal's ACTIVE transition (``active_cb``) and to its first feedback.

Medians and maxima over ``--client-goals`` goals (default 40); the robot finishes each goal
before the next one is sent, so the figures are the answer to a request, not the queue.

    python bench/bench_serve.py [--runs 5] [--requests 40] [--only corridor20|socket|ros] [--budget N]
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
    from nxt_link.wire.clock import VirtualClock
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
        from cplus.robot.serving.script import RequestScript, ScriptEntry
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


# ---------------------------------------------------------------------------------------- clients
def _serve(extra: list[str], env: dict | None = None):
    """``cplus serve`` on the paper's domain as a process; returns it with the line that says
    it is ready (stderr is read on by a thread, so that it never blocks the server)."""
    import subprocess
    import threading
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "mailbot.cp"), "--quiet", *extra],
                            stderr=subprocess.PIPE, text=True, env=dict(env or os.environ, PYTHONUNBUFFERED="1",
                                                                        PYTHONPATH=str(ROOT)))
    assert proc.stderr is not None
    ready = ""
    for line in proc.stderr:
        if "listening on" in line or "ROS action server" in line:
            ready = line
            break
    threading.Thread(target=lambda: [None for _ in proc.stderr], daemon=True).start()  # type: ignore[union-attr]
    return proc, ready


def _stop(proc) -> None:
    import signal
    import subprocess
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _figures(name: str, xs: list[float]) -> str:
    return f"{name} median {statistics.median(xs):.2f} ms, max {max(xs):.2f} ms" if xs else f"{name}: none"


def bench_socket(goals: int, action_time: float) -> None:
    import json
    import socket
    proc, ready = _serve(["--listen", "127.0.0.1:0", "--action-time", str(action_time)])
    try:
        host, port = ready.split("listening on ")[1].split()[0].rsplit(":", 1)
        sock = socket.create_connection((host, int(port)), timeout=60)
        rfile = sock.makefile("rb")
        rng = random.Random(1)
        ack, second, feedback, cancel = [], [], [], []
        for _ in range(goals):
            a, b = rng.sample(range(1, 5), 2)
            c, d = rng.sample(range(1, 5), 2)
            lines = (json.dumps({"request": f"deliver(office{a},office{b})"}) + "\n" +
                     json.dumps({"request": f"deliver(office{c},office{d})"}) + "\n").encode()
            t0 = time.perf_counter()
            sock.sendall(lines)                  # two lines in one write
            acks: list[int] = []
            first_feedback = None
            while len(acks) < 2 or first_feedback is None:
                x = json.loads(rfile.readline())
                now = time.perf_counter()
                if x["type"] == "goal":
                    (ack if not acks else second).append((now - t0) * 1000)
                    acks.append(x["id"])
                elif x["type"] == "feedback" and first_feedback is None:
                    first_feedback = now
                    feedback.append((now - t0) * 1000)
            t1 = time.perf_counter()
            sock.sendall((json.dumps({"cancel": acks[1]}) + "\n").encode())
            while True:
                x = json.loads(rfile.readline())
                if x["type"] == "cancel":
                    cancel.append((time.perf_counter() - t1) * 1000)
                    break
            done = set()
            while len(done) < 2:                 # both ended before the next pair
                x = json.loads(rfile.readline())
                if x["type"] == "result":
                    done.add(x["id"])
        sock.close()
    finally:
        _stop(proc)
    print(f"socket, client side ({goals} pairs of requests, actions of {action_time:g} s): "
          f"{_figures('acknowledgement', ack)}; {_figures('second line of a write', second)}; "
          f"{_figures('first feedback', feedback)}; {_figures('cancel answered', cancel)}")


ROS_CLIENT = """
import json, sys, threading, time
import rospy, actionlib
from cplus_msgs.msg import ServeAction, ServeGoal
rospy.init_node("cplus_bench_client", anonymous=True, disable_signals=True)
client = actionlib.SimpleActionClient(sys.argv[1], ServeAction)
assert client.wait_for_server(rospy.Duration(60))
active, feedback = [], []
for i in range(int(sys.argv[2])):
    a, f = threading.Event(), threading.Event()
    t0 = time.perf_counter()
    def on_active(t0=t0, a=a):
        active.append((time.perf_counter() - t0) * 1000); a.set()
    def on_feedback(fb, t0=t0, f=f):
        if not f.is_set():
            feedback.append((time.perf_counter() - t0) * 1000); f.set()
    client.send_goal(ServeGoal(request="deliver(office%d,office%d)" % (1 + i % 4, 1 + (i + 2) % 4)),
                     active_cb=on_active, feedback_cb=on_feedback)
    assert client.wait_for_result(rospy.Duration(60))
print(json.dumps({"active": active, "feedback": feedback}))
"""


def bench_ros(goals: int, action_time: float) -> None:
    import json
    import shutil
    import socket
    import subprocess
    import tempfile
    dist = "/usr/lib/python3/dist-packages"
    if shutil.which("roscore") is None or not Path(dist, "rospy").is_dir():
        print("ros: ROS 1 is not installed (see docs/serve.md), skipped")
        return
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    home = tempfile.mkdtemp(prefix="bench-ros-")
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_HOSTNAME="127.0.0.1", ROS_HOME=home,
               ROS_LOG_DIR=f"{home}/log")
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        for _ in range(300):
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    break
            except OSError:
                time.sleep(0.2)
        proc, _ = _serve(["--ros", "--ros-name", "bench", "--action-time", str(action_time)], env)
        try:
            cenv = dict(env, PYTHONPATH=os.pathsep.join([str(ROOT / "cplus" / "robot" / "serving" / "ros"), dist]))
            python = "/usr/bin/python3" if Path("/usr/bin/python3").exists() else sys.executable
            r = subprocess.run([python, "-c", ROS_CLIENT, "/bench", str(goals)], env=cenv, capture_output=True,
                               text=True, timeout=120 + 30 * goals)
            if r.returncode != 0:
                print(f"ros: the client failed: {r.stderr[-500:]}")
                return
            out = json.loads(r.stdout.strip().splitlines()[-1])
        finally:
            _stop(proc)
    finally:
        import signal
        os.killpg(core.pid, signal.SIGINT)
        core.wait(30)
    print(f"ros, client side ({goals} goals, actions of {action_time:g} s): {_figures('ACTIVE', out['active'])}; "
          f"{_figures('first feedback', out['feedback'])}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--requests", type=int, default=40, help="requests per run (default 40)")
    p.add_argument("--only", choices=sorted(SCENARIOS) + ["socket", "ros"])
    p.add_argument("--client-goals", type=int, default=40, help="goals each client sends (default 40)")
    p.add_argument("--action-time", type=float, default=0.05, help="the clients' server: seconds per action")
    p.add_argument("--budget", type=int, default=None, help="the planner's budget in propagations (default: the server's)")
    p.add_argument("--solver", default=None, help="SAT solver (default: the server's)")
    args = p.parse_args()
    gc.disable()
    print(f"# {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the start; "
          f"{args.runs} runs of {args.requests} requests each")
    if args.only in (None, "socket"):
        bench_socket(args.client_goals, args.action_time)
    if args.only in (None, "ros"):
        bench_ros(args.client_goals, args.action_time)
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
