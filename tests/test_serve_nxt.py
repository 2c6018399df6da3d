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
