"""The payload task end to end: domain + scene -> refined plan -> trajectory -> FK check."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest

import trajectory
from cplus.cli import main
from cplus.robot import RefineStatus, RobotTask, refine

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENE = ROOT / "domains" / "payload" / "scene.toml"


@pytest.fixture(scope="module")
def task() -> RobotTask:
    return RobotTask.load(str(DOMAIN), str(SCENE))


@pytest.fixture(scope="module")
def refined(task):
    return refine(task, "0")


def test_the_first_plan_passes_the_grid_but_not_the_continuous_check(refined):
    assert refined.first_violation is not None
    assert refined.first_violation.kind.value in ("payload-collision", "payload-length")
    assert len(refined.iterations) >= 2


def test_refinement_needs_no_more_iterations_than_the_paper(task, refined):
    """The paper's Algorithm 1 needed 9 iterations; the exact-action form of it needs many more."""
    assert len(refined.iterations) <= 9
    assert refined.history.maxstep == 9
    assert refined.no_solution_with_maxstep == list(range(9))
    paper = refine(task, "0", nogoods="actions")
    assert paper.status is RefineStatus.FOUND and paper.history.maxstep == 9
    assert len(paper.iterations) > len(refined.iterations)


def test_the_refined_plan_is_collision_free(task, refined):
    assert refined.found
    states = task.states(refined.history)
    assert trajectory.first_violation(task.scene, states) is None
    assert trajectory.all_violations(task.scene, states) == ()
    goal = states[-1].payload
    assert goal["pl1"] == (10.0, 0.0) and goal["pl2"] == (10.0, 5.0)
    assert states[0].payload["pl1"] == (0.0, 0.0) and states[0].payload["pl2"] == (0.0, 5.0)
    assert refined.history.maxstep >= refined.first_history.maxstep


def test_every_iteration_forbids_something_new(refined):
    seen = set()
    for it in refined.iterations[:-1]:
        assert it.violations and it.learned
        for nogood in it.learned:
            assert nogood.form == "positions" and nogood.key not in seen
            constants = {c for _, c, _ in nogood.conditions}
            assert constants <= {"xpos(r1)", "ypos(r1)", "xpos(r2)", "ypos(r2)", "xpay(pl1)", "ypay(pl1)",
                                  "xpay(pl2)", "ypay(pl2)"}      # positions only, no actions
            seen.add(nogood.key)
    assert refined.iterations[-1].violation is None


def test_the_store_agrees_with_the_solver(refined):
    """The refined plan was proposed by the solver, so no clause forbids it; every unsafe plan
    the loop saw is forbidden now."""
    store = refined.store
    assert store.excludes(list(refined.history.states)) is None
    assert store.excludes(list(refined.first_history.states)) is not None


def test_the_plan_respects_the_cost_bound_and_the_payload_length(task, refined):
    hist = refined.history
    for t, _state in enumerate(hist.states):
        assert hist.value("cost", t) <= 2
        p1 = (hist.value("xpay(pl1)", t), hist.value("ypay(pl1)", t))
        p2 = (hist.value("xpay(pl2)", t), hist.value("ypay(pl2)", t))
        assert 23 <= (p1[0] - p2[0]) ** 2 + (p1[1] - p2[1]) ** 2 <= 27


def test_the_trajectory_reproduces_the_grid_points(task, refined, tmp_path):
    states = task.states(refined.history)
    traj = trajectory.build_trajectory(task.scene, states, points_per_step=10, step_time_s=1.0)
    out = tmp_path / "t.json"
    trajectory.save_json(traj, out)
    loaded = trajectory.load_trajectory(out)
    for robot in loaded.robots:
        xs, ys = robot.xy_from_motor_deg(robot.setpoints_deg)
        for k, state in enumerate(states):
            x, y = xs[k * 10], ys[k * 10]
            gx, gy = state.robots[robot.name]
            # motor setpoints are whole degrees: a fraction of a grid unit at most
            assert math.hypot(x - gx, y - gy) < 0.05, (robot.name, k)


