"""Goals of a server on the mail robot (domains/mailbot), from scripts, on a simulated robot
and simulated time: ROSoClingo's Table I, cancellations before and after the pickup, the
capacity, two requests interleaved, requests the domain cannot express, goals waiting for a
slot and recalled, goals aborted when the run stops, and the log."""
from __future__ import annotations

import io
import json
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from walltime import wall

from cplus.api import Domain
from cplus.robot.online.loop import CycleRecord, OnlineStatus
from cplus.robot.serving.goals import GoalBoard, GoalRecorder, GoalStatus, GoalWatcher, Limits
from cplus.robot.serving.reactive import Server, ServerSettings
from cplus.robot.serving.script import ScriptError, parse_script
from cplus.robot.serving.vocabulary import Rejected, RequestsError, load_requests, parse_requests
from nxt_link.wire.clock import VirtualClock

MAILBOT = Path(__file__).resolve().parent.parent / "domains" / "mailbot"


@pytest.fixture(scope="module")
def domain():
    return Domain.load(str(MAILBOT / "mailbot.cp"))


def vocabulary(d):
    return load_requests(str(MAILBOT / "requests.toml"), d)


def serve(d, lines: list[dict], **kw):
    """Run a server on a script until it is done; return the result, the server and the log."""
    text = "".join(json.dumps(x) + "\n" for x in lines)
    server = Server(d, vocabulary(d), ServerSettings(clock=VirtualClock(), **kw))
    out = io.StringIO()
    server.log_to(out)
    server.add_script(parse_script(text, "script.jsonl"))
    result = server.run()
    return result, server, [json.loads(x) for x in out.getvalue().splitlines()]


def executed(result) -> list[list[str]]:
    return [[a.text for a in r.executed] for r in result.records]


def status(server) -> dict[int, str]:
    return {g.id: g.status.value for g in server.board.goals.values()}


# ROSoClingo's Table I: the plans returned for varying requests, as steps 1.. of the history
TABLE_I = {
    1: {1: "move(office2)", 2: "move(office3)", 3: "pickup(1)", 4: "move(office2)", 5: "deliver(1)"},
    2: {1: "move(office2)", 2: "move(office3)"},
    3: {1: "move(office2)", 2: "move(office3)", 4: "pickup(2)", 5: "move(office4)", 6: "deliver(2)"},
}


def test_the_papers_scenario_gives_the_plans_of_table_1(domain):
    script = (MAILBOT / "table1.jsonl").read_text()
    server = Server(domain, vocabulary(domain), ServerSettings(clock=VirtualClock()))
    server.add_script(parse_script(script, "table1.jsonl"))
    result = server.run()
    assert result.status is OnlineStatus.GOAL_REACHED
    plans = []
    for r in result.records:
        if r.replanned is not None and r.events:
            history = {k: x[0] for k, x in enumerate(executed(result)[:r.cycle]) if x}
            history.update({r.cycle + i: s[0] for i, s in enumerate(r.plan.texts())})
            plans.append(history)
    assert plans == [TABLE_I[1], TABLE_I[2], TABLE_I[3]]
    # cycle 3 waits at office3 (plan 2 is empty); the second request's pickup is at cycle 4
    assert executed(result)[3] == [] and result.records[3].state.value("at") == "office3"
    assert status(server) == {1: "preempted", 2: "succeeded"}
    g1, g2 = server.board.goals[1], server.board.goals[2]
    assert (g1.slot, g1.cycle, g1.done_cycle) == (1, 1, 3) and (g2.slot, g2.cycle, g2.done_cycle) == (2, 4, 7)


def test_a_cancellation_before_the_pickup_drops_the_request(domain):
    result, server, _ = serve(domain, [{"cycle": 1, "request": "deliver(office3,office4)"}, {"cycle": 2, "cancel": 1}])
    assert status(server) == {1: "preempted"}
    assert executed(result) == [[], ["move(office2)"], []]
    assert server.board.goals[1].done_cycle == 2
    assert result.state.value("at") == "office2" and result.state.value("phase(1)") == "idle"


def test_a_cancellation_after_the_pickup_brings_the_package_back_to_its_origin(domain):
    result, server, _ = serve(domain, [{"cycle": 1, "request": "deliver(office2,office4)"}, {"cycle": 4, "cancel": 1}])
    assert executed(result) == [[], ["move(office2)"], ["pickup(1)"], ["move(office3)"],
                                ["move(office2)"], ["deliver(1)"], []]
    r4 = result.records[4]
    assert r4.events == ["cancel(1)"] and r4.state.value("dest(1)") == "office2"
    # preempting while it travels back, preempted once it is delivered at office2
    assert status(server) == {1: "preempted"} and server.board.goals[1].done_cycle == 6
    assert result.records[5].state.value("at") == "office2"


