"""The goal state machine of docs/serve.md, held against what the robot did: random interleavings
of requests, cancellations, status queries and the robot's steps, through the board's API and
the socket, on the mail robot (domains/mailbot) with a simulated robot that takes one step
each time the test lets it.

For every goal: the statuses its watchers heard are a path of the machine; a status query
answered one of them; and the final status agrees with the actions executed while the goal
held its package: succeeded if and only if ``deliver(P)`` was executed at the goal's
destination, preempted or recalled never so, recalled with nothing executed at all (no
package, no events)."""
from __future__ import annotations

import json
import queue
import socket
import threading
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus.api import Domain
from cplus.robot.online import SimulatedExecutor
from cplus.robot.serving.goals import FINAL, GoalStatus, GoalWatcher
from cplus.robot.serving.reactive import Server, ServerSettings
from cplus.robot.serving.vocabulary import load_requests

MAILBOT = Path(__file__).resolve().parent.parent / "domains" / "mailbot"
OFFICES = ["office1", "office2", "office3", "office4"]

S = GoalStatus
NEXT = {                                   # the machine of docs/serve.md ("Goals")
    S.PENDING: {S.ACTIVE, S.RECALLED, S.REJECTED, S.ABORTED},
    S.ACTIVE: {S.PREEMPTING, S.SUCCEEDED, S.ABORTED},
    S.PREEMPTING: {S.PREEMPTED, S.SUCCEEDED, S.ABORTED},
}
FIRST = {S.PENDING, S.REJECTED}

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def domain():
    return Domain.load(str(MAILBOT / "mailbot.cp"))


class GatedRobot(SimulatedExecutor):
    """The simulated robot, which takes a step only when the test releases one."""

    def __init__(self, model) -> None:
        super().__init__(model)
        self.permits = threading.Semaphore(0)
        self.closing = threading.Event()

    def execute(self, step):
        while not self.permits.acquire(timeout=0.02):
            if self.closing.is_set():
                break
        return super().execute(step)


class Heard(GoalWatcher):
    def __init__(self) -> None:
        self.statuses: dict[int, list[GoalStatus]] = {}
        self.lock = threading.Lock()

    def status(self, goal, status) -> None:
        with self.lock:
            self.statuses.setdefault(goal.id, []).append(status)


class LineClient:
    """A socket client: each line sent is answered in order; other lines are the goals' news."""

    def __init__(self, address) -> None:
        self.sock = socket.create_connection(address, timeout=30)
        self.file = self.sock.makefile("r", encoding="utf-8")
        self.answers: queue.Queue = queue.Queue()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        try:
            for line in self.file:
                msg = json.loads(line)
                if msg["type"] in ("goal", "cancel", "status", "error"):
                    self.answers.put(msg)
        except (OSError, ValueError):
            pass

    def ask(self, obj: dict) -> dict:
        """The answer to ``obj``: the next line of its type (a goal's news is also of type
        ``status``: for a status query, the first line about that goal, which says the same)."""
        (key, value), = obj.items()
        want = {"request": "goal", "cancel": "cancel", "status": "status"}[key]
        self.sock.sendall((json.dumps(obj) + "\n").encode())
        while True:
            msg = self.answers.get(timeout=30)
            if msg["type"] == "error" or (msg["type"] == want and (key == "request" or msg["id"] == value)):
                return msg

    def close(self) -> None:
        self.sock.close()


op = st.one_of(
    st.tuples(st.just("request"), st.sampled_from(["api", "socket"]),
              st.sampled_from(OFFICES), st.sampled_from(OFFICES)).filter(lambda t: t[2] != t[3]),
    st.tuples(st.just("cancel"), st.sampled_from(["api", "socket"]), st.integers(0, 7)),
    st.tuples(st.just("status"), st.sampled_from(["api", "socket"]), st.integers(0, 7)),
    st.tuples(st.just("step"), st.integers(1, 4)),
)


def delivered(records, goal, dest: str) -> bool:
    """Whether deliver(P) of the goal's package was executed at its destination while it held it."""
    if goal.slot is None:
        return False
    end = goal.done_cycle if goal.done_cycle is not None else 10**9
    return any(goal.cycle <= r.cycle < end and f"deliver({goal.slot})" in [a.text for a in r.executed]
               and r.state is not None and r.state.value("at") == dest for r in records)


@settings(max_examples=30)
@given(ops=st.lists(op, min_size=1, max_size=14))
def test_final_statuses_agree_with_what_the_robot_did(domain, ops):
    vocabulary = load_requests(str(MAILBOT / "requests.toml"), domain)
    server = Server(domain, vocabulary, ServerSettings(idle_poll_s=0.01), executor=GatedRobot)
    robot = server.executor
    assert isinstance(robot, GatedRobot)
    heard = Heard()
    server.board.watch(heard)
    client = LineClient(server.listen("127.0.0.1", 0))
    box: list = []
    thread = threading.Thread(target=lambda: box.append(server.run()), daemon=True)
    thread.start()
    ids: list[int] = []
    dests: dict[int, str] = {}
    answered: list[tuple[int, str]] = []
    try:
        for o in ops:
            if o[0] == "request":
                text = f"deliver({o[2]},{o[3]})"
                if o[1] == "api":
                    gid = server.board.submit(text).id
                else:
                    gid = client.ask({"request": text})["id"]
                ids.append(gid)
                dests[gid] = o[3]
            elif o[0] in ("cancel", "status") and ids:
                gid = ids[o[2] % len(ids)]
                if o[1] == "api":
                    if o[0] == "cancel":
                        server.board.cancel(gid)
                    got = server.board.describe(gid)
                else:
                    got = client.ask({o[0]: gid})
                assert got is not None and got["id"] == gid
                answered.append((gid, got["status"]))
            elif o[0] == "step":
                for _ in range(o[1]):
                    robot.permits.release()
        # let the robot finish every goal (a delivery on four offices takes 7 steps at most)
        for _ in range(10 * len(ids) + 10):
            if all(server.board.get(g).final for g in ids):
                break
            robot.permits.release()
            server.board.drain(1.0)
            threading.Event().wait(0.005)
    finally:
        server.stop()
        robot.closing.set()
        thread.join(30)
        client.close()
    assert not thread.is_alive()
    result = box[0]
    server.board.drain(2.0)
    for gid in ids:
        goal = server.board.get(gid)
        assert goal is not None and goal.final, (gid, goal)
        path = heard.statuses[gid]
        assert path[0] in FIRST and path[-1] is goal.status, path
        for a, b in zip(path, path[1:]):
            assert b in NEXT.get(a, set()), (gid, path)
        assert [s for s in path if s in FINAL] == [goal.status]
        assert {s for g, s in answered if g == gid} <= {s.value for s in path}
        if goal.status is S.ABORTED:          # the run was stopped before this one ended
            continue
        assert goal.status in (S.SUCCEEDED, S.PREEMPTED, S.RECALLED), goal
        did = delivered(result.records, goal, dests[gid])
        assert did == (goal.status is S.SUCCEEDED), (gid, goal.status, goal.slot, goal.cycle, goal.done_cycle)
        if goal.status is S.RECALLED:             # never reached the loop: no package, no events
            assert goal.slot is None and goal.cycle is None and not goal.events