def test_cli_runs_refinement_and_exports(tmp_path, capsys):
    code = main(["plan", str(DOMAIN), "--plot", str(tmp_path / "p.png"), "--trajectory",
                 str(tmp_path / "t.json"), "--csv", str(tmp_path / "t.csv"), "--json"])
    out, err = capsys.readouterr()
    assert code == 0
    doc = json.loads(out)
    res = doc["results"][0]
    assert res["status"] == "found" and res["reason"] is None
    assert res["no_solution_with_maxstep"] == list(range(9)) and res["maxstep"] == 9
    assert [s["maxstep"] for s in res["stats"]] == list(range(10))
    assert res["stats"][-1]["variables"] > 0 and res["stats"][-1]["satisfiable"] is True
    assert res["refinement"][-1]["violations"] == [] and res["refinement"][-1]["learned"] == []
    first = res["refinement"][0]
    assert first["violations"][0]["kind"] in ("payload-collision", "payload-length")
    assert first["learned"] and first["learned"][0]["form"] == "positions"
    assert res["nogoods"]["learned"] == sum(len(it["learned"]) for it in res["refinement"])
    assert res["nogoods"]["precheck"]["points"] > 0
    assert "% refinement 1:" in err
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((tmp_path / "t.json").read_text())["format"] == "cplus.trajectory/1"
    assert (tmp_path / "t.csv").read_text().startswith("robot,tick,")


def test_no_refine_shows_the_raw_first_plan_and_says_it_is_unsafe(capsys):
    code = main(["plan", str(DOMAIN), "--no-refine"])
    out, err = capsys.readouterr()
    assert code == 9
    assert "ACTIONS:" in out and "% refinement 1:" in err and "between steps" in err
    assert "forbidding" not in err and "not collision-free" in err


def test_refusing_to_export_an_unsafe_plan_still_prints_the_result(tmp_path, capsys):
    code = main(["plan", str(DOMAIN), "--no-refine", "--json", "--trajectory", str(tmp_path / "t.json"),
                 "--plot", str(tmp_path / "p.svg")])
    out, err = capsys.readouterr()
    assert code == 9
    res = json.loads(out)["results"][0]
    assert res["status"] == "unsafe" and res["histories"] and res["refinement"][0]["violations"]
    assert "not collision-free" in err and "not written" in err
    assert not (tmp_path / "t.json").exists()
    assert (tmp_path / "p.svg").read_text().lstrip().startswith("<?xml")   # the picture shows why


def test_giving_up_is_not_a_proof(capsys):
    code = main(["plan", str(DOMAIN), "--max-iterations", "1", "--json"])
    out, err = capsys.readouterr()
    assert code == 5
    res = json.loads(out)["results"][0]
    assert res["status"] == "gave_up" and res["histories"] == [] and res["horizon"] == 8
    assert len(res["refinement"]) == 1 and res["no_solution_with_maxstep"] == list(range(8))
    assert "gave up after 1 refinement iteration (--max-iterations) at maxstep 8" in res["reason"]
    assert "gave up after 1 refinement iteration" in err


def test_gave_up_in_the_python_api(task):
    result = refine(task, "0", max_iterations=1)
    assert result.status is RefineStatus.GAVE_UP and not result.found
    assert result.to_json("0")["status"] == "gave_up"


def _copy_task(tmp_path, scene_edit=None, domain_edit=None) -> Path:
    d = tmp_path / "task"
    d.mkdir()
    shutil.copy(DOMAIN, d / "payload.cp")
    shutil.copy(SCENE, d / "scene.toml")
    if scene_edit:
        p = d / "scene.toml"
        p.write_text(scene_edit(p.read_text()))
    if domain_edit:
        p = d / "payload.cp"
        p.write_text(domain_edit(p.read_text()))
    return d / "payload.cp"


def test_a_binding_naming_an_unknown_fluent_is_located(tmp_path, capsys):
    path = _copy_task(tmp_path, lambda s: s.replace('x = "xpos(r1)"', 'x = "xpoz(r1)"'))
    code = main(["plan", str(path)])
    _, err = capsys.readouterr()
    assert code == 2
    line = next(i for i, t in enumerate((path.parent / "scene.toml").read_text().splitlines(), 1)
                if "xpoz" in t)
    assert f"scene.toml:{line}:" in err and "unknown fluent 'xpoz(r1)'" in err


