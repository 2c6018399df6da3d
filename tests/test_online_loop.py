"""The online loop (cplus.robot.online.loop) on a simulated robot, on simulated time: scripted
events (a button press mid-run, a landmark missed), a contradicting observation, a lost robot,
ambiguity, no plan, idle waiting for a standing goal, the cycle limit, stop()."""
from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from walltime import wall

from cplus.api import Domain
from cplus.robot.online.estimation import OnlineModel, Roles
from cplus.robot.online.events import EventsError, LineEvents, ScriptedEvents, check_events, parse_events
from cplus.robot.online.executors import SimulatedExecutor
from cplus.robot.online.loop import Observer, OnlineLoop, OnlineStatus, RunResult
from nxt_link.wire.clock import VirtualClock

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery" / "delivery.cp"


@pytest.fixture(scope="module")
def model() -> OnlineModel:
    d = Domain.load(str(DELIVERY))
    return OnlineModel(d, "deliver", Roles.of(d, observed=["press"], inferred=["missed"]))


def simulate(model, clock=None, **kw) -> SimulatedExecutor:
    kw.setdefault("sensed", {"atLandmark": ["follow"]})
    kw.setdefault("durations", {"follow": 3.0})
    kw.setdefault("default_s", 1.0)
    return SimulatedExecutor(model, clock=clock or VirtualClock(), **kw)


class Recorder(Observer):
    def __init__(self) -> None:
        self.events: list[tuple] = []

    def on_start(self, loop) -> None:
        self.events.append(("start",))

    def on_act(self, record) -> None:
        self.events.append(("act", record.cycle, [a.text for a in record.executed]))

    def on_cycle(self, record) -> None:
        self.events.append(("cycle", record.cycle, json.loads(json.dumps(record.to_json()))))

    def on_end(self, result: RunResult) -> None:
        self.events.append(("end", result.status))


def run(model, executor, **kw) -> tuple[RunResult, Recorder]:
    rec = Recorder()
    clock = executor.clock
    result = OnlineLoop(model, executor, observers=[rec], clock=clock, **kw).run()
    return result, rec


def executed(result: RunResult) -> list[list[str]]:
    return [[a.text for a in r.executed] for r in result.records]


def test_an_undisturbed_run_follows_its_first_plan(model):
    result, rec = run(model, simulate(model))
    assert result.status is OnlineStatus.GOAL_REACHED
    assert executed(result) == [["follow"], ["follow"], ["turn"], ["lowerTray"], ["raiseTray"], ["follow"],
                                ["follow"], []]
    assert result.replans == 0 and result.records[0].replanned.reason == "start"
    assert result.state.value("atLandmark") == 1 and result.state.value("letter(3)") == "false"
    # the log's times are the simulated clock: 4 follows of 3 s and 3 other actions of 1 s
    assert [r.time for r in result.records] == [0, 3, 6, 7, 8, 9, 12, 15]
    assert rec.events[0] == ("start",) and rec.events[-1] == ("end", OnlineStatus.GOAL_REACHED)
    acts = [e for e in rec.events if e[0] == "act"]
    assert [e[2] for e in acts] == executed(result)[:-1]


def test_grounding_happens_once_per_run(monkeypatch):
    import cplus.api
    import cplus.sat.horizon
    import cplus.sat.templates
    calls = {"ground": 0, "templates": 0}

    def counting(name, fn):
        def wrapper(*a, **kw):
            calls[name] += 1
            return fn(*a, **kw)
        return wrapper
    monkeypatch.setattr(cplus.api, "ground_program", counting("ground", cplus.api.ground_program))
    monkeypatch.setattr(cplus.sat.templates, "build_templates",
                        counting("templates", cplus.sat.templates.build_templates))
    monkeypatch.setattr(cplus.sat.horizon, "build_templates", counting("templates", cplus.sat.horizon.build_templates))
    d = Domain.load(str(DELIVERY))
    m = OnlineModel(d, "deliver", Roles.of(d, observed=["press"], inferred=["missed"]))
    result, _ = run(m, simulate(m, events={1: ["press"], 5: ["missed"]}))
    assert result.status is OnlineStatus.GOAL_REACHED and result.replans == 2
    assert calls == {"ground": 1, "templates": 1}