def test_a_cancellation_that_comes_with_the_delivery_is_too_late(domain):
    # deliver(1) is executed at cycle 3; the cancellation arrives with the transition it ends
    result, server, _ = serve(domain, [{"cycle": 1, "request": "deliver(office1,office2)"}, {"cycle": 4, "cancel": 1}])
    assert executed(result)[1:4] == [["pickup(1)"], ["move(office2)"], ["deliver(1)"]]
    assert status(server) == {1: "succeeded"} and server.board.goals[1].cancel_cycle == 4


def test_the_robot_carries_at_most_three_packages(domain):
    def run(capacity: int):
        text = (MAILBOT / "mailbot.cp").read_text().replace("slots -> 3;", "slots -> 4;")
        text = text.replace("capacity -> 3;", f"capacity -> {capacity};")
        d = Domain.from_text(text, str(MAILBOT / "mailbot4.cp"))
        return serve(d, [{"cycle": 1, "request": "deliver(office2,office4)"} for _ in range(4)], budget=None)
    result, server, _ = run(3)
    assert result.status is OnlineStatus.GOAL_REACHED and set(status(server).values()) == {"succeeded"}
    assert max(r.state.value("load") for r in result.records) <= 3
    acts = [x[0] for x in executed(result) if x]
    # four packages from office2 to office4: two trips, 15 actions (with room for four: one trip, 11)
    assert len(acts) == 15 and acts.count("move(office4)") == 2
    result, server, _ = run(4)
    assert sum(1 for x in executed(result) if x) == 11 and max(r.state.value("load") for r in result.records) == 4


def test_two_requests_interleave_in_one_plan(domain):
    result, server, log = serve(domain, [{"cycle": 1, "request": "deliver(office1,office4)"},
                                         {"cycle": 3, "request": "deliver(office2,office3)"}])
    assert status(server) == {1: "succeeded", 2: "succeeded"}
    r3 = result.records[3]
    assert r3.replanned.reason == "event" and r3.state.value("at") == "office2"
    # the plan made at cycle 3 picks package 2 up on the way and delivers it first
    assert r3.plan.texts() == [["pickup(2)"], ["move(office3)"], ["deliver(2)"], ["move(office4)"], ["deliver(1)"]]
    assert executed(result) == [[], ["pickup(1)"], ["move(office2)"], ["pickup(2)"], ["move(office3)"],
                                ["deliver(2)"], ["move(office4)"], ["deliver(1)"], []]
    assert max(r.state.value("load") for r in result.records) == 2


def test_requests_the_domain_cannot_express_are_rejected_and_the_server_goes_on(domain):
    result, server, log = serve(domain, [
        {"cycle": 1, "request": "deliver(office3"},
        {"cycle": 1, "request": "deliver(office9,office2)"},
        {"cycle": 1, "request": "fetch(office1)"},
        {"cycle": 1, "request": "deliver(office1)"},
        {"cycle": 2, "request": "deliver(office1,office2)"}])
    assert status(server) == {1: "rejected", 2: "rejected", 3: "rejected", 4: "rejected", 5: "succeeded"}
    reasons = [server.board.goals[i].reason for i in (1, 2, 3, 4)]
    assert reasons == ["cannot read 'deliver(office3' as a request such as deliver(office,office)",
                       "office9 is not an office (office1, office2, office3, office4)",
                       "unknown request 'fetch'; this domain accepts deliver(office,office)",
                       "deliver takes 2 arguments (deliver(office,office)), not 1"]
    assert server.board.goals[5].slot == 1            # rejected requests take no slot
    goals = {g["id"]: g for g in log if g["record"] == "goal"}
    assert goals[2] == {"record": "goal", "id": 2, "request": "deliver(office9,office2)", "status": "rejected",
                        "reason": "office9 is not an office (office1, office2, office3, office4)"}