def test_an_unreachable_start_is_reported_before_planning(tmp_path, capsys):
    path = _copy_task(tmp_path, domain_edit=lambda s: s.replace("xpos(r2)=0, ypos(r2)=5,",
                                                                  "xpos(r2)=0, ypos(r2)=-1,"))
    code = main(["plan", str(path)])
    _, err = capsys.readouterr()
    assert code == 2
    assert "robot r2 cannot reach the start" in err and "payload.cp:" in err


def test_a_broken_scene_is_located(tmp_path, capsys):
    bowtie = "[[4.5, -3.0], [5.5, 1.5], [5.5, -3.0], [4.5, 1.5], [4.5, -3.0]]"
    path = _copy_task(tmp_path, lambda s: s.replace(
        "[[4.5, -3.0], [5.5, -3.0], [5.5, 1.5], [4.5, 1.5], [4.5, -3.0]]", bowtie))
    code = main(["plan", str(path)])
    _, err = capsys.readouterr()
    assert code == 2 and "scene.toml:" in err and "error:" in err and "self-intersect" in err


def test_horizon_bound_proves_no_safe_plan(capsys):
    """The first plans have length 8; with no room to grow, refinement proves there is none."""
    code = main(["plan", str(DOMAIN), "--max-horizon", "8"])
    out, err = capsys.readouterr()
    assert code == 4
    assert "no collision-free plan with maxstep 0..8 (--max-horizon)" in err
    # no unsafe plan presented as the result: no solution at any horizon tried
    assert [x for x in out.splitlines() if x] == [f"No solution with maxstep {m}." for m in range(9)]


def test_no_plan_at_all_up_to_the_horizon_is_the_horizon_limit(capsys):
    code = main(["plan", str(DOMAIN), "--max-horizon", "5", "--json"])
    out, _ = capsys.readouterr()
    assert code == 3
    res = json.loads(out)["results"][0]
    assert res["status"] == "horizon_limit" and res["no_solution_with_maxstep"] == list(range(6))
    assert res["reason"] == "no plan with maxstep 0..5 (--max-horizon)"


def test_no_plan_in_a_closed_range(tmp_path, capsys):
    path = _copy_task(tmp_path, domain_edit=lambda s: s.replace("maxstep :: 0..infinity;", "maxstep :: 2..4;"))
    code = main(["plan", str(path)])
    out, err = capsys.readouterr()
    assert code == 1
    assert "no plan with maxstep 2..4" in err
    assert [x for x in out.splitlines() if x] == [f"No solution with maxstep {m}." for m in (2, 3, 4)]


@pytest.mark.slow
def test_cplus_run_the_whole_job_on_emulated_bricks(tmp_path, capsys):
    """Plan, refine, trajectory, execution on two emulated bricks (through their ptys),
    tracking report and pictures, all from one command."""
    out = tmp_path / "out"
    code = main(["run", str(DOMAIN), "--out", str(out), "--step-time", "0.5", "--points-per-step", "5"])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    assert "ACTIONS:" in stdout and "tracking error" in stdout
    for name in ("plan.txt", "plan.json", "plan.png", "trajectory.json", "trajectory.csv",
                 "execution.json", "execution.png", "report.txt"):
        assert (out / name).stat().st_size > 0, name
    log = json.loads((out / "execution.json").read_text())
    assert log["format"] == "cplus.execlog/1"
    report = (out / "report.txt").read_text()
    rows = [line.split() for line in report.splitlines() if line.strip().startswith(("r1 ", "r2 "))]
    grid_errors = [float(r[1]) for r in rows if len(r) >= 3 and r[0] in ("r1", "r2") and "mm)" in " ".join(r)]
    assert grid_errors and max(grid_errors) < 0.5   # the arms follow the plan within half a cell


def test_cplus_run_needs_a_scene(tmp_path, capsys):
    lone = tmp_path / "lone.cp"
    lone.write_text(":- constants p :: inertialFluent. :- query maxstep :: 0.")
    code = main(["run", str(lone), "--out", str(tmp_path / "o")])
    _, err = capsys.readouterr()
    assert code == 2 and "no scene" in err
