"""The robot-task command line keeps its promises: options and paths are checked before any
planning, bad tasks give one located error, statuses map to exit codes, --stats shows work."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cplus.cli import main

ROOT = Path(__file__).resolve().parents[2]
DOMAIN = ROOT / "domains" / "payload" / "payload.cp"
SCENE = ROOT / "domains" / "payload" / "scene.toml"
WALL = ROOT / "domains" / "payload" / "scenes" / "raised-wall.toml"
LAMP = ROOT / "domains" / "examples" / "lamp.cp"


def task_copy(tmp_path: Path, scene_edit=None, domain_edit=None) -> Path:
    d = tmp_path / "task"
    d.mkdir()
    for src, name, edit in ((DOMAIN, "payload.cp", domain_edit), (SCENE, "scene.toml", scene_edit)):
        text = src.read_text()
        (d / name).write_text(edit(text) if edit else text)
    return d / "payload.cp"


def line_of(path: Path, needle: str) -> int:
    return next(i for i, t in enumerate(path.read_text().splitlines(), 1) if needle in t)


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# ---------------------------------------------------------------- refused before planning


@pytest.mark.parametrize("argv, message", [
    (["--step-time", "1", "--points-per-step", "3"], "whole number of milliseconds"),
    (["--step-time", "0"], "--step-time: must be > 0"),
    (["--step-time", "inf"], "--step-time: must be finite"),
    (["--step-time", "nan"], "--step-time: must be > 0"),
    (["--points-per-step", "0"], "expected a positive integer, got '0'"),
    (["--plot", "plan.jpg"], "must be a .png or .svg file"),
])
def test_bad_sampling_and_picture_options_are_refused_at_once(capsys, argv, message):
    code, out, err = run(capsys, "plan", DOMAIN, *argv)
    assert code == 2 and out == ""
    assert message in err and "% refinement" not in err and len(err.strip().splitlines()) == 1


def test_an_output_that_cannot_be_written_is_refused_before_planning(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    code, out, err = run(capsys, "plan", DOMAIN, "--trajectory", blocker / "t.json")
    assert code == 2 and out == "" and "% refinement" not in err
    assert err.strip() == f"cplus plan: error: --trajectory {blocker / 't.json'}: {blocker} is not a directory"
    code, _, err = run(capsys, "plan", DOMAIN, "--csv", tmp_path)
    assert code == 2 and "it is a directory" in err


def test_one_file_for_two_outputs_is_refused(tmp_path, capsys):
    code, _, err = run(capsys, "plan", DOMAIN, "--trajectory", tmp_path / "x", "--csv", tmp_path / "x")
    assert code == 2 and f"--trajectory and --csv are the same file {tmp_path / 'x'}" in err


def test_outputs_need_a_single_query(tmp_path, capsys):
    path = task_copy(tmp_path, domain_edit=lambda s: s + "\n:- query label :: 1; maxstep :: 0..2.\n")
    code, out, err = run(capsys, "plan", path, "--plot", tmp_path / "p.png")
    assert code == 2 and out == "" and "choose one with --query" in err
    assert not (tmp_path / "p.png").exists()


def test_a_start_inside_an_obstacle_is_one_located_error(tmp_path, capsys):
    block = ('[[obstacles]]\nname = "block"\npoints = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5], '
             '[-0.5, -0.5]]\n\n[[obstacles]]\nname = "post"')
    path = task_copy(tmp_path, scene_edit=lambda s: s.replace('[[obstacles]]\nname = "post"', block))
    code, out, err = run(capsys, "plan", path)
    assert code == 2 and out == ""
    line = line_of(path, "0: -canCarry")
    col = path.read_text().splitlines()[line - 1].index("xpos(r1)=0") + 1
    assert err.strip().splitlines() == [f"{path}:{line}:{col}: error: robot r1's start (0,0) is inside obstacle 'block'"]


def test_a_payload_start_across_an_obstacle_is_one_located_error(tmp_path, capsys):
    bar = ('[[obstacles]]\nname = "bar"\npoints = [[-0.5, 2.2], [0.5, 2.2], [0.5, 2.8], [-0.5, 2.8], '
           '[-0.5, 2.2]]\n\n[[obstacles]]\nname = "post"')
    path = task_copy(tmp_path, scene_edit=lambda s: s.replace('[[obstacles]]\nname = "post"', bar))
    code, _, err = run(capsys, "plan", path)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "payload.cp:" in err and "the payload's start (0,0)-(0,5) meets obstacle 'bar'" in err


def test_a_grid_that_disagrees_with_the_domain_is_refused_at_the_binding(tmp_path, capsys):
    path = task_copy(tmp_path, scene_edit=lambda s: s.replace("x_max = 12", "x_max = 11"))
    code, _, err = run(capsys, "plan", path)
    scene = path.parent / "scene.toml"
    line = line_of(scene, 'x = "xpos(r1)"')
    assert code == 2
    assert err.startswith(f"{scene}:{line}:")
    assert "'xpos(r1)' ranges over 0..12, but the scene's [grid] has x in 0..11" in err


# ---------------------------------------------------------------- plain domains, grounding


def test_robot_options_on_a_plain_domain_warn(tmp_path, capsys):
    code, out, err = run(capsys, "plan", LAMP, "--query", "on", "--plot", tmp_path / "p.png", "--max-iterations", "3")
    assert code == 0 and "ACTIONS:" in out
    assert "warning: --plot applies to robot tasks only" in err
    assert "warning: --max-iterations applies to robot tasks only" in err
    assert not (tmp_path / "p.png").exists()


def test_cplus_ground_grounds_a_robot_task(tmp_path, capsys):
    code, _, err = run(capsys, "ground", DOMAIN, "--maxstep", "1", "--dimacs", tmp_path / "d.cnf")
    assert code == 0 and "% wrote" in err
    text = (tmp_path / "d.cnf").read_text()
    assert text.startswith("c") or text.startswith("p cnf")
    assert "xpos(r1)" in text
    copy = tmp_path / "alone.cp"
    shutil.copy(DOMAIN, copy)       # no scene beside it: --scene names one
    code, _, err = run(capsys, "ground", copy, "--maxstep", "1", "--dimacs", tmp_path / "e.cnf", "--scene", WALL)
    assert code == 0, err
    code, _, err = run(capsys, "ground", copy, "--maxstep", "1", "--dimacs", tmp_path / "f.cnf")
    assert code == 2 and "collision" in err     # without the scene the external is unknown


# ---------------------------------------------------------------- what --stats shows


def test_stats_show_loading_grounding_the_pre_check_and_the_sizes(capsys):
    code, _, err = run(capsys, "plan", DOMAIN, "--stats")
    assert code == 0
    lines = err.splitlines()
    assert lines[0].startswith(f"% {DOMAIN}: loaded with the scene ") and lines[0].endswith("grounding ...")
    assert lines[1].startswith("% grounded ") and " rules over " in lines[1]
    assert lines[2].startswith("% pre-check (") and "payload turns" in lines[2]
    assert any(x.startswith("% maxstep 9: ") for x in lines)
    summary = next(x for x in lines if x.startswith("% refinement: "))
    assert "nogoods learned" in summary and "variables" in summary and "clauses" in summary


def test_the_paper_s_form_is_an_option(capsys):
    code, out, err = run(capsys, "plan", DOMAIN, "--nogoods", "actions", "--json")
    assert code == 0
    res = json.loads(out)["results"][0]
    assert res["nogoods"]["form"] == "actions" and res["nogoods"]["precheck"] is None
    learned = res["refinement"][0]["learned"][0]
    assert learned["form"] == "actions" and any(c["constant"].startswith("move(") for c in learned["conditions"])
    assert "forbidding at every step: {move(" in err


def test_lazy_only_and_eager_everything(capsys):
    for eager in ("no", "yes"):
        code, out, _ = run(capsys, "plan", DOMAIN, "--eager", eager, "--json")
        res = json.loads(out)["results"][0]
        assert code == 0 and res["maxstep"] == 9
        pre = res["nogoods"]["precheck"]
        if eager == "no":
            assert pre is None
        else:
            assert (pre["points"], pre["pairs_checked"], pre["length_pairs"]) == (82, 2 * 117 * 116, 332)
            assert pre["motions"] > 1000


# ---------------------------------------------------------------- cplus run maps the statuses


def test_cplus_run_stops_at_a_proof_of_no_safe_plan(tmp_path, capsys):
    code, out, err = run(capsys, "run", DOMAIN, "--scene", WALL, "--out", tmp_path / "o", "--max-horizon", "14")
    assert code == 4 and "no collision-free plan with maxstep 0..14" in err
    assert not (tmp_path / "o" / "trajectory.json").exists()


def test_cplus_run_gives_up_with_exit_5(tmp_path, capsys):
    code, _, err = run(capsys, "run", DOMAIN, "--out", tmp_path / "o", "--max-iterations", "1")
    assert code == 5 and "gave up after 1 refinement iteration" in err


# ---------------------------------------------------------------- the process


_THREADS_AFTER_NUMPY = r"""
import os, sys
import cplus.cli

def report(argv=None, exiting=False):
    import numpy  # noqa: F401  (what a robot task's command loads)
    threads = next(line.split()[1] for line in open("/proc/self/status") if line.startswith("Threads:"))
    print(os.environ.get("OPENBLAS_NUM_THREADS"), threads, flush=True)
    return 0

cplus.cli.main = report
cplus.cli.run()
"""


@pytest.mark.parametrize("given, expected", [(None, "1 1"), ("2", "2 2")])
def test_the_command_keeps_numpy_to_one_thread_unless_told(given, expected):
    """numpy's OpenBLAS starts a spinning worker per core when it loads: half of numpy's import
    in processor time.  The ``cplus`` entry point asks for one thread, unless the user chose."""
    import os
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given:
        env["OPENBLAS_NUM_THREADS"] = given
    if given and os.cpu_count() == 1:
        pytest.skip("one core: OpenBLAS starts no worker whatever it is told")
    out = subprocess.run([sys.executable, "-c", _THREADS_AFTER_NUMPY], env=env, capture_output=True, text=True,
                         check=True).stdout
    assert out.split() == expected.split()