def test_each_record_holds_the_plan_it_executed_from(model):
    result, _ = run(model, simulate(model))
    for r in result.records:
        line = r.to_json()
        assert set(line) >= {"cycle", "state", "executed", "events", "sensed", "plan", "replanned"}
        assert line["plan"][:1] == ([line["executed"]] if line["executed"] else [])
    assert result.records[1].to_json()["sensed"] == {"atLandmark": 2}
    assert result.records[-1].to_json()["plan"] == []


def test_a_button_press_mid_run_replans_with_the_new_letter(model):
    result, _ = run(model, simulate(model, events={1: ["press"]}))
    assert result.status is OnlineStatus.GOAL_REACHED
    r2 = result.records[2].to_json()
    assert r2["events"] == ["press"]
    assert r2["replanned"] == {"reason": "event", "events": ["press"],
                               "fluents": {"letter(1)": {"predicted": False, "observed": True}}}
    assert result.replans == 1
    # the letter for the mailroom is delivered there: the last action lowers the tray at 1
    assert executed(result)[-2] == ["lowerTray"] and result.state.value("letter(1)") == "false"
    assert result.records[-2].state.value("atLandmark") == 1


def test_a_missed_landmark_is_inferred_and_replanned(model):
    # cycle 5 is the first follow back from landmark 3: the follower drives past 2
    result, _ = run(model, simulate(model, events={5: ["missed"]}))
    assert result.status is OnlineStatus.GOAL_REACHED
    r6 = result.records[6].to_json()
    assert r6["inferred"] == ["missed"] and r6["events"] == []
    assert r6["replanned"]["reason"] == "diverged"
    assert r6["replanned"]["fluents"] == {"atLandmark": {"predicted": 2, "observed": 1}}
    assert r6["plan"] == []                      # already home: one follow saved
    assert len(result.records) == 7


def test_a_contradicting_observation_stops_and_names_it(model):
    ex = simulate(model, readings={0: {"atLandmark": 4}})
    result, _ = run(model, ex)
    assert result.status is OnlineStatus.CONTRADICTED
    assert result.unexplained == ["sensed atLandmark=4"]
    assert "sensed atLandmark=4" in result.message and "cycle 1" in result.message
    last = result.records[-1].to_json()
    assert last["state"] is None and last["plan"] is None and last["executed"] == []
    assert result.state.value("atLandmark") == 1          # the last state known


def test_a_failed_action_stops_the_run(model):
    result, _ = run(model, simulate(model, failures={1: "stuck"}))
    assert result.status is OnlineStatus.CONTRADICTED
    assert result.message == "follow failed at cycle 1: stuck"
    assert result.records[1].failure == "stuck"


class Aborts(SimulatedExecutor):
    aborted = 0
    closed = 0

    def abort(self) -> None:
        self.aborted += 1

    def close(self) -> None:
        self.closed += 1


def test_a_lost_robot_stops_the_run_and_aborts(model):
    ex = Aborts(model, sensed={"atLandmark": ["follow"]}, lost_at=2, clock=VirtualClock())
    result, _ = run(model, ex)
    assert result.status is OnlineStatus.ROBOT_LOST
    assert "no answer at cycle 2" in result.message
    assert executed(result) == [["follow"], ["follow"], ["turn"]]
    assert result.records[-1].failure and ex.aborted == 1 and ex.closed == 1


def test_a_goal_reached_does_not_abort(model):
    ex = Aborts(model, sensed={"atLandmark": ["follow"]}, clock=VirtualClock())
    result, _ = run(model, ex)
    assert result.status is OnlineStatus.GOAL_REACHED and ex.aborted == 0 and ex.closed == 1


