"""`cplus online`: the command line on a simulated robot (exit statuses, progress, the
cplus.online/1 log, refusals before anything moves)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cplus.cli import main

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery"


def run(argv, capsys):
    code = main(["online", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.fixture
def delivery(tmp_path) -> Path:
    """A copy of the delivery domain and its binding (so tests may edit them)."""
    for name in ("delivery.cp", "robot.toml"):
        shutil.copy(DELIVERY / name, tmp_path / name)
    return tmp_path / "delivery.cp"


def test_simulated_run_reaches_the_goal_and_logs_every_cycle(delivery, tmp_path, capsys):
    log = tmp_path / "out" / "run.jsonl"
    code, out, err = run([str(delivery), "--simulate", "--log", str(log)], capsys)
    assert code == 2 and err == f"cplus online: error: --log {log}: no such directory {log.parent} (it is not created)\n"
    log.parent.mkdir()
    code, out, err = run([str(delivery), "--simulate", "--log", str(log)], capsys)
    assert code == 0 and out == ""
    assert "cycle 0 [" in err and "plan: 7 steps: follow, follow, turn" in err and "| send follow" in err
    assert "goal_reached: goal 'deliver' reached at cycle 7" in err
    lines = records(log)
    assert lines[0]["record"] == "start" and lines[0]["format"] == "cplus.online/1"
    assert lines[0]["goal"] == "deliver" and lines[0]["agent"] == ["follow", "lowerTray", "raiseTray", "turn"]
    cycles = [r for r in lines if r["record"] == "cycle"]
    assert [r["cycle"] for r in cycles] == list(range(8))
    for r in cycles:
        assert {"cycle", "state", "executed", "events", "sensed", "plan", "replanned", "time"} <= set(r)
        assert len(r["state"]) == 7
    assert cycles[0]["executed"] == ["follow"] and cycles[0]["plan"][0] == ["follow"]
    assert cycles[1]["sensed"] == {"atLandmark": 2}
    assert lines[-1] == {**lines[-1], "record": "end", "status": "goal_reached", "cycles": 8, "replans": 0}


def test_an_event_from_the_keyboard_file_replans(delivery, tmp_path, capsys):
    events = tmp_path / "events.txt"
    events.write_text("# someone presses the button while the robot drives to landmark 3\n@2 press\n")
    log = tmp_path / "run.jsonl"
    code, _, err = run([str(delivery), "--simulate", "--events", str(events), "--log", str(log)], capsys)
    assert code == 0
    assert "events press | replan (after press: letter(1) false -> true): 6 steps" in err
    cycles = [r for r in records(log) if r["record"] == "cycle"]
    assert cycles[2]["events"] == ["press"]
    assert cycles[2]["replanned"]["fluents"] == {"letter(1)": {"predicted": False, "observed": True}}
    assert cycles[-2]["executed"] == ["lowerTray"] and cycles[-1]["state"]["atLandmark"] == 1


def test_events_from_standard_input(delivery, capsys, monkeypatch):
    import io
    monkeypatch.setattr("sys.stdin", io.StringIO("@1 press\nhello\n"))
    code, _, err = run([str(delivery), "--simulate", "--events", "-", "--action-time", "0"], capsys)
    assert code == 0
    assert "on simulated robot (atLandmark; 0 s per action)" in err and "events press" in err


def test_typed_events_give_the_simulated_robot_time_to_type(delivery, capsys, monkeypatch):
    """The README's `--simulate --events -` example: actions of 1 s unless --action-time says
    otherwise (of 0 s the run would end before anyone typed), and the README's table says so."""
    import io
    readme = " ".join(" ".join(p.read_text(encoding="utf-8") for p in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]).split())
    assert "actions taking S seconds (default 0; 1 with `--events -`, so that there is time to type an event)" \
        in readme
    assert "cplus online domains/delivery/delivery.cp --simulate --events -    # no brick; type \"press\"" \
        in (ROOT / "docs" / "online.md").read_text()
    monkeypatch.setattr("sys.stdin", io.StringIO(""))
    code, _, err = run([str(delivery), "--simulate", "--events", "-", "--max-cycles", "0"], capsys)
    assert code == 3 and "on simulated robot (atLandmark; 1 s per action)" in err
    code, _, err = run([str(delivery), "--simulate", "--max-cycles", "0"], capsys)
    assert code == 3 and "on simulated robot (atLandmark; 0 s per action)" in err
    from cplus.cli.online import build_parser
    assert "(default 0; with --events -, 1, so that there is time to type an event)" in \
        " ".join(build_parser().format_help().split())