def test_a_request_waits_for_a_free_slot_and_can_be_recalled_meanwhile(domain):
    lines = [{"cycle": 1, "request": "deliver(office4,office1)"} for _ in range(5)] + [{"cycle": 2, "cancel": 5}]
    result, server, _ = serve(domain, lines)
    goals = server.board.goals
    assert status(server) == {1: "succeeded", 2: "succeeded", 3: "succeeded", 4: "succeeded", 5: "recalled"}
    first = min((goals[i] for i in (1, 2, 3)), key=lambda g: g.done_cycle)
    # the fourth takes the first slot freed, at the next cycle; the fifth never had one
    assert [goals[i].slot for i in (1, 2, 3)] == [1, 2, 3] and goals[4].slot == first.slot
    assert goals[4].cycle == first.done_cycle + 1 and goals[5].slot is None
    assert result.status is OnlineStatus.GOAL_REACHED


def test_slots_are_given_round_robin(domain):
    result, server, _ = serve(domain, [{"cycle": c, "request": "deliver(office1,office2)"} for c in (1, 8, 15, 22)])
    assert [g.slot for g in server.board.goals.values()] == [1, 2, 3, 1]


class Statuses(GoalWatcher):
    def __init__(self) -> None:
        self.seen: list[tuple[int, str]] = []
        self.feedback_cycles: list[int] = []
        self.changed = threading.Event()

    def status(self, goal, status) -> None:
        self.seen.append((goal.id, status.value))
        self.changed.set()

    def feedback(self, goal, feedback) -> None:
        self.feedback_cycles.append(feedback.cycle)


def test_stopping_the_server_aborts_the_goals_in_flight(domain):
    server = Server(domain, vocabulary(domain), ServerSettings(action_time=0.01))
    server.board.open_channel()                       # a live client: the run waits for requests
    watcher = Statuses()
    done = threading.Event()
    result_box = []
    thread = threading.Thread(target=lambda: (result_box.append(server.run()), done.set()))
    thread.start()
    goal = server.board.submit("deliver(office4,office1)", watcher)
    while not watcher.feedback_cycles:
        watcher.changed.wait(0.05)
    server.stop()
    thread.join(wall(10))
    assert result_box[0].status is OnlineStatus.STOPPED
    assert goal.status is GoalStatus.ABORTED
    assert goal.reason == f"the server stopped (ended on request at cycle {result_box[0].cycles - 1})"
    assert watcher.seen[:2] == [(1, "pending"), (1, "active")] and watcher.seen[-1] == (1, "aborted")
    late = server.board.submit("deliver(office1,office2)")
    assert late.status is GoalStatus.REJECTED and late.reason.startswith("the server stopped")


def test_watchers_hear_each_change_in_order_with_feedback_per_cycle(domain):
    watcher = Statuses()
    server = Server(domain, vocabulary(domain), ServerSettings(clock=VirtualClock()))
    server.board.watch(watcher)
    server.board.submit("deliver(office2,office1)")
    server.run()
    assert watcher.seen == [(1, "pending"), (1, "active"), (1, "succeeded")]
    assert watcher.feedback_cycles == [1, 2, 3, 4]


def test_the_log_is_the_online_log_with_a_record_at_each_goal_change(domain):
    result, server, log = serve(domain, [{"cycle": 1, "request": "deliver(office3,office2)"}, {"cycle": 3, "cancel": 1}])
    kinds = [x["record"] for x in log]
    assert kinds[0] == "start" and kinds[-1] == "end" and kinds.count("cycle") == len(result.records)
    assert log[0]["format"] == "cplus.online/1" and "cancel(1)" in log[0]["observed"]
    assert "move(office2)" in log[0]["agent"] and "request(1,office3)" not in log[0]["agent"]
    assert log[0]["serve_format"] == "cplus.serve/3" and log[0]["first_goal_id"] == 1 and "continues" not in log[0]
    for line in log:
        if line["record"] == "cycle":
            assert {"cycle", "state", "executed", "events", "sensed", "plan", "replanned"} <= set(line)
            assert "goals" not in line
    # each change where it happened: pending and active before the record of cycle 1 (the
    # transition that took it), preempted before the record of cycle 3 (where it closed)
    where = [(x["record"], x.get("cycle") if x["record"] == "cycle" else x.get("status")) for x in log[1:-1]]
    assert where[:4] == [("cycle", 0), ("goal", "pending"), ("goal", "active"), ("cycle", 1)]
    assert where[5:8] == [("goal", "preempting"), ("goal", "preempted"), ("cycle", 3)]
    active = log[3]
    assert active == {"record": "goal", "id": 1, "request": "deliver(office3,office2)", "status": "active", "slot": 1,
                      "cycle": 1}
    done = next(x for x in log if x["record"] == "goal" and x["status"] == "preempted")
    assert done["done_cycle"] == 3 and done["reason"] == "cancelled"
    assert log[-1]["status"] == "goal_reached" and [g["status"] for g in log[-1]["goals"]] == ["preempted"]
    assert log[-1]["goal_counts"] == {"preempted": 1}