def test_without_sensing_the_state_becomes_ambiguous(model):
    result, _ = run(model, simulate(model, sensed={}))
    assert result.status is OnlineStatus.AMBIGUOUS
    assert {gc.text: sorted(v) for gc, v in result.open.items()} == {"atLandmark": [2, 3]}
    assert "atLandmark in {2, 3}" in result.message


def test_no_plan_from_the_observed_state_ends_the_run():
    d = Domain.from_text("""
:- constants broken, ready, done :: inertialFluent; prep, work, smash :: exogenousAction.
prep causes ready.  work causes done.  smash causes broken.
nonexecutable work if -ready.  nonexecutable work if broken.
:- query label :: g; maxstep :: 0..4; 0: -done & -ready & -broken; maxstep: done.""")
    m = OnlineModel(d, "g", Roles.of(d, observed=["smash"]))
    result, _ = run(m, SimulatedExecutor(m, events={0: ["smash"]}, clock=VirtualClock()))
    assert result.status is OnlineStatus.NO_PLAN
    assert result.message == "no plan reaches the goal 'g' from the state of cycle 1 within 4 steps"
    last = result.records[-1].to_json()
    assert last["events"] == ["smash"] and last["plan"] is None and last["state"]["broken"] is True
    assert last["replanned"]["reason"] == "event"


LAMP = """
:- constants pending, lit :: inertialFluent; serve, request :: exogenousAction.
request causes pending.  serve causes -pending & lit.
nonexecutable serve if -pending.
:- query label :: idle; maxstep :: 0..5; 0: -pending & -lit; maxstep: -pending."""


def test_a_standing_goal_waits_for_scripted_requests():
    d = Domain.from_text(LAMP)
    m = OnlineModel(d, "idle", Roles.of(d, observed=["request"]))
    script = ScriptedEvents(parse_events("@2 request\n@5 request\n", "script.txt"))
    clock = VirtualClock()
    loop = OnlineLoop(m, SimulatedExecutor(m, default_s=1.0, clock=clock), [script], when_done="wait", clock=clock)
    result = loop.run()
    assert result.status is OnlineStatus.GOAL_REACHED and "no more events" in result.message
    assert executed(result) == [[], [], ["serve"], [], [], ["serve"], []]
    assert [r.events for r in result.records] == [[], [], ["request"], [], [], ["request"], []]
    assert result.records[2].replanned.reason == "event"


def test_an_idle_loop_waits_for_a_line_typed_later():
    d = Domain.from_text(LAMP)
    m = OnlineModel(d, "idle", Roles.of(d, observed=["request"]))
    read_fd, write_fd = os.pipe()
    reader = open(read_fd, encoding="utf-8")
    writer = open(write_fd, "w", encoding="utf-8")
    source = LineEvents(reader, ["request"])
    clock = VirtualClock()
    loop = OnlineLoop(m, SimulatedExecutor(m, clock=clock), [source], when_done="wait", clock=clock,
                      idle_poll_s=0.01)
    out: list[RunResult] = []
    t = threading.Thread(target=lambda: out.append(loop.run()))
    t.start()
    writer.write("requst\nrequest\n")
    writer.flush()
    writer.close()
    t.join(timeout=wall(20))
    assert not t.is_alive()
    result = out[0]
    assert result.status is OnlineStatus.GOAL_REACHED
    assert ["serve"] in executed(result)
    notes = [n for r in result.records for n in r.notes]
    assert any("'requst' is not an event" in n for n in notes)


def test_the_log_writes_every_record_and_takes_annotations(model):
    import io

    from cplus.robot.online.loop import JsonLinesLog
    out = io.StringIO()
    log = JsonLinesLog(out, {"who": "test"}, annotate=lambda rec, line: line.update(goals=[rec.cycle]))
    ex = simulate(model)
    result = OnlineLoop(model, ex, observers=[log], clock=ex.clock).run()
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    assert [x["record"] for x in lines] == ["start"] + ["cycle"] * len(result.records) + ["end"]
    assert lines[0]["who"] == "test" and lines[0]["format"] == "cplus.online/1"
    assert [x["goals"] for x in lines[1:-1]] == [[r.cycle] for r in result.records]
    assert lines[-1]["status"] == "goal_reached"


