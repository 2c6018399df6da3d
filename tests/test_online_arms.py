"""Monitoring the payload arms (cplus.robot.online.payload_monitor): a stalled motor is seen through
the tracking error, both bricks stop, the arms are mapped to the nearest grid state and the rest
is re-planned with the refinement loop; on emulated bricks in memory (virtual clock) and, end
to end, through `cplus online` on pseudo-terminals."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import cplus.robot.online.payload_monitor as pm
from cplus.cli import main
from cplus.robot import RobotTask
from cplus.robot.offline.refine import RefineStatus
from cplus.robot.online.estimation import OnlineModel, Roles
from cplus.robot.online.loop import OnlineStatus, RunResult
from nxt_link import BrickEmulator, EmulatorConfig, LinkParams
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.stall import Stall
from nxt_link.wire.clock import VirtualClock

ROOT = Path(__file__).resolve().parent.parent
PAYLOAD = ROOT / "domains" / "payload"


@pytest.fixture(scope="module")
def task() -> RobotTask:
    return RobotTask.load(str(PAYLOAD / "payload.cp"), str(PAYLOAD / "scene.toml"))


class Arms:
    """Two emulated arm bricks in memory on one virtual clock, r1 with the given stalls.

    A stall is seen only when the motor should be moving: ``A@4.5+1`` holds r1's carriage
    during the first plan's long moves (59 degrees of tracking error against the threshold's
    30).  Another first plan of the same length (the planner's encoding changes which one the
    solver meets first) may need other times."""

    def __init__(self, *stalls: str) -> None:
        self.clock = VirtualClock()
        self.emus = {n: BrickEmulator(EmulatorConfig(name=n, link=LinkParams.instant(),
                                                     stalls=tuple(Stall.parse(s) for s in stalls) if n == "r1" else ()))
                     for n in ("r1", "r2")}
        self.executor = pm.ArmsExecutor(["r1", "r2"], transports={n: MemoryTransport(e, self.clock)
                                                                  for n, e in self.emus.items()})

    def run(self, task, **kw) -> RunResult:
        return pm.run_arms(task, "0", self.executor, clock=self.clock, **kw)


def assert_stopped(arms: Arms) -> None:
    """Both bricks' programs stopped and every motor released, a second later."""
    for emu in arms.emus.values():
        emu.advance_to(emu.now_ms + 1000)
        assert emu.firmware.program is None
        assert all(o.power == 0 for o in emu.firmware.outputs)


def positions(state) -> dict[str, object]:
    return {k: v for k, v in state.text().items() if k.startswith(("xpos", "ypos"))}


def test_without_a_fault_the_first_plan_runs_to_the_goal(task):
    result = Arms().run(task)
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    assert [r.cycle for r in result.records] == [0, 9]
    assert result.records[0].failure is None and result.records[0].plan.length == 9
    assert positions(result.state) == {"xpos(r1)": 10, "ypos(r1)": 0, "xpos(r2)": 10, "ypos(r2)": 5}
    # the final angles were read and mapped: they are the goal state's
    assert result.records[1].to_json()["sensed"] == {"xpos(r1)": 10, "ypos(r1)": 0, "xpos(r2)": 10, "ypos(r2)": 5}


def test_a_stall_is_seen_mapped_to_the_grid_and_replanned(task):
    result = Arms("A@4.5+1").run(task)
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    first, again = result.records[0], result.records[1]
    assert first.failure and first.failure.startswith("robot r1 motor A:") and "threshold 30" in first.failure
    assert 0 < len(first.executed) < len(first.plan.steps[1]) * 9      # stopped part-way
    assert again.replanned.reason == "fault" and again.cycle == first.cycle + len(
        [s for s in first.plan.steps[:again.cycle]])
    assert set(again.raw) == {f"{r}.{p}" for r in ("r1", "r2") for p in "ABC"}
    assert again.plan.length < first.plan.length                       # only the rest
    assert positions(result.state) == {"xpos(r1)": 10, "ypos(r1)": 0, "xpos(r2)": 10, "ypos(r2)": 5}
    assert result.replans == 1


def test_a_motor_stalled_for_good_stops_the_arms_safely(task):
    arms = Arms("A@3")
    result = arms.run(task)
    assert result.status is OnlineStatus.CONTRADICTED
    assert "could not run the plan" in result.message and "initial configuration" in result.message
    assert result.records[0].failure.startswith("robot r1 motor A:")
    assert_stopped(arms)


def test_no_plan_from_where_the_arms_are_stops_safely(task, monkeypatch):
    real = pm.refine
    calls = []

    def refine_then_nothing(*a, **kw):
        calls.append(1)
        result = real(*a, **kw)
        if len(calls) > 1:
            result.status, result.history, result.reason = RefineStatus.NO_PLAN, None, "no plan with maxstep 0..40"
        return result
    monkeypatch.setattr(pm, "refine", refine_then_nothing)
    arms = Arms("A@4.5+1")
    result = arms.run(task)
    assert result.status is OnlineStatus.NO_PLAN
    assert result.message.startswith(f"stopped safely at cycle {result.records[-1].cycle}: no plan")
    assert result.records[-1].plan is None and result.records[-1].replanned.reason == "fault"
    assert_stopped(arms)


def test_too_many_faults_give_up(task):
    result = Arms("A@4.5+1").run(task, max_faults=0)
    assert result.status is OnlineStatus.CONTRADICTED and "failed to follow 1 times" in result.message