# ---------------------------------------------------------------------------------- inputs
def test_script_errors_are_located():
    cases = {
        '{"cycle": 1, "request": "deliver(a,b)"}\n{"cycle": 0, "request": "x"}\n':
            'script.jsonl:2:1: error: "cycle" must be an integer from 1',
        '{"cycle": 1, "request": "x"\n': "script.jsonl:1:28: error: not JSON: Expecting ',' delimiter",
        '{"cycle": 1, "request": "x", "cancel": 1}\n': "script.jsonl:1:1: error: a line has exactly one of",
        '{"cycle": 1, "cancel": 2}\n{"cycle": 2, "request": "x"}\n':
            "script.jsonl:1:1: error: cancels goal 2, but only 0 requests arrive by cycle 1",
        '{"cycle": 1, "request": "x"}\n{"cycle": 3, "cancel": 2}\n':
            "script.jsonl:2:1: error: cancels goal 2, but only 1 request arrives by cycle 3",
        '{"cycle": 1, "requests": "x"}\n': "script.jsonl:1:1: error: unknown field 'requests'",
        '[1, 2]\n': "script.jsonl:1:1: error: each line is a JSON object",
        '{"cycle": 1, "request": 3}\n': 'script.jsonl:1:1: error: "request" must be a string',
    }
    for text, message in cases.items():
        with pytest.raises(ScriptError) as e:
            parse_script(text, "script.jsonl")
        assert e.value.render().startswith(message), (text, e.value.render())


REQUESTS = '''format = "cplus.requests/1"
slots = "package"
open = "pending($slot)"
cancel = ["cancel($slot)"]
[requests]
deliver = ["request($slot,$1)", "address($slot,$2)"]
'''


def test_requests_file_errors_are_located(domain):
    cases = [
        (("slots = \"package\"", "slots = \"parcel\""), "requests.toml:2:1: error: unknown sort 'parcel'"),
        (("open = \"pending($slot)\"", "open = \"load\""), "requests.toml:3:1: error: load must be a Boolean fluent "
                                                          "(true while the goal is open), not an inertialFluent of 0, 1"),
        (("open = \"pending($slot)\"", "open = \"phase($slot)\""), "requests.toml:3:1: error: phase must be a Boolean"),
        (("\"cancel($slot)\"", "\"cancel($1)\""), "requests.toml:4:11: error: $1: only $slot may appear here"),
        (("\"address($slot,$2)\"", "\"adress($slot,$2)\""), "requests.toml:6:33: error: "
                                                           f"{MAILBOT / 'mailbot.cp'} has no event adress/2 (events: "
                                                           "address, cancel, deliver, move, pickup, request)"),
        (("\"address($slot,$2)\"", "\"address($slot,$3)\""), "requests.toml:6:1: error: request deliver uses $3 but not $2"),
        (("\"address($slot,$2)\"", "\"address($1,$2)\""), "requests.toml:6:33: error: $1 fills places of two"),
        (("[requests]", "[request]"), "requests.toml:5:1: error: unknown top-level field 'request'"),
        (("cplus.requests/1", "cplus.requests/2"), "requests.toml:1:1: error: unsupported requests format"),
        (("deliver = [", "deliver = ["), None),
    ]
    for (old, new), message in cases:
        text = REQUESTS.replace(old, new)
        if message is None:
            assert parse_requests(text, "requests.toml", domain).usage() == "deliver(office,office)"
            continue
        with pytest.raises(RequestsError) as e:
            parse_requests(text, "requests.toml", domain)
        assert e.value.render().startswith(message), (new, e.value.render())
    with pytest.raises(RequestsError, match="invalid TOML"):
        parse_requests("format = ", "requests.toml", domain)