def test_max_cycles_stops_before_acting(model):
    result, _ = run(model, simulate(model), max_cycles=2)
    assert result.status is OnlineStatus.MAX_CYCLES
    assert executed(result) == [["follow"], ["follow"], []]
    result0, _ = run(model, simulate(model), max_cycles=0)
    assert executed(result0) == [[]] and result0.records[0].plan.length == 7


def test_stop_ends_the_run_between_cycles(model):
    class StopAt2(Observer):
        def __init__(self, loop_ref: list) -> None:
            self.loop_ref = loop_ref

        def on_cycle(self, record) -> None:
            if record.cycle == 2:
                self.loop_ref[0].stop()
    ref: list = []
    ex = simulate(model)
    loop = OnlineLoop(model, ex, observers=[StopAt2(ref)], clock=ex.clock)
    ref.append(loop)
    result = loop.run()
    assert result.status is OnlineStatus.STOPPED and len(result.records) == 4


@settings(max_examples=25)
@given(presses=st.sets(st.integers(0, 8), max_size=3), misses=st.sets(st.integers(0, 8), max_size=2))
def test_the_estimate_tracks_the_simulated_world(model, presses, misses):
    """Whatever presses and misses happen, the loop's state is the simulated world's state at
    every cycle, executed steps are those of the plan of their cycle, and the goal is reached
    unless the world was asked to do the impossible (a miss past the last landmark)."""
    events = {c: ["press"] for c in presses}
    for c in misses:
        events.setdefault(c, []).append("missed")
    ex = simulate(model, events=events)
    result, _ = run(model, ex)
    assert result.status in (OnlineStatus.GOAL_REACHED, OnlineStatus.CONTRADICTED)
    if result.status is OnlineStatus.CONTRADICTED:
        assert "simulated world cannot" in result.message
        return
    world = {cycle: state for cycle, _, state in ex.log}
    for r in result.records[1:]:
        assert r.state == world[r.cycle - 1]
    for r in result.records:
        assert [a.text for a in r.executed] == (r.plan.texts()[0] if r.plan.length else [])
    assert all(result.state.value(f"letter({n})") == "false" for n in range(1, 5))


def test_event_files_are_parsed_with_cycles():
    lines = parse_events("# header\n@3 press  # a comment\nrequest(office3,office2) cancel(1)\n\n", "ev.txt")
    assert [(e.cycle, e.events) for e in lines] == [(3, ("press",)), (None, ("request(office3,office2)", "cancel(1)"))]
    source = ScriptedEvents(lines)
    assert source.poll(1) == ["request(office3,office2)", "cancel(1)"]
    assert source.poll(2) == [] and source.waiting(2) and source.poll(3) == ["press"] and source.finished()


@pytest.mark.parametrize("text, message, where", [
    ("@0 press\n", "a cycle is written @N with N a whole number from 1", "ev.txt:1:1"),
    ("press @3\n", "'@N' must come first", "ev.txt:1:7"),
    ("\n@2\n", "no event after '@2'", "ev.txt:2:1"),
    ("@2 Press\n", "'Press' is not an event", "ev.txt:1:4"),
])
def test_event_file_errors_are_located(text, message, where):
    with pytest.raises(EventsError, match=message) as info:
        parse_events(text, "ev.txt")
    assert info.value.render().startswith(where + ": error:")


def test_unknown_events_are_located():
    lines = parse_events("@1 press\n@2  prss\n", "ev.txt")
    with pytest.raises(EventsError, match="'prss' is not an event the input may send") as info:
        check_events(lines, ["press"])
    assert info.value.render().startswith("ev.txt:2:5: error:")