def test_max_cycles_is_exit_3(delivery, capsys):
    code, _, err = run([str(delivery), "--simulate", "--max-cycles", "3"], capsys)
    assert code == 3
    assert "cplus online: max_cycles: no goal after 3 cycles, the --max-cycles limit; 3 cycles ran, 0 replans, " in err


def test_the_end_line_counts_the_cycles_that_ran(delivery, capsys):
    code, _, err = run([str(delivery), "--simulate"], capsys)
    assert code == 0
    assert "cplus online: goal_reached: goal 'deliver' reached at cycle 7; 7 cycles ran, 0 replans, " in err


def test_an_unknown_goal_names_the_labels_without_a_place_in_the_file(delivery, capsys):
    code, _, err = run([str(delivery), "--simulate", "--goal", "nope"], capsys)
    assert code == 2
    assert err == "cplus online: error: --goal nope: no query with label 'nope' (this file's labels: deliver)\n"


def test_an_ambiguous_state_is_exit_7(delivery, capsys):
    robot = delivery.parent / "robot.toml"
    text = robot.read_text()
    robot.write_text(text[:text.index("# The follower counts")])
    code, _, err = run([str(delivery), "--simulate"], capsys)
    assert code == 7 and "ambiguous: the state at cycle 1 is not known: atLandmark in {2, 3}" in err


CONTRA = """
:- constants open, lamp :: inertialFluent; push, slam :: exogenousAction.
push causes open.  slam causes -open.  nonexecutable slam if -open.
:- query label :: g; maxstep :: 0..3; 0: -open & -lamp; maxstep: open & lamp.
"""

DOOR = 'format = "cplus.robot/1"\n[bricks.b]\n[actions.push]\nbrick = "b"\nbehaviour = 1\n' \
       '[events.slam]\nsource = "input"\n'


def test_a_contradiction_is_exit_5_and_names_the_observation(tmp_path, capsys):
    (tmp_path / "d.cp").write_text(CONTRA.replace("open & lamp.", "open."))
    (tmp_path / "robot.toml").write_text(DOOR)
    (tmp_path / "ev.txt").write_text("@1 slam\n")       # while the door was being pushed open
    log = tmp_path / "run.jsonl"
    code, _, err = run([str(tmp_path / "d.cp"), "--simulate", "--events", str(tmp_path / "ev.txt"),
                        "--log", str(log)], capsys)
    assert code == 6
    assert "contradicted: the model cannot explain what was observed at cycle 1: event slam" in err
    end = records(log)[-1]
    assert end["status"] == "contradicted" and end["unexplained"] == ["event slam"]
    assert end["state"] == {"open": False, "lamp": False}


def test_no_plan_is_exit_1(tmp_path, capsys):
    (tmp_path / "d.cp").write_text(CONTRA)
    (tmp_path / "robot.toml").write_text(DOOR)
    code, _, err = run([str(tmp_path / "d.cp"), "--simulate"], capsys)
    assert code == 1 and "no_plan: no plan reaches the goal 'g' from the state of cycle 0 within 3 steps" in err


@pytest.mark.parametrize("argv, message", [
    (["--goal", "nope"], "no query with label 'nope'"),
    (["--simulate", "--brick", "robot=/dev/null"], "--simulate uses no brick"),
    (["--brick", "arm=/dev/null"], "--brick arm: "),
    (["--brick", "robot"], "--brick expects NAME=PORT"),
    (["--robot", "missing.toml"], "cannot read binding file missing.toml"),
    (["--max-cycles", "-1"], "expected a non-negative integer"),
    (["--events", "missing.txt", "--simulate"], "cannot read missing.txt"),
])
def test_bad_usage_is_one_line_and_exit_2(delivery, argv, message, capsys):
    code, out, err = run([str(delivery), *argv], capsys)
    assert code == 2 and out == ""
    assert message in err and "Traceback" not in err


