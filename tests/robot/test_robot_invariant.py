"""``maxstep :: any`` on a robot task: the invariant is over the domain's fluents, the proof
runs on the task's grounding (its scene's externals included), and the command prints it
and exits as for a plain domain (10 proved, 11 wrong) instead of refining."""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from tiny_scene import DOMAIN, tiny_scene  # noqa: E402

from cplus.cli import main  # noqa: E402

HELD = """
:- query label :: held; maxstep :: any;
  invariant: on(r1,pl1) & on(r2,pl2);
  0: xpos(r1)=0, ypos(r1)=0, xpos(r2)=0, ypos(r2)=2,
     xpay(pl1)=0, ypay(pl1)=0, xpay(pl2)=0, ypay(pl2)=2;
  maxstep: -on(r1,pl1).
:- query label :: loose; maxstep :: any;
  invariant: xpos(r1)=0;
  0: xpos(r1)=0, ypos(r1)=0, xpos(r2)=0, ypos(r2)=2,
     xpay(pl1)=0, ypay(pl1)=0, xpay(pl2)=0, ypay(pl2)=2;
  maxstep: xpos(r1)=3.
"""


def task(tmp_path: Path) -> Path:
    d = tmp_path / "task"
    d.mkdir()
    (d / "tiny.cp").write_text(DOMAIN.read_text() + HELD)
    (d / "scene.toml").write_text(tiny_scene([]))
    return d / "tiny.cp"


def test_a_robot_task_proves_that_an_end_is_never_let_go(tmp_path, capsys):
    path = task(tmp_path)
    code = main(["plan", str(path), "-q", "held"])
    out, err = capsys.readouterr()
    assert code == 10, err
    assert out.endswith("\nNo solution for any maxstep.\n\n") and "refinement" not in err


def test_a_wrong_invariant_on_a_robot_task_shows_a_move(tmp_path, capsys):
    path = task(tmp_path)
    code = main(["plan", str(path), "--json"])
    out, _ = capsys.readouterr()
    results = {r["query"]["label"]: r for r in json.loads(out)["results"]}
    assert code == 11
    assert results["held"]["status"] == "no_plan_proved"
    loose = results["loose"]
    assert loose["status"] == "invariant_wrong" and loose["invariant"]["failed"] == "transition"
    states = loose["invariant"]["counterexample"]["states"]
    assert states[0]["xpos(r1)"] == 0 and states[1]["xpos(r1)"] == 1
    assert results["0"]["status"] == "found"      # the task's own query is still refined