def test_a_request_becomes_the_events_of_its_slot(domain):
    v = vocabulary(domain)
    assert v.events(" deliver( office3 , office2 ) ", 2) == ["request(2,office3)", "address(2,office2)"]
    assert v.cancel_events(3) == ["cancel(3)"] and v.open_fluent(1).text == "pending(1)"
    assert v.slots == (1, 2, 3) and v.usage() == "deliver(office,office)"
    assert {gc.text for gc in v.event_constants()} >= {"request(1,office1)", "address(3,office4)", "cancel(2)"}
    for bad in ("", "deliver", "deliver()", "deliver(office1,office2,office3)", "deliver(office1,,office2)",
                "deliver(office1,office2", "42", "deliver(office1,office2) extra"):
        with pytest.raises(Rejected):
            v.events(bad, 1)


def test_a_binding_must_take_the_request_events_from_input(domain, tmp_path):
    from cplus.robot.online.binding import parse_binding
    from cplus.robot.serving.reactive import serve_roles
    text = ('format = "cplus.robot/1"\n[bricks.robot]\n[actions.move]\nbrick = "robot"\nbehaviour = 1\n'
            '[actions.pickup]\nbrick = "robot"\nbehaviour = 2\n[actions.deliver]\nbrick = "robot"\nbehaviour = 3\n'
            '[events.request]\nsource = "input"\n[events.address]\nsource = "input"\n[events.cancel]\n'
            'source = "inferred"\n')
    binding = parse_binding(text, str(tmp_path / "robot.toml"), domain)
    with pytest.raises(RequestsError) as e:
        serve_roles(domain, vocabulary(domain), binding)
    assert "cancel(1) is an event of the requests" in e.value.message and ":16:1" in str(e.value)
    fixed = parse_binding(text.replace('source = "inferred"', 'source = "input"'), "robot.toml", domain)
    roles = serve_roles(domain, vocabulary(domain), fixed)
    assert {gc.text for gc in roles.agent} >= {"move(office1)", "pickup(2)"} and not roles.inferred