def test_the_nearest_grid_state_moves_held_ends_with_their_robots(task):
    model = OnlineModel(task.domain, "0", Roles.of(task.domain))
    s0 = model.initial_state().state
    plan = model.plan(s0)
    # mid-way through a carrying step: robots between the states of step 3 and 4
    before, after = plan.states[3], plan.states[4]
    r1 = (before.value("xpos(r1)") + 0.3, before.value("ypos(r1)") + 0.1)
    r2 = (before.value("xpos(r2)") + 0.4, before.value("ypos(r2)") - 0.2)
    state, points = pm.nearest_grid_state(task, model, before, after, {"r1": r1, "r2": r2})
    assert points == {"r1": (round(r1[0]), round(r1[1])), "r2": (round(r2[0]), round(r2[1]))}
    for robot, end in (("r1", "pl1"), ("r2", "pl2")):
        if before.value(f"on({robot},{end})") == "true":
            assert (state.value(f"xpay({end})"), state.value(f"ypay({end})")) == points[robot]
    assert state.value("cost") == after.value("cost")                  # the interrupted step was paid for


def test_the_monitor_aligns_the_motors_of_a_brick_on_one_tick():
    class Reply:
        def __init__(self, deg: int) -> None:
            self.rotation_count = deg

    class Brick:
        def __init__(self, angles) -> None:
            self.angles = angles

        def get_output_state(self, port: int) -> Reply:
            return Reply(self.angles[port])
    from nxt_link import Progress, SetpointStream
    rows = tuple((10 * k, 5 * k) for k in range(20))
    stream = SetpointStream("r1", ("A", "B"), 100, rows)
    late = pm.TrackingMonitor([stream], {"r1": Brick([80, 40])})           # at tick 8, reported at 5
    late(Progress("r1", "run", 5, 20))
    assert late.worst["r1"] == 0
    stuck = pm.TrackingMonitor([stream], {"r1": Brick([30, 60])})          # A at tick 3, B at tick 12
    with pytest.raises(pm.TrackingFault) as info:
        stuck(Progress("r1", "run", 10, 20))
    assert info.value.robot == "r1" and info.value.port in ("A", "B") and info.value.error_deg > 30


@pytest.mark.slow
def test_the_stall_scenario_end_to_end(tmp_path, capsys):
    """`cplus online` on the payload task, emulated bricks on ptys, r1's motor A held for 2 s
    while the carriage moves (102 degrees of tracking error against the threshold's 30)."""
    log = tmp_path / "arms.jsonl"
    code = main(["online", str(PAYLOAD / "payload.cp"), "--no-latency",          # simulated time
                 "--stall", "r1:A@4+2", "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "robot r1 motor A:" in err and "replan (fault" in err and "goal_reached" in err
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert lines[0]["record"] == "start" and lines[0]["scene"].endswith("scene.toml")
    cycles = [x for x in lines if x["record"] == "cycle"]
    assert cycles[0]["failure"].startswith("robot r1 motor A:")
    assert cycles[1]["replanned"]["reason"] == "fault"
    assert lines[-1]["status"] == "goal_reached" and lines[-1]["replans"] >= 1


@pytest.mark.parametrize("argv, message", [
    (["--events", "x.txt"], "--events has no meaning for the arms of a robot task"),
    (["--stall", "r3:A@1"], "--stall expects ROBOT:PORT@SECONDS"),
    (["--stall", "r1:D@1"], "--stall: expected PORT@SECONDS"),
    (["--stall", "r1:A@1", "--brick", "r1=/dev/null", "--brick", "r2=/dev/null"], "--stall needs emulated bricks"),
    (["--brick", "r1=/dev/null"], "no --brick for robot 'r2'"),
])
def test_arms_usage_errors(argv, message, capsys):
    code = main(["online", str(PAYLOAD / "payload.cp"), *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err


@pytest.mark.slow
def test_the_readmes_stall_example_reaches_the_goal(tmp_path, capsys):
    """`cplus online domains/payload/payload.cp --stall r1:A@2+1 --log arms.jsonl` as printed
    (Bluetooth timing, simulated time). The bricks used to go on with the old trajectory after
    the fault, so the angles read were not where the arms stood when the new plan started
    (motor B 119 degrees from its start: contradicted, with 22 actions logged as executed that
    never ran). Now they stop at the fault, are braked, and are read standing still."""
    log = tmp_path / "arms.jsonl"
    code = main(["online", str(PAYLOAD / "payload.cp"), "--stall", "r1:A@2+1", "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 0, err
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    cycles = [x for x in lines if x["record"] == "cycle"]
    assert cycles[0]["failure"].startswith("robot r1 motor A:") and cycles[1]["replanned"]["reason"] == "fault"
    assert all(x["failure"] is None for x in cycles[1:])
    assert lines[-1]["status"] == "goal_reached"


def test_a_plan_refused_before_anything_moved_logs_nothing_as_executed(task, monkeypatch):
    from nxt_link.wire.errors import SetpointError

    def refuse(*a, **kw):
        raise SetpointError("brick r1 motor B stands at 461 deg, the trajectory starts at 342 deg")
    monkeypatch.setattr(pm.nxt_link, "execute_streams", refuse)
    result = Arms().run(task)
    assert result.status is OnlineStatus.CONTRADICTED
    assert result.records[-1].failure.startswith("brick r1 motor B") and result.records[-1].executed == []
