"""Robot tasks: the JSON result says what the checker found, and the options reach the planner.

The violation fields of ``--json`` are compared with the continuous checker run on the plan
read back from the same JSON (through the scene's bindings, written out here), so a field
that is renamed, rounded, shifted or taken from the wrong motion fails. The ``no_plan``
status in JSON, and ``cplus run --extern``, complete the statuses and options tested beside.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import trajectory
from cplus.cli import main

ROOT = Path(__file__).resolve().parents[2]
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENE = ROOT / "domains" / "payload" / "scene.toml"
ROBOTS, ENDS = ("r1", "r2"), ("pl1", "pl2")


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def states_from_json(history: dict) -> list[trajectory.StepState]:
    """The plan of a cplus.plan/1 history as the checker's states (the scene's bindings)."""
    out = []
    for s in history["states"]:
        out.append(trajectory.StepState(
            {r: (s[f"xpos({r})"], s[f"ypos({r})"]) for r in ROBOTS},
            {p: (s[f"xpay({p})"], s[f"ypay({p})"]) for p in ENDS},
            {p: next((r for r in ROBOTS if s[f"on({r},{p})"]), None) for p in ENDS}))
    return out


def test_the_violations_in_json_are_the_checker_s(capsys):
    code, out, _ = run(capsys, "plan", DOMAIN, "--no-refine", "--json")
    (res,) = json.loads(out)["results"]
    assert code == 9 and res["status"] == "unsafe"
    (hist,) = res["histories"]
    expected = trajectory.all_violations(trajectory.load_scene(SCENE), states_from_json(hist))
    got = res["refinement"][0]["violations"]
    assert expected and len(got) == len(expected)
    for g, v in zip(got, expected):
        assert (g["kind"], g["step"], g["subject"], g["message"]) == (v.kind.value, v.step, v.subject, v.message)
        assert g["u"] == pytest.approx(v.u, abs=1e-12) and g["point"] == pytest.approx(list(v.point), abs=1e-12)
        assert 0 <= g["step"] < hist["maxstep"] and 0.0 <= g["u"] <= 1.0


def test_no_plan_in_a_closed_range_in_json(tmp_path, capsys):
    task = tmp_path / "task"
    task.mkdir()
    (task / "payload.cp").write_text(DOMAIN.read_text().replace("maxstep :: 0..infinity;", "maxstep :: 2..4;"))
    (task / "scene.toml").write_text(SCENE.read_text())
    code, out, _ = run(capsys, "plan", task / "payload.cp", "--json")
    (res,) = json.loads(out)["results"]
    assert code == 1
    assert res["status"] == "no_plan" and res["histories"] == [] and res["maxstep"] is None
    assert res["no_solution_with_maxstep"] == [2, 3, 4] and "2..4" in res["reason"]
    assert (res["query"]["min_maxstep"], res["query"]["max_maxstep"]) == (2, 4)


def test_cplus_run_passes_extern_to_the_planner(tmp_path, capsys):
    """An external the domain needs only from --extern: missing, it is a located error;
    given, it is used (here it forbids everything, so run stops before any brick)."""
    task = tmp_path / "task"
    task.mkdir()
    domain = task / "payload.cp"
    domain.write_text(DOMAIN.read_text() + "\nconstraint xpos(r1) \\= 0 where closed(1).\n")
    (task / "scene.toml").write_text(SCENE.read_text())
    ext = tmp_path / "closed.py"
    ext.write_text("def closed(day):\n    return day == 1\n")
    out_dir = tmp_path / "out"
    code, _, err = run(capsys, "run", domain, "--out", out_dir, "--max-horizon", "2")
    assert code == 2 and err.startswith(f"{domain}:") and "closed" in err
    code, _, err = run(capsys, "run", domain, "--extern", ext, "--out", out_dir, "--max-horizon", "2")
    assert code == 3 and "no plan with maxstep 0..2" in err
    assert not (out_dir / "execution.json").exists()