# ---------------------------------------------------------------------------------- threads and bounds
class Blocking(GoalWatcher):
    """A watcher that holds the dispatcher until told to let go (as a client whose socket is full
    would have held the old board's lock)."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self.release = threading.Event()
        self.seen: list[tuple[int, str]] = []

    def status(self, goal, status) -> None:
        self.seen.append((goal.id, status.value))
        self.entered.set()
        assert self.release.wait(30)


def test_a_watcher_that_blocks_holds_no_client_and_no_lock(domain):
    board = GoalBoard(vocabulary(domain))
    stuck = Blocking()
    board.watch(stuck)
    board.submit("deliver(office1,office2)")
    assert stuck.entered.wait(30)                 # the dispatcher is inside the watcher
    done = threading.Event()

    def client() -> None:                         # another thread: submit, cancel, look, poll
        g = board.submit("deliver(office2,office3)")
        board.cancel(g.id)
        board.describe(g.id)
        board.poll(1)
        done.set()
    t = threading.Thread(target=client, daemon=True)
    t.start()
    assert done.wait(30), "the board waited for a watcher"
    stuck.release.set()
    assert board.drain(30)
    # and each watcher heard every change in order, with the goal as it was then
    assert stuck.seen == [(1, "pending"), (2, "pending"), (2, "recalled"), (1, "active")]
    board.close()


def test_a_watcher_may_call_back_into_the_board(domain):
    board = GoalBoard(vocabulary(domain))

    class Again(GoalWatcher):
        def __init__(self) -> None:
            self.seen: list[tuple[int, str]] = []

        def status(self, goal, status) -> None:
            self.seen.append((goal.id, status.value))
            if goal.id == 1 and status.value == "pending":
                board.cancel(board.submit("deliver(office3,office4)").id)
    w = Again()
    board.watch(w)
    board.submit("deliver(office1,office2)")
    assert board.drain(30)
    assert w.seen == [(1, "pending"), (2, "pending"), (2, "recalled")]
    board.close()


def test_open_goals_are_bounded_per_client_and_in_all(domain):
    board = GoalBoard(vocabulary(domain), limits=Limits(open_goals=5, client_goals=2, kept_final=3))
    a = [board.submit("deliver(office1,office2)", client="a") for _ in range(3)]
    assert [g.status.value for g in a] == ["pending", "pending", "rejected"]
    assert a[2].reason == ("this client has 2 goals open (at most 2 per client): send it again when one has ended")
    b = [board.submit("deliver(office1,office2)", client=c) for c in ("b", "b", "c", "d")]
    assert [g.status.value for g in b] == ["pending", "pending", "pending", "rejected"]
    assert b[3].reason == "the server has 5 goals open, its limit: send it again when one has ended"
    board.cancel(a[0].id)                         # one ends: room again, for that client too
    assert board.submit("deliver(office1,office2)", client="a").status.value == "pending"
    assert board.submit("deliver(office1,office2)").status.value == "rejected"
    # final goals are remembered up to kept_final; an older one is forgotten, not unknown
    final = [g.id for g in board.goals.values() if g.final]
    assert len(final) == 3 and a[2].id not in board.goals and board.forgotten(a[2].id)
    assert not board.forgotten(99) and board.describe(99) is None
    assert board.summary()["forgotten"] == 1


def test_a_request_is_read_in_one_pass(domain):
    v = vocabulary(domain)
    with pytest.raises(Rejected, match="cannot read"):
        v.parse("deliver" + " " * 900 + "x")         # the old regex: quadratic in the blanks
    with pytest.raises(Rejected, match="a request of 60008 characters; a request has at most 1000"):
        v.parse("deliver" + " " * 60_000 + "x")
    assert v.parse("  deliver (office1 , office2)  ")[1] == ("office1", "office2")
    with pytest.raises(Rejected, match="is not an office"):
        v.parse("deliver(office\u0663,office2)")    # an Arabic-Indic digit: not the office 3
    goal = GoalBoard(v).submit("deliver(" + "x" * 10_000_000 + ")")    # a ROS string has no length limit
    assert goal.status is GoalStatus.REJECTED and goal.request.endswith("... (10000009 characters)")
    assert len(goal.request) < 200 and "10000009 characters" in goal.reason


def test_hostile_requests_and_scripts_are_located_errors(domain):
    for arg, message in (("$" + "9" * 20, "requests.toml:6:33: error: $99999999999999999999: only $slot, $1"),
                         ("$\u00b2", "requests.toml:6:33: error: $\u00b2: only $slot, $1"),
                         ("$33", "requests.toml:6:33: error: $33: only $slot, $1, $2, ... (up to $32)")):
        with pytest.raises(RequestsError) as e:
            parse_requests(REQUESTS.replace('"address($slot,$2)"', f'"address($slot,{arg})"'), "requests.toml", domain)
        assert e.value.render().startswith(message), e.value.render()
    for text, message in (
            ('{"cycle": 1000000, "request": "x"}\n', 'script.jsonl:1:1: error: "cycle" must be an integer from 1'),
            ('{"cycle": 1000000000000000000, "cancel": 1}\n', 'script.jsonl:1:1: error: "cycle" must be an integer'),
            ('{"cycle": 1' + "0" * 5000 + ', "request": "x"}\n', "script.jsonl:1:1: error: not JSON: a number with "
                                                               "too many digits"),
            ("[" * 100_000 + "\n", "script.jsonl:1:1: error: not JSON: nested too deeply")):
        with pytest.raises(ScriptError) as e:
            parse_script(text, "script.jsonl")
        assert e.value.render().startswith(message), e.value.render()[:200]


# ---------------------------------------------------------------- the board driven by hand
# The loop's side of the board (poll, ready, wait, on_cycle, abort_all) called directly with
# cycle records made here: a state is a mapping from a goal's open fluent to "false" once done.

def record(cycle: int, state: dict | None = None, executed: tuple[str, ...] = ()) -> CycleRecord:
    return CycleRecord(cycle, 0.0, {} if state is None else state,
                       executed=[SimpleNamespace(text=a) for a in executed])


def done(board: GoalBoard, *slots) -> dict:
    return {board.vocabulary.open_fluent(s): "false" for s in slots}


class EnteredCondition(threading.Condition):
    """The loop's idle wait, which says when a thread is inside it (set under the lock, so that
    whatever the test does next with the lock happens while the thread waits)."""

    def __init__(self, lock) -> None:
        super().__init__(lock)
        self.entered = threading.Event()

    def wait(self, timeout=None):
        self.entered.set()
        return super().wait(timeout)


@pytest.mark.parametrize("how", ["cancel", "close_channel"])
def test_the_loops_idle_wait_ends_on_a_cancel_and_on_a_closed_channel(domain, how):
    board = GoalBoard(vocabulary(domain))
    board.open_channel()
    goal = board.submit("deliver(office1,office2)")
    assert board.poll(1) == ["request(1,office1)", "address(1,office2)"] and goal.status is GoalStatus.ACTIVE
    assert not board.ready(1)                     # nothing to do: the loop waits idle
    board._arrived = EnteredCondition(board._lock)
    returned = threading.Event()
    t = threading.Thread(target=lambda: (board.wait(3600), returned.set()), daemon=True)
    t.start()
    assert board._arrived.entered.wait(wall(30))
    if how == "cancel":
        board.cancel(goal.id)                     # the cancellation must reach the robot now
        assert goal.status is GoalStatus.PREEMPTING
    else:
        board.close_channel()                     # the last client left: the loop may end
    assert returned.wait(wall(30)), f"{how} left the loop in its idle wait"
    board.close()


class Counting(GoalWatcher):
    """Blocks the dispatcher on the first status until released; records everything heard."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self.release = threading.Event()
        self.seen: list[tuple] = []

    def status(self, goal, status) -> None:
        self.seen.append((goal.id, status.value))
        self.entered.set()
        assert self.release.wait(60)

    def feedback(self, goal, feedback) -> None:
        self.seen.append((goal.id, "feedback", feedback.cycle))


