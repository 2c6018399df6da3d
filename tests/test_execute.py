"""`cplus execute`: a cplus.trajectory/1 file run on emulated bricks through the serial path."""
from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np
import pytest

import nxt_link
import trajectory as tj
from cplus.cli import main
from cplus.robot.execution import skew_verdict, streams_from_trajectory, tracking_report
from nxt_link.host.execlog import BrickLog, ExecutionLog

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "domains" / "payload" / "scene.toml"
FAST = ["--no-latency", "--quiet"]   # emulated bricks: simulated time


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


@pytest.mark.slow
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


@pytest.mark.slow
def test_execute_on_given_ports(traj_file, tmp_path, capsys):
    clock = nxt_link.SimClock()   # given ports of bricks emulated here: used on their clock
    servers = [nxt_link.PtyBrickServer(nxt_link.BrickEmulator(nxt_link.EmulatorConfig(
        name=n, link=nxt_link.LinkParams.instant())), clock=clock)
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
    one_line_error(capsys, [str(orphan), "--animate", str(tmp_path / "a.gif"), *FAST], 2,
                   "--animate needs the scene")


@pytest.mark.slow
def test_execute_animates_executed_over_planned_and_plots_the_run_over_time(traj_file, tmp_path, capsys):
    from PIL import Image

    from cplus.cli.execute import run_timeline
    plot_path, gif, log_path = tmp_path / "fig5.png", tmp_path / "run.gif", tmp_path / "log.json"
    code = execute_main([str(traj_file), "--plot", str(plot_path), "--animate", str(gif), "--frames", "6",
                         "--dpi", "20", "--log", str(log_path), "--no-latency"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert f"cplus execute: wrote {gif}\n" in err
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == 6 and im.size[0] == 8 * 20
    assert plot_path.read_bytes().startswith(b"\x89PNG")
    log = ExecutionLog.loads(log_path.read_text())
    timeline = run_timeline(log)
    assert timeline.names == ("r1", "r2")
    for b, tb in zip(log.bricks, timeline.bricks):
        assert tb.tick_s == b.tick_ms / 1000 / log.time_scale and tb.start_s == b.start_s
        assert np.array_equal(tb.setpoint_deg, np.array(b.reference_deg))
        assert np.array_equal(tb.measured_deg, np.array(b.measured_deg, dtype=float))
        assert [e[1] for e in tb.events] == [e.event for e in b.events]
    sk = log.start_skew()
    assert timeline.skew_s == (sk.estimate, sk.min, sk.max) and timeline.stopped is None


def test_an_incomplete_log_becomes_a_timeline_with_its_stop():
    from cplus.cli.execute import run_timeline
    from nxt_link.host.execlog import Stopped
    log = ExecutionLog((BrickLog("r1", ("A",), 50, ((0,), (5,), (9,)), ((0,), None), (), (1.0, 1.1), "run"),),
                       stopped=Stopped(2.5, "brick r1: link lost", "r1"), time_scale=2.0)
    timeline = run_timeline(log)
    b = timeline.brick("r1")
    assert b.tick_s == 0.025 and b.measured_ticks == 1 and b.reached == "run"
    assert np.isnan(b.measured_deg[1:]).all() and timeline.stopped == (2.5, "brick r1: link lost")


def test_animation_files_are_checked_before_anything_moves(traj_file, tmp_path, capsys, monkeypatch):
    one_line_error(capsys, [str(traj_file), "--animate", str(tmp_path / "a.avi"), *FAST], 2,
                   "--animate " + str(tmp_path / "a.avi") + ": use a .gif or .mp4 file name")
    (tmp_path / "d.gif").mkdir()
    one_line_error(capsys, [str(traj_file), "--animate", str(tmp_path / "d.gif"), *FAST], 2,
                   f"--animate {tmp_path / 'd.gif'}: it is a directory")
    a_file = tmp_path / "file"
    a_file.write_text("x")
    one_line_error(capsys, [str(traj_file), "--animate", str(a_file / "a.gif"), *FAST], 2,
                   f"{a_file} is not a directory")
    one_line_error(capsys, [str(traj_file), "--dpi", "5", *FAST], 2, "--dpi: must be from 10 to 600 dpi")
    import trajectory.animate
    monkeypatch.setattr(trajectory.animate.animation.writers, "is_available", lambda name: False)
    one_line_error(capsys, [str(traj_file), "--animate", str(tmp_path / "a.mp4"), *FAST], 2,
                   "an .mp4 needs ffmpeg, which is not installed")


@pytest.fixture
def bricks_on_ptys():
    """Two emulated bricks on ptys (instant link, simulated time), for --brick; stopped at the
    end."""
    servers = []
    clock = nxt_link.SimClock()

    def start(program: str | None = None) -> list:
        for name in ("r1", "r2"):
            emu = nxt_link.BrickEmulator(nxt_link.EmulatorConfig(
                name=name, link=nxt_link.LinkParams.instant(),
                program_running=program is None))
            if program is not None:
                emu.firmware.files.add(program)
                emu.firmware.start_program_now(program)
            server = nxt_link.PtyBrickServer(emu, clock=clock)
            server.start()
            servers.append(server)
        return servers

    yield start
    for s in servers:
        s.stop()


def brick_args(servers) -> list[str]:
    return ["--brick", f"r1={servers[0].path}", "--brick", f"r2={servers[1].path}"]


def test_outputs_and_ports_are_checked_before_anything_moves(traj_file, tmp_path, capsys,
                                                            bricks_on_ptys):
    servers = bricks_on_ptys()
    a_file = tmp_path / "file"
    a_file.write_text("x")
    one_line_error(capsys, [str(traj_file), *brick_args(servers), "--log", str(tmp_path)], 2,
                   f"--log {tmp_path}: it is a directory")
    one_line_error(capsys, [str(traj_file), *brick_args(servers), "--report",
                            str(a_file / "r.txt")], 2, f"{a_file} is not a directory")
    one_line_error(capsys, [str(traj_file), *brick_args(servers), "--log", str(a_file),
                            "--report", str(a_file)], 2, f"--log and --report are the same file {a_file}")
    one_line_error(capsys, [str(traj_file), *brick_args(servers), "--plot",
                            str(tmp_path / "p.gif")], 2, "use a .png or .svg file name")
    one_line_error(capsys, [str(traj_file), "--brick", f"r1={servers[0].path}",
                            "--brick", f"r2={servers[0].path}"], 2,
                   "--brick r1 and --brick r2 are both")
    one_line_error(capsys, [str(traj_file), "--tolerance", "300"], 2, "must be in 0..255")
    one_line_error(capsys, [str(traj_file), "--max-start-offset", "-1"], 2, "must be in 0..")
    for s in servers:
        assert s.emulator.stats.frames_in == 0  # nobody talked to the bricks


def test_hostile_trajectory_files_are_one_line(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 200_000 + "]" * 200_000)
    one_line_error(capsys, [str(deep), *FAST], 2, "nested too deeply")
    huge = tmp_path / "huge.json"
    huge.write_text('{"format": "cplus.trajectory/1", "tick_ms": ' + "9" * 5000 + "}")
    one_line_error(capsys, [str(huge), *FAST], 2, "invalid JSON")


def test_the_scene_decides_the_motor_limits(traj_file, tmp_path, capsys):
    scene = SCENE.read_text().replace("theta_limits_deg = [5.0, 175.0]",
                                      "theta_limits_deg = [10.0, 175.0]")
    other = tmp_path / "scene.toml"
    other.write_text(scene)
    one_line_error(capsys, [str(traj_file), "--scene", str(other), *FAST], 2,
                   "robot r1: the trajectory's theta_limits_deg [5, 175] is not the scene's "
                   "[10, 175]")
    scene = SCENE.read_text().replace("deg_per_unit = 5.0", "deg_per_unit = 4.0", 1)
    other.write_text(scene)
    one_line_error(capsys, [str(traj_file), "--scene", str(other), *FAST], 2,
                   "robot r1: the trajectory's motors A:sx81.82, B:sx81.82, C:thetax5 are not "
                   "the scene's")


def test_a_failed_run_still_writes_its_log_and_report(traj_file, tmp_path, capsys,
                                                      bricks_on_ptys):
    servers = bricks_on_ptys(program="tetris.rxe")  # the wrong program runs on both
    log_path, report_path = tmp_path / "log.json", tmp_path / "report.txt"
    code = execute_main([str(traj_file), *brick_args(servers), "--log", str(log_path),
                         "--report", str(report_path), "-q"])
    err = capsys.readouterr().err
    assert code == 1
    assert err == ("cplus execute: brick r1 is running 'tetris.rxe', not 'cplus_follow.rxe'; "
                   "stop it on the brick first\n")
    log = ExecutionLog.loads(log_path.read_text())
    assert not log.complete and log.stopped.brick == "r1"
    assert log.stopped.reason == err.split(": ", 1)[1].strip()
    assert [b.reached for b in log.bricks] == ["connect", "connect"]
    report = report_path.read_text()
    assert "INCOMPLETE: the execution stopped at" in report and ": brick r1 is running" in report
    assert "r1: 0 of 21 ticks measured" in report and "(no measurements)" in report


def test_the_payload_is_compared_on_a_common_clock(traj_file):
    """A brick that started late shows as the payload error it caused."""
    traj = tj.load_trajectory(traj_file)

    def log_with_starts(r2_start: float) -> ExecutionLog:
        bricks = []
        for robot, start in zip(traj.robots, (1.0, r2_start)):
            ref = tuple(tuple(int(v) for v in row) for row in robot.setpoints_deg)
            bricks.append(BrickLog(robot.name, robot.ports, traj.tick_ms, ref, ref, (),
                                   (start, start)))
        return ExecutionLog(tuple(bricks), abs(r2_start - 1.0))

    together = tracking_report(traj, log_with_starts(1.0))
    late = tracking_report(traj, log_with_starts(1.3))  # three ticks late
    assert together.payload_length_max_grid < 0.05
    assert late.payload_mid_max_grid > 0.2  # r2 lagging three ticks behind r1
    assert late.start_skew.estimate == pytest.approx(0.3)
    assert "start skew (measured from the log): 300 ms (r2 after r1" in late.text()
    # each robot on its own clock still tracked its own setpoints perfectly
    assert all(r.max_deg == (0, 0, 0) for r in late.robots)
    error, warning = skew_verdict(traj, log_with_starts(1.3))
    assert error == ("the bricks started 300 ms apart (between 300 and 300 ms), more than one "
                     "tick (100 ms)") and warning is None
    assert skew_verdict(traj, log_with_starts(1.05)) == (None, None)


def run_main(argv):
    return main(["run", *argv])


@pytest.mark.parametrize("argv, message", [
    (["nosuch.cp"], "cannot read nosuch.cp: no such file"),
    ([str(ROOT / "domains/payload/payload.cp"), "--points-per-step", "0"],
     "--points-per-step must be at least 1"),
    ([str(ROOT / "domains/payload/payload.cp"), "--points-per-step", "3"],
     "a tick of 333.333 ms; it must be a whole number of milliseconds"),
    ([str(ROOT / "domains/payload/payload.cp"), "--step-time", "0.05"],
     "a tick of 5 ms; it must be a whole number of milliseconds from 10"),
    ([str(ROOT / "domains/payload/payload.cp"), "--step-time", "inf"],
     "--step-time must be a positive number"),
    ([str(ROOT / "domains/payload/payload.cp"), "--brick", "r1=/dev/x", "--brick", "r2=/dev/x"],
     "--brick r1 and --brick r2 are both /dev/x"),
    ([str(ROOT / "domains/payload/payload.cp"), "--brick", "r1"], "expects NAME=PORT"),
    ([str(ROOT / "domains/payload/payload.cp"), "--time-scale", "0"],
     "must be at least 0.001 and at most 1000 times real time, got '0'"),
    ([str(ROOT / "domains/payload/payload.cp"), "--animate", "x.png"], "--animate x.png: use a .gif or .mp4"),
    ([str(ROOT / "domains/payload/payload.cp"), "--frames", "x"], "expected a whole number of frames"),
])
def test_cplus_run_checks_everything_before_planning(argv, message, capsys):
    assert run_main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "% planning" not in err, err


def test_cplus_run_refuses_an_out_that_is_a_file(tmp_path, capsys):
    a_file = tmp_path / "out"
    a_file.write_text("x")
    assert run_main([str(ROOT / "domains/payload/payload.cp"), "--out", str(a_file)]) == 2
    assert "--out" in capsys.readouterr().err


@pytest.mark.slow
def test_cplus_run_runs_on_simulated_time_by_default_and_names_every_file(tmp_path, capsys):
    out = tmp_path / "out"
    code = run_main([str(ROOT / "domains/payload/payload.cp"), "--out", str(out), "--step-time",
                     "0.5", "--points-per-step", "5"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "on emulated bricks (simulated time, no latency)" in err
    for name in ("plan.txt", "plan.json", "plan.png", "trajectory.json", "trajectory.csv",
                 "execution.json", "execution.png", "report.txt"):
        assert (out / name).is_file()
        assert f"wrote {out / name}\n" in err, name
    log = ExecutionLog.loads((out / "execution.json").read_text())
    assert log.complete and log.time_scale == 1


def test_cplus_run_keeps_real_time_for_given_bricks(tmp_path):
    run = importlib.import_module("cplus.cli.run")  # (cplus.cli.run is also a function)
    domain = str(ROOT / "domains/payload/payload.cp")
    out = str(tmp_path / "out")
    args = run.build_parser().parse_args([domain, "--out", out])
    run._validate(args)
    assert (args.time_scale, args.latency) == (None, False)  # emulated: simulated time by default
    args = run.build_parser().parse_args([domain, "--out", out, "--brick", "r1=/dev/rfcomm0",
                                          "--brick", "r2=/dev/rfcomm1"])
    run._validate(args)
    assert args.time_scale == 1.0  # real bricks keep time
    args = run.build_parser().parse_args([domain, "--out", out, "--time-scale", "1", "--latency"])
    run._validate(args)
    assert (args.time_scale, args.latency) == (1.0, True)


def test_cplus_run_animates_only_when_asked(tmp_path):
    run = importlib.import_module("cplus.cli.run")
    domain = str(ROOT / "domains/payload/payload.cp")
    out = str(tmp_path / "out")
    for extra, animate in (([], None), (["--animate"], str(tmp_path / "out" / "run.gif")),
                           (["--animate", str(tmp_path / "mine.gif")], str(tmp_path / "mine.gif"))):
        args = run.build_parser().parse_args([domain, "--out", out, *extra])
        run._validate(args)
        assert args.animate == animate


def test_cplus_run_animate_before_the_domain_file_says_where_it_goes(capsys):
    """`--animate` alone before the domain takes the domain as its FILE: one line says so."""
    from cplus.cli import main
    code = main(["run", "--animate", str(ROOT / "domains/payload/payload.cp")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1
    assert "--animate took" in err and "put --animate after the domain file, or write --animate=FILE" in err


def test_a_trajectory_that_continues_from_elsewhere_is_streamed_in_the_encoders_frame():
    """A re-plan starts where the arms stopped; the brick's encoders count from the first start."""
    scene = tj.load_scene(str(SCENE))
    holds = {"pl1": "r1", "pl2": "r2"}

    def at(p1, p2):
        return tj.StepState({"r1": p1, "r2": p2}, {"pl1": p1, "pl2": p2}, holds)

    first = tj.build_trajectory(scene, [at((0, 0), (0, 5)), at((1, 0), (1, 5))], points_per_step=5,
                                step_time_s=0.5)
    later = tj.build_trajectory(scene, [at((1, 0), (1, 5)), at((2, 0), (2, 5))], points_per_step=5,
                                step_time_s=0.5)
    own = streams_from_trajectory(later)
    framed = streams_from_trajectory(later, origin=first)
    for a, b, f in zip(own, framed, streams_from_trajectory(first)):
        assert a.rows[0] == (0, 0, 0)  # its own frame: zero at its own start
        # in the encoders' frame it starts where the first one ended, and moves the same way
        assert all(abs(x - y) <= 1 for x, y in zip(b.rows[0], f.rows[-1]))
        assert all(abs((r1[j] - r0[j]) - (s1[j] - s0[j])) <= 1
                   for (r0, r1), (s0, s1) in zip(zip(a.rows, a.rows[1:]), zip(b.rows, b.rows[1:]))
                   for j in range(3))
        assert b.limits == f.limits


def test_cplus_plan_animates_the_plan(tmp_path, capsys):
    from PIL import Image
    domain = str(ROOT / "domains/payload/payload.cp")
    gif = tmp_path / "plan.gif"
    assert main(["plan", domain, "--animate", str(gif), "--frames", "4", "--dpi", "20"]) == 0
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == 4
    assert f"% wrote {gif}\n" in capsys.readouterr().err
    unsafe = tmp_path / "unsafe.gif"      # the first plan meets the post: animated all the same, exit 9
    assert main(["plan", domain, "--no-refine", "--animate", str(unsafe), "--frames", "3", "--dpi", "20"]) == 9
    assert unsafe.is_file()


def test_cplus_plan_checks_the_animation_first(tmp_path, capsys):
    domain = str(ROOT / "domains/payload/payload.cp")
    assert main(["plan", domain, "--animate", str(tmp_path / "plan.txt")]) == 2
    err = capsys.readouterr().err
    assert err == f"cplus plan: error: --animate {tmp_path / 'plan.txt'}: use a .gif or .mp4 file name\n"
    lamp = str(ROOT / "domains/examples/lamp.cp")
    assert main(["plan", lamp, "--query", "on", "--animate", str(tmp_path / "lamp.gif")]) == 0
    assert "--animate applies to robot tasks only" in capsys.readouterr().err
    assert not (tmp_path / "lamp.gif").exists()


# ------------------------------------------- the trajectory names its domain and scene (issue 31)


def scene_found(trajectory_file: Path):
    from cplus.cli.execute import _scene_path, build_parser
    path = _scene_path(build_parser().parse_args([str(trajectory_file)]), tj.load_trajectory(trajectory_file))
    return None if path is None else tj.load_scene(path)


@pytest.fixture
def planned_elsewhere(tmp_path, monkeypatch) -> Path:
    """`cplus plan --trajectory` run in one folder, with a scene that is not the one beside the
    domain (the shipped scene under another name); then the working directory moves away."""
    work = tmp_path / "work"
    (work / "domains" / "payload" / "scenes").mkdir(parents=True)
    (work / "domains" / "payload" / "payload.cp").write_text((ROOT / "domains/payload/payload.cp").read_text())
    (work / "domains" / "payload" / "scene.toml").write_text(SCENE.read_text())
    (work / "domains" / "payload" / "scenes" / "renamed.toml").write_text(
        SCENE.read_text().replace('name = "payload"', 'name = "renamed"', 1))
    (work / "out").mkdir()
    monkeypatch.chdir(work)
    assert main(["plan", "domains/payload/payload.cp", "--scene", "domains/payload/scenes/renamed.toml",
                 "--trajectory", "out/t.json"]) == 0
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    return work / "out" / "t.json"


def test_the_trajectory_names_its_scene_relative_to_itself(planned_elsewhere):
    source = json.loads(planned_elsewhere.read_text())["source"]
    assert source == {"domain": "../domains/payload/payload.cp", "scene": "../domains/payload/scenes/renamed.toml",
                      "plan_length": 9}
    scene = scene_found(planned_elsewhere)
    assert scene is not None and scene.name == "renamed"     # not scene.toml beside the domain
    (planned_elsewhere.parents[1] / "domains/payload/scenes/renamed.toml").unlink()
    assert scene_found(planned_elsewhere) is None             # a named scene is not replaced by another


@pytest.mark.slow
def test_execute_plots_from_any_working_directory(planned_elsewhere, tmp_path, capsys):
    capsys.readouterr()
    plot = tmp_path / "x.png"
    assert execute_main([str(planned_elsewhere), "--plot", str(plot), *FAST]) == 0, capsys.readouterr().err
    assert plot.stat().st_size > 0 and "no scene found" not in capsys.readouterr().err


def test_a_trajectory_written_before_is_read_as_then(traj_file, tmp_path, monkeypatch):
    """Files written before the scene was named give the domain as the run was given it,
    relative to where the run started: still found from there."""
    data = json.loads(traj_file.read_text())
    data["source"] = {"domain": "domains/payload/payload.cp", "plan_length": 2}
    old = tmp_path / "out" / "old.json"
    old.parent.mkdir()
    old.write_text(json.dumps(data))
    monkeypatch.chdir(ROOT)
    scene = scene_found(old)
    assert scene is not None and Path(scene.file).resolve() == SCENE
    monkeypatch.chdir(tmp_path)
    assert scene_found(old) is None
