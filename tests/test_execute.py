"""`cplus execute`: a cplus.trajectory/1 file run on emulated bricks through the serial path."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import nxt_link
import trajectory as tj
from cplus.cli import main
from cplus.robot.execution import streams_from_trajectory, tracking_report
from nxt_link.execlog import BrickLog, ExecutionLog

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "domains" / "payload" / "scene.toml"
FAST = ["--no-latency", "--time-scale", "10", "--quiet"]


def execute_main(argv):
    return main(["execute", *argv])


@pytest.fixture(scope="module")
def traj_file(tmp_path_factory) -> Path:
    """A short trajectory of the payload scene: both arms carry the stick right and up."""
    scene = tj.load_scene(str(SCENE))
    holds = {"pl1": "r1", "pl2": "r2"}
    states = [tj.StepState({"r1": (0, 0), "r2": (0, 5)}, {"pl1": (0, 0), "pl2": (0, 5)}, holds),
              tj.StepState({"r1": (1, 0), "r2": (1, 5)}, {"pl1": (1, 0), "pl2": (1, 5)}, holds),
              tj.StepState({"r1": (2, 1), "r2": (2, 6)}, {"pl1": (2, 1), "pl2": (2, 6)}, holds)]
    traj = tj.build_trajectory(scene, states, points_per_step=10, step_time_s=1.0,
                               source={"domain": str(ROOT / "domains/payload/payload.cp")})
    path = tmp_path_factory.mktemp("traj") / "traj.json"
    tj.save_json(traj, path)
    return path


def test_streams_carry_ports_tick_setpoints_and_limits(traj_file):
    traj = tj.load_trajectory(traj_file)
    streams = streams_from_trajectory(traj)
    assert [s.brick for s in streams] == ["r1", "r2"]
    for s, robot in zip(streams, traj.robots):
        assert s.ports == robot.ports == ("A", "B", "C")
        assert s.tick_ms == traj.tick_ms == 100
        assert np.array_equal(np.array(s.rows), robot.setpoints_deg)
        assert s.limits_deg == tuple((m.min_deg, m.max_deg) for m in robot.motors)


def test_execute_on_emulated_bricks_writes_log_report_and_plot(traj_file, tmp_path, capsys):
    log_path, plot_path = tmp_path / "exec.json", tmp_path / "fig5.png"
    code = execute_main([str(traj_file), "--log", str(log_path), "--plot", str(plot_path), *FAST])
    out, err = capsys.readouterr()
    assert code == 0, err
    traj = tj.load_trajectory(traj_file)
    log = ExecutionLog.loads(log_path.read_text())
    for robot in traj.robots:
        b = log.brick(robot.name)
        assert np.array_equal(np.array(b.reference_deg), robot.setpoints_deg)
        assert len(b.measured_deg) == traj.ticks
    assert plot_path.read_bytes().startswith(b"\x89PNG")
    assert "tracking error" in out and "payload r1-r2" in out
    for name in ("r1", "r2"):
        assert any(line.split()[:1] == [name] for line in out.splitlines())
    # the arms followed the plan closely (grid units; one unit = 40 mm)
    report = tracking_report(traj, log)
    assert all(r.max_grid < 0.2 for r in report.robots)


def test_execute_on_given_ports(traj_file, tmp_path, capsys):
    servers = [nxt_link.PtyBrickServer(nxt_link.BrickEmulator(nxt_link.EmulatorConfig(
        name=n, link=nxt_link.LinkParams.instant(), stale_frame_ms=2500)), time_scale=10)
        for n in ("r1", "r2")]
    for s in servers:
        s.start()
    try:
        report = tmp_path / "report.txt"
        code = execute_main([str(traj_file), "--brick", f"r1={servers[0].path}",
                             "--brick", f"r2={servers[1].path}", "--report", str(report),
                             "--quiet"])
        assert code == 0, capsys.readouterr().err
        assert capsys.readouterr().out == ""
        assert "end-effector error" in report.read_text()
        traj = tj.load_trajectory(traj_file)
        for s, robot in zip(servers, traj.robots):
            assert s.emulator.program.reference_rows() == [tuple(r) for r in
                                                           robot.setpoints_deg.tolist()]
    finally:
        for s in servers:
            s.stop()


def test_tracking_report_measures_the_difference(traj_file):
    traj = tj.load_trajectory(traj_file)
    bricks = []
    for robot in traj.robots:
        ref = [tuple(int(v) for v in row) for row in robot.setpoints_deg]
        offset = (0, 0, 10) if robot.name == "r1" else (0, 0, 0)  # r1's arm motor 10 deg off
        meas = [tuple(v + o for v, o in zip(row, offset)) for row in ref]
        bricks.append(BrickLog(robot.name, robot.ports, traj.tick_ms, tuple(ref), tuple(meas), ()))
    report = tracking_report(traj, ExecutionLog(tuple(bricks), 0.0))
    r1, r2 = report.robots
    assert r1.max_deg == (0, 0, 10) and r1.rms_deg == (0.0, 0.0, 10.0)
    assert r2.max_deg == (0, 0, 0)
    # 10 motor degrees = 2 degrees of arm (5 deg per degree) on a 7-unit arm
    arm = 7.0 * np.radians(10 / traj.robots[0].motors[2].deg_per_unit)
    assert r1.max_grid == pytest.approx(arm, abs=0.03)
    assert r2.max_grid < 0.03  # only the rounding of setpoints to whole degrees
    assert report.payload == ("r1", "r2") and report.payload_length_max_grid > 0.1


def one_line_error(capsys, argv: list[str], code: int, needle: str) -> None:
    assert execute_main(argv) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err


def test_bad_input_is_one_line(traj_file, tmp_path, capsys):
    one_line_error(capsys, [str(tmp_path / "nope.json")], 2, "cannot read")
    one_line_error(capsys, [str(traj_file), "--brick", "r1"], 2, "expects NAME=PORT")
    one_line_error(capsys, [str(traj_file), "--brick", "r9=/dev/null"], 2, "no robot 'r9'")
    one_line_error(capsys, [str(traj_file), "--brick", "r1=/dev/null"], 2,
                   "no --brick for robot 'r2'")
    one_line_error(capsys, [str(traj_file), "--kp", "0"], 2, "gain")
    one_line_error(capsys, [str(traj_file), "--brick", f"r1={tmp_path}/rfcomm9",
                            "--brick", f"r2={tmp_path}/rfcomm8", "-q"], 1, "cannot open")


def test_unexecutable_trajectory_is_refused_before_anything_moves(traj_file, tmp_path, capsys):
    data = json.loads(traj_file.read_text())
    data["robots"][0]["setpoints_deg"][5][0] += 900  # a jump no motor can make in 100 ms
    bad = tmp_path / "jump.json"
    bad.write_text(json.dumps(data))
    one_line_error(capsys, [str(bad), *FAST], 2, "setpoints_deg[5][0]: 941 deg, but sample 5 puts "
                                                 "motor A at 40.9 deg")
    one_line_error(capsys, [str(traj_file), "--max-speed", "10", *FAST], 2,
                   "refused before anything moved: stream 'r1' port A:")


def test_plot_needs_a_scene(traj_file, tmp_path, capsys):
    data = json.loads(traj_file.read_text())
    data["source"] = {}
    orphan = tmp_path / "orphan.json"
    orphan.write_text(json.dumps(data))
    one_line_error(capsys, [str(orphan), "--plot", str(tmp_path / "p.png"), *FAST], 2,
                   "--plot needs the scene")