def test_an_event_the_input_may_not_send_is_located(delivery, tmp_path, capsys):
    ev = tmp_path / "ev.txt"
    ev.write_text("@1 press\n@2 missed\n")
    code, _, err = run([str(delivery), "--simulate", "--events", str(ev)], capsys)
    assert code == 2
    assert err.startswith(f"{ev}:2:4: error: 'missed' is not an event the input may send (those are: press)")


def test_a_bad_binding_is_located_before_anything_moves(delivery, tmp_path, capsys):
    robot = delivery.parent / "robot.toml"
    robot.write_text(robot.read_text().replace('[sensed.atLandmark]\nbrick = "robot"\nvalue = "landmark"',
                                               '[sensed.atLandmark]\nbrick = "robot"\nport = "A"'))
    log = tmp_path / "run.jsonl"
    code, _, err = run([str(delivery), "--simulate", "--log", str(log)], capsys)
    assert code == 2 and f"{robot}:" in err and "port A is a motor port" in err
    assert not log.exists()


def test_an_unbound_action_is_located_in_the_domain(delivery, capsys):
    robot = delivery.parent / "robot.toml"
    robot.write_text(robot.read_text().replace("[actions.turn]\nbrick = \"robot\"\nbehaviour = 2", ""))
    code, _, err = run([str(delivery), "--simulate"], capsys)
    assert code == 2
    assert err.startswith(f"{delivery}:") and "action 'turn' has no binding" in err


def test_no_binding_file_is_one_line(tmp_path, capsys):
    (tmp_path / "d.cp").write_text(CONTRA)
    code, _, err = run([str(tmp_path / "d.cp"), "--simulate"], capsys)
    assert code == 2 and "no robot.toml (or scene.toml) beside" in err


def test_a_brick_that_cannot_be_opened_is_exit_7(delivery, tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    code, _, err = run([str(delivery), "--brick", f"robot={tmp_path / 'rfcomm9'}", "--log", str(log)], capsys)
    assert code == 8 and "robot_lost: brick robot:" in err
    assert [r["record"] for r in records(log)] == ["start", "end"]


@pytest.mark.slow
def test_the_delivery_domain_alone_runs_on_its_emulated_world(tmp_path, capsys):
    """`cplus online domains/delivery/delivery.cp`: the emulated brick in world.toml (on
    simulated time), a button press on the way and a re-plan, to the goal."""
    log = tmp_path / "run.jsonl"
    code, _, err = run([str(DELIVERY / "delivery.cp"), "--no-latency", "--log", str(log)], capsys)
    assert code == 0, err
    assert "emulated NXT bricks robot" in err and "events press" in err and "replan (after press" in err
    lines = records(log)
    cycles = [r for r in lines if r["record"] == "cycle"]
    assert any(r["events"] == ["press"] for r in cycles)
    assert lines[-1]["status"] == "goal_reached" and lines[-1]["replans"] >= 1
    assert cycles[-1]["state"]["atLandmark"] == 1 and not any(
        v for k, v in cycles[-1]["state"].items() if k.startswith("letter"))
    assert [r["sensed"].get("atLandmark") for r in cycles if r["sensed"]] == [2, 3, 2, 1]


@pytest.mark.slow
def test_a_brick_given_by_its_port(tmp_path, capsys):
    """--brick robot=PTY: a brick served on a pseudo-terminal by another party (here, in the
    test; `cplus brick --world world.toml` does the same as a process)."""
    from cplus.robot.online.world_file import load_world
    from nxt_link import BrickEmulator, EmulatorConfig, LinkParams, PtyBrickServer, SimClock
    spec = load_world(DELIVERY / "world.toml")
    # served on a simulated clock, which `cplus online` finds behind the port and waits on
    server = PtyBrickServer(BrickEmulator(EmulatorConfig(name="robot", world=spec, link=LinkParams.instant())),
                            clock=SimClock())
    server.start()
    try:
        code, _, err = run([str(DELIVERY / "delivery.cp"), "--brick", f"robot={server.path}"], capsys)
    finally:
        server.stop()
    assert code == 0, err
    assert f"NXT bricks robot={server.path}" in err and "goal_reached" in err


def test_a_missing_world_is_located_before_anything_moves(delivery, capsys):
    code, _, err = run([str(delivery)], capsys)
    robot = delivery.parent / "robot.toml"
    assert code == 2 and err.startswith(f"{robot}:7:1: error: no world file")
