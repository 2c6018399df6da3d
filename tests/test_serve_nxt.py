"""``cplus serve --robot``: the mail robot on the emulated NXT delivery robot (the Legolog
behaviour program on a brick emulated over a pseudo-terminal, in its line-track world),
on simulated time."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

from walltime import wall

ROOT = Path(__file__).resolve().parent.parent
MAILBOT = ROOT / "domains" / "mailbot"


def serve(robot: Path, log: Path, script: Path = MAILBOT / "table1.jsonl") -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "line.cp"), "--robot", str(robot),
                           "--script", str(script), "--no-latency", "--log", str(log)],
                          capture_output=True, text=True, timeout=wall(300))


def test_the_papers_scenario_on_the_emulated_nxt_robot(tmp_path):
    log = tmp_path / "run.jsonl"
    r = serve(MAILBOT / "robot.toml", log)
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert lines[0]["executor"] == "emulated NXT bricks robot (world mailbot)"
    cycles = [x for x in lines if x["record"] == "cycle"]
    # the same cycles as Table I, in the line robot's actions: two offices up, the cancellation,
    # a wait, then the second package picked up at cycle 4 and delivered one office further
    assert [x["executed"] for x in cycles] == [[], ["follow"], ["follow"], [], ["pickup(2)"], ["follow"],
                                               ["deliver(2)"], []]
    assert [x["sensed"] for x in cycles] == [{}, {}, {"at": "office2"}, {"at": "office3"}, {}, {}, {"at": "office4"}, {}]
    assert [(g["id"], g["status"]) for g in lines[-1]["goals"]] == [(1, "preempted"), (2, "succeeded")]


def test_an_office_the_follower_misses_is_inferred_and_the_goal_still_served(tmp_path):
    for name in ("robot.toml", "world.toml"):
        shutil.copy(MAILBOT / name, tmp_path / name)
    world = tmp_path / "world.toml"
    world.write_text(world.read_text().replace("number = 2\nat_mm = 1400\n", "number = 2\nat_mm = 1400\nmisses = 1\n"))
    script = tmp_path / "script.jsonl"
    script.write_text('{"cycle": 1, "request": "deliver(office2,office1)"}\n')
    log = tmp_path / "run.jsonl"
    r = serve(tmp_path / "robot.toml", log, script)
    assert r.returncode == 0, r.stderr
    cycles = [json.loads(x) for x in log.read_text().splitlines() if '"record":"cycle"' in x]
    # the first follow ends at office3 (office2 missed): re-planned from there, back to office2
    assert cycles[2]["sensed"] == {"at": "office3"} and cycles[2]["inferred"] == ["missed"]
    assert cycles[2]["replanned"]["reason"] == "diverged"
    assert [x["executed"] for x in cycles] == [[], ["follow"], ["turn"], ["follow"], ["pickup(1)"], ["follow"],
                                               ["deliver(1)"], []]
    assert json.loads(log.read_text().splitlines()[-1])["goals"][0]["status"] == "succeeded"


def test_preempt_stop_halts_the_follow_and_plans_on_from_between_two_offices():
    """--preempt stop on the emulated robot (simulated time): a package on board is cancelled
    1 s into a follow; the brick is told to ABORT within 100 ms of simulated time, the follow
    counts with the event halted (the robot stands between office2 and office3), and the robot
    turns, follows back to office3 and hands the package back where it was taken."""
    import threading

    from cplus.api import Domain
    from cplus.robot.online import NxtExecutor, Observer, OnlineStatus, load_binding
    from cplus.robot.serving.reactive import Server, ServerSettings
    from cplus.robot.serving.vocabulary import load_requests

    domain = Domain.load(str(MAILBOT / "line.cp"))
    binding = load_binding(str(MAILBOT / "robot.toml"), domain)
    server = Server(domain, load_requests(str(MAILBOT / "requests.toml"), domain), ServerSettings(preempt="stop"),
                    binding=binding, executor=lambda model: NxtExecutor(model, binding, latency=True))
    executor = server.executor
    assert isinstance(executor, NxtExecutor)
    asked: list[float] = []
    stopped: list[float] = []                      # when both wheels' motors were at power 0 again

    def cancel_later() -> None:
        from nxt_link.emulator.world import _drive
        world = executor.servers["robot"].emulator.world   # type: ignore[attr-defined]
        step = world.step

        def watched(fw) -> None:                   # the world's millisecond, on the bricks' clock
            step(fw)
            ports = world.spec.ports
            if asked and not stopped and all(_drive(fw.outputs[p]) == 0 for p in (ports.left, ports.right)):
                stopped.append(executor.clock.now())
        world.step = watched
        executor.clock.sleep(1.0)                  # simulated time, one second into the follow
        asked.append(executor.clock.now())
        server.board.cancel(1)

    class CancelOnTheWayBack(Observer):
        started = False

        def on_act(self, record) -> None:
            if not self.started and record.executed and record.executed[0].text == "follow" \
                    and record.state.value("phase(1)") == "carried":
                self.started = True
                threading.Thread(target=cancel_later, daemon=True).start()
    server.loop.observers.append(CancelOnTheWayBack())
    goal = server.board.submit("deliver(office3,office1)")
    result = server.run()
    assert result.status is OnlineStatus.GOAL_REACHED, result.message
    assert goal.status.value == "preempted"
    executed = [[a.text for a in r.executed] for r in result.records]
    k = next(i for i, r in enumerate(result.records) if any("stopped part-way" in n for n in r.notes))
    assert executed[k] == ["follow"] and ["pickup(1)"] in executed[:k] and ["turn"] in executed[:k]
    after = result.records[k + 1]
    assert after.events == ["halted", "cancel(1)"]
    assert after.state.value("between") == "true" and after.state.value("at") == "office2"
    assert after.state.value("dest(1)") == "office3"                 # it goes back where it was taken
    assert executed[k + 1:] == [["turn"], ["follow"], ["deliver(1)"], []]
    assert result.records[k + 2].state.value("facing") == "up"
    assert result.records[k + 3].sensed and result.records[k + 3].state.value("at") == "office3"
    # the motors were at power 0 within 100 ms of simulated time of the cancellation (the brick
    # acknowledged the ABORT a little later: Bluetooth's turnaround)
    assert 0 <= stopped[0] - asked[0] <= 0.1, (asked, stopped, executor.stopped_at)
    assert executor.stopped_at is not None and executor.stopped_at >= stopped[0]