def test_a_full_outbox_drops_feedback_and_never_a_status(domain):
    board = GoalBoard(vocabulary(domain), limits=Limits(outbox=2))
    w = Counting()
    board.watch(w)
    g1 = board.submit("deliver(office1,office2)")
    assert w.entered.wait(wall(30))               # the dispatcher holds (1, pending): the outbox is empty
    board.poll(1)                                 # (1, active): one queued
    board.on_cycle(record(1, executed=("move(office1)",)))   # feedback: two queued, the limit
    board.on_cycle(record(2, executed=("pickup(1)",)))       # feedback beyond it: dropped
    assert board.dropped_feedback == 1
    for _ in range(3):                            # statuses beyond it: every one kept
        board.cancel(board.submit("deliver(office2,office3)").id)
    board.cancel(g1.id)
    w.release.set()
    assert board.drain(wall(30))
    assert w.seen == [(1, "pending"), (1, "active"), (1, "feedback", 1),
                      (2, "pending"), (2, "recalled"), (3, "pending"), (3, "recalled"),
                      (4, "pending"), (4, "recalled"), (1, "preempting")]
    assert board.dropped_feedback == 1
    board.close()


def test_a_goal_done_before_its_cancellation_reached_the_robot_succeeded(domain):
    """preempting -> succeeded (docs/serve.md): the robot finished the goal before the
    cancellation took effect; its cancellation is then never sent, and is no work for the loop."""
    board = GoalBoard(vocabulary(domain))
    goal = board.submit("deliver(office1,office2)")
    board.poll(1)
    board.cancel(goal.id)
    assert goal.status is GoalStatus.PREEMPTING and board.ready(2)
    board.on_cycle(record(2, done(board, 1)))     # delivered, the cancellation not yet polled
    assert goal.status is GoalStatus.SUCCEEDED and goal.done_cycle == 2 and goal.cancel_cycle is None
    assert not board.ready(3)
    assert board.poll(3) == [] and goal.cancel_cycle is None
    assert board.finished() and board.agenda() == []
    # its slot is free for the next request, whose goal no stale cancellation reaches
    nxt = board.submit("deliver(office3,office4)")
    assert board.poll(4) == ["request(2,office3)", "address(2,office4)"] and nxt.status is GoalStatus.ACTIVE
    board.close()


def test_a_cancellation_delivered_then_the_goal_done_is_preempted(domain):
    board = GoalBoard(vocabulary(domain))
    goal = board.submit("deliver(office1,office2)")
    board.poll(1)
    board.cancel(goal.id)
    assert board.poll(2) == ["cancel(1)"] and goal.cancel_cycle == 2
    assert not board.ready(3) and board.poll(3) == []          # delivered once
    board.on_cycle(record(3, done(board, 1)))
    assert goal.status is GoalStatus.PREEMPTED and goal.reason == "cancelled" and goal.done_cycle == 3


def test_aborting_frees_every_slot_and_every_client_share(domain):
    board = GoalBoard(vocabulary(domain), limits=Limits(client_goals=2))
    goals = [board.submit("deliver(office1,office2)", client="a") for _ in range(2)]
    board.poll(1)
    assert [g.slot for g in goals] == [1, 2] and len(board.agenda()) == 2
    assert board.abort_all("the server stopped (test)")
    assert [g.status for g in goals] == [GoalStatus.ABORTED] * 2
    assert board.agenda() == [] and board._by_client == {} and board._open == 0
    board.on_cycle(record(2, done(board, 1, 2)))                 # nothing in flight to close
    assert [g.status for g in goals] == [GoalStatus.ABORTED] * 2
    assert board.poll(3) == []
    board.close()


@settings(max_examples=60)
@given(st.lists(st.one_of(st.just("submit"), st.integers(1, 3)), max_size=25))
@example(["submit"] * 3 + [2, 3, "submit"])       # 2 and 3 free: the one after the last given (3) is 1, then 2
def test_slots_are_given_round_robin_from_the_one_after_the_last_given(domain, ops):
    """Each poll gives the oldest request the first free slot after the last one given
    (wrapping round), so that a slot just freed is not at once taken again. An integer op:
    that slot's goal is done (if it holds one)."""
    board = GoalBoard(vocabulary(domain))
    slots = list(board.vocabulary.slots)
    held: dict[object, object] = {}
    nxt = 0
    waiting = []
    for cycle, op in enumerate(ops, 1):
        if op == "submit":
            waiting.append(board.submit("deliver(office1,office2)"))
        elif op in held:
            board.on_cycle(record(cycle, done(board, op)))
            assert held.pop(op).status is GoalStatus.SUCCEEDED
        board.poll(cycle)
        while waiting and len(held) < len(slots):
            for i in range(len(slots)):
                slot = slots[(nxt + i) % len(slots)]
                if slot not in held:
                    break
            nxt = (nxt + i + 1) % len(slots)
            goal = waiting.pop(0)
            assert goal.slot == slot and goal.cycle == cycle
            held[slot] = goal
        assert [lit.tag for lit in board.agenda()] == sorted(g.id for g in held.values())
    board.close()


def test_ids_before_the_first_are_an_earlier_runs_and_none_is_zero(domain):
    board = GoalBoard(vocabulary(domain), first_id=5)
    assert [board.forgotten(i) for i in (-1, 0, 1, 4, 5, 6)] == [False, False, True, True, False, False]
    assert board.submit("deliver(office1,office2)").id == 5
    assert not board.forgotten(5) and board.summary() == {"pending": 1, "forgotten": 4}
    fresh = GoalBoard(vocabulary(domain))
    assert not fresh.forgotten(0) and fresh.submit("deliver(office1,office2)").id == 1


def test_the_default_limits_are_the_documented_ones():
    """docs/serve.md: 256 goals open in all, 32 per client, the last 1000 final ones remembered."""
    limits = Limits()
    assert (limits.open_goals, limits.client_goals, limits.kept_final) == (256, 32, 1000)


def test_a_long_request_is_kept_as_its_first_80_characters_and_its_length(domain):
    text = "deliver(" + "o" * 1200 + ")"
    goal = GoalBoard(vocabulary(domain)).submit(text)
    assert goal.request == text[:80] + f"... ({len(text)} characters)"


def test_the_log_is_made_durable_before_a_result_only(domain):
    """The dispatcher syncs the recorder before it tells a final status, and not for the
    others (an fsync per status would slow every client down)."""
    class Recorder(GoalRecorder):
        def __init__(self) -> None:
            self.changes: list[str] = []

        def goal_changed(self, goal) -> None:
            self.changes.append(goal.status.value)

        def sync(self) -> None:
            self.changes.append("sync")
    board = GoalBoard(vocabulary(domain))
    board.recorder = rec = Recorder()
    board.watch(GoalWatcher())
    goal = board.submit("deliver(office1,office2)")
    assert board.drain(wall(30))
    board.poll(1)
    assert board.drain(wall(30)) and rec.changes == ["pending", "active"]
    board.on_cycle(record(2, done(board, 1)))
    assert board.drain(wall(30)) and goal.status is GoalStatus.SUCCEEDED
    assert rec.changes == ["pending", "active", "succeeded", "sync"]
    board.close()


def test_the_reaction_is_timed_to_the_first_action_sent_after_the_goal_was_taken(domain):
    now = [10.0]
    board = GoalBoard(vocabulary(domain), clock=lambda: now[0])
    goal = board.submit("deliver(office1,office2)")
    now[0] = 11.0
    board.poll(3)                                  # taken at cycle 3
    board.on_act(record(2))                        # an earlier cycle's act: not its reaction
    assert goal.reaction_s is None
    now[0] = 12.5
    board.on_act(record(4))                        # the first act since (cycle 3 sent nothing)
    assert goal.reaction_s == 2.5
    now[0] = 20.0
    board.on_act(record(5))
    assert goal.reaction_s == 2.5
    board.close()
