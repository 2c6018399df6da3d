"""`cplus replay LOG --animate FILE`: an online run's log animated cycle by cycle; a bad log is
one line on stderr and exit code 2."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from PIL import Image

from cplus.cli import main
from cplus.cli.replay import ONLINE_FORMAT, frames_of, read_log
from cplus.robot.online.loop import ONLINE_FORMAT as WRITTEN_FORMAT

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery" / "delivery.cp"
SCENE = ROOT / "domains" / "payload" / "scene.toml"
SMALL = ["--dpi", "20", "--quiet"]


def n_frames(path: Path) -> int:
    with Image.open(path) as im:
        assert im.format == "GIF"
        return im.n_frames


def cycle(k: int, state: dict, **extra) -> dict:
    return {"record": "cycle", "cycle": k, "time": 1.5 * k, "state": state, "events": [], "inferred": [],
            "sensed": {}, "raw": {}, "plan": [["a"]], "replanned": None, "executed": ["a"], "failure": None,
            "notes": [], "decision_ms": 1.0, "act_s": 1.0, **extra}


def arms_log(path: Path, scene: str | None = str(SCENE)) -> Path:
    """The log of a payload-arms run as `cplus online` writes it: two cycles, a fault and a re-plan."""
    def at(x1, x2):
        return {"xpos(r1)": x1, "ypos(r1)": 0, "xpos(r2)": x2, "ypos(r2)": 5, "xpay(pl1)": x1, "ypay(pl1)": 0,
                "xpay(pl2)": x2, "ypay(pl2)": 5, "on(r1,pl1)": True}
    start = {"record": "start", "format": ONLINE_FORMAT, "domain": "domains/payload/payload.cp", "goal": "0",
             "executor": "emulated NXT bricks r1, r2", **({"scene": scene} if scene else {})}
    lines = [start, cycle(0, at(0, 0), replanned={"reason": "start", "fluents": {}, "events": []},
                          failure="robot r1 motor A: 62 degrees from its setpoints"),
             cycle(1, at(2, 2), replanned={"reason": "fault", "fluents": {
                 "xpos(r1)": {"predicted": 4, "observed": 2}}, "events": []}),
             {"record": "end", "status": "goal_reached", "message": "goal '0' reached", "cycles": 2, "replans": 1,
              "state": at(10, 10), "seconds": 4.0}]
    path.write_text("".join(json.dumps(x) + "\n" for x in lines))
    return path


def one_line_error(capsys, argv: list[str], message: str) -> None:
    assert main(["replay", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("cplus replay: error: ") and message in err, err


def test_the_format_is_the_one_the_loop_writes():
    assert ONLINE_FORMAT == WRITTEN_FORMAT


def test_a_real_online_log_replays_cycle_by_cycle(tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    assert main(["online", str(DELIVERY), "--simulate", "--log", str(log), "--quiet"]) == 0
    start, cycles, end = read_log(str(log))
    assert end is not None and end["status"] == "goal_reached"
    frames = frames_of(cycles, end)
    assert [f.cycle for f in frames[:-1]] == [c["cycle"] for c in cycles] and frames[-1].ended
    assert not any(f.positions for f in frames)          # no scene: the fluents are drawn
    assert frames[0].state["atLandmark"] == "1" and "executed (1): follow" in frames[0].lines
    out = tmp_path / "run.gif"
    assert main(["replay", str(log), "--animate", str(out), "--dpi", "20"]) == 0
    assert n_frames(out) == len(cycles) + 1
    assert f"cplus replay: wrote {out} ({len(cycles) + 1} frames)" in capsys.readouterr().err


def test_a_servers_log_names_the_goals_that_changed():
    record = cycle(3, {"at": "office3"}, goals=[{"id": 1, "request": "deliver(office3,office2)",
                                               "status": "preempted", "reason": "cancelled"}])
    (frame,) = frames_of([record], None)
    assert "goal 1 deliver(office3,office2): preempted (cancelled)" in frame.lines


def test_an_arms_log_draws_the_arms_where_the_states_put_them(tmp_path):
    log = arms_log(tmp_path / "arms.jsonl")
    _, cycles, end = read_log(str(log))
    import trajectory
    frames = frames_of(cycles, end, trajectory.load_scene(SCENE))
    assert frames[1].positions == {"r1": (2.0, 0.0), "r2": (2.0, 5.0), "pl1": (2.0, 0.0), "pl2": (2.0, 5.0)}
    assert [f.replanned for f in frames] == [False, True, False]
    assert [f.failed for f in frames] == [True, False, False]
    assert "RE-PLANNED (fault): 1 steps" in frames[1].lines and "  xpos(r1): predicted 4, observed 2" in frames[1].lines
    assert frames[-1].lines[:2] == ("the run ended: goal_reached", "goal '0' reached")
    out = tmp_path / "arms.gif"
    assert main(["replay", str(log), "--animate", str(out), *SMALL]) == 0
    assert n_frames(out) == 3
    assert main(["replay", str(log), "--animate", str(tmp_path / "two.gif"), "--frames", "2", *SMALL]) == 0
    assert n_frames(tmp_path / "two.gif") == 2


def test_a_scene_the_log_names_must_exist_unless_given(tmp_path, capsys):
    log = arms_log(tmp_path / "arms.jsonl", scene=str(tmp_path / "gone.toml"))
    one_line_error(capsys, [str(log), "--animate", str(tmp_path / "a.gif")],
                   "gone.toml: no such file (the scene the log names: give --scene FILE)")
    assert main(["replay", str(log), "--animate", str(tmp_path / "a.gif"), "--scene", str(SCENE), *SMALL]) == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("format = 'cplus.scene/1'\n[grid]\nx_min = 'a'\n")
    assert main(["replay", str(log), "--animate", str(tmp_path / "b.gif"), "--scene", str(bad), *SMALL]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.toml:" in err and "Traceback" not in err


@pytest.mark.parametrize("content, message", [
    (None, "run.jsonl: no such file"),
    ("", "run.jsonl: the file is empty (not a cplus.online/1 log)"),
    ("hello\n", "run.jsonl:1: not JSON: Expecting value at column 1 (not a cplus.online/1 log)"),
    ('{"record": "start", "format": "cplus.execlog/1"}\n', "not a cplus.online/1 log"),
    ('[1, 2]\n', 'run.jsonl:1: a record is a JSON object with a "record" field'),
    ('{"record": "start", "format": "cplus.online/1"}\n', "run.jsonl: the log has no cycle to replay"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "ti',
     "run.jsonl: the log has no cycle to replay"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "ti\n'
     '{"record": "cycle", "cycle": 1, "time": 1}\n', "run.jsonl:2: not JSON"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle"\n{"record": "end"}\n',
     "run.jsonl:2: not JSON"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0}\n',
     'run.jsonl:2: a cycle record needs "time" (seconds)'),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": 0, "state": 3}\n',
     'run.jsonl:2: "state" must be an object'),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "frame"}\n', "run.jsonl:2: unknown record 'frame'"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "end"}\n{"record": "end"}\n',
     "run.jsonl:3: a record after the end record"),
    # cycles out of order, and times that are no finite number of seconds going forward
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 2, "time": 0}\n'
     '{"record": "cycle", "cycle": 1, "time": 1}\n',
     "run.jsonl:3: cycle 1 after cycle 2: a run's cycles are in increasing order"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": 0}\n'
     '{"record": "cycle", "cycle": 0, "time": 1}\n', "run.jsonl:3: cycle 0 after cycle 0"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": NaN}\n',
     'run.jsonl:2: "time" must be a finite number of seconds from the run\'s start, not nan'),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": Infinity}\n',
     'run.jsonl:2: "time" must be a finite number'),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": -1}\n',
     'run.jsonl:2: "time" must be a finite number'),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": 5}\n'
     '{"record": "cycle", "cycle": 1, "time": 4.5}\n', "run.jsonl:3: cycle 1 at 4.5 s, before the cycle ahead of it"),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": 0}\n'
     '{"record": "end", "seconds": NaN}\n', 'run.jsonl:3: "seconds" must be a finite number'),
    ('{"record": "start", "format": "cplus.online/1"}\n{"record": "cycle", "cycle": 0, "time": 0}\n'
     '{"record": "start", "format": "cplus.execlog/1"}\n', "run.jsonl:3: a start record of another format"),
])
def test_bad_logs_are_one_line(tmp_path, capsys, content, message):
    log = tmp_path / "run.jsonl"
    if content is not None:
        log.write_text(content)
    one_line_error(capsys, [str(log), "--animate", str(tmp_path / "a.gif")], message)
    assert not (tmp_path / "a.gif").exists()


def test_binary_and_directory_inputs_are_one_line(tmp_path, capsys):
    (tmp_path / "bin.jsonl").write_bytes(b"\xff\xfe\x00")
    one_line_error(capsys, [str(tmp_path / "bin.jsonl"), "--animate", str(tmp_path / "a.gif")], "not UTF-8 text")
    one_line_error(capsys, [str(tmp_path), "--animate", str(tmp_path / "a.gif")], "not a regular file")


def test_the_animation_file_is_checked_first(tmp_path, capsys, monkeypatch):
    log = arms_log(tmp_path / "arms.jsonl")
    one_line_error(capsys, [str(log)], "nothing to do: give --animate FILE")
    one_line_error(capsys, [str(log), "--animate", str(tmp_path / "a.png")], "a.png: use a .gif or .mp4 file name")
    one_line_error(capsys, [str(log), "--animate", str(tmp_path)], "use a .gif or .mp4")
    import trajectory.animate
    monkeypatch.setattr(trajectory.animate.animation.writers, "is_available", lambda name: False)
    one_line_error(capsys, [str(log), "--animate", str(tmp_path / "a.mp4")],
                   "a.mp4: an .mp4 needs ffmpeg, which is not installed")
    assert main(["replay", str(log), "--animate", str(tmp_path / "a.gif"), "--frames", "0"]) == 2
    assert "--frames: must be from 1 to 10000 frames" in capsys.readouterr().err


def test_the_command_line_defaults_are_the_api_defaults():
    import inspect

    import trajectory.animate
    from cplus.cli.animation_options import DEFAULT_DPI, DEFAULT_FRAMES
    for fn in (trajectory.animate.animate_run, trajectory.animate.animate_cycles):
        params = inspect.signature(fn).parameters
        assert (params["max_frames"].default, params["dpi"].default) == (DEFAULT_FRAMES, DEFAULT_DPI)


def test_long_writes_report_progress_at_every_quarter():
    import io

    from cplus.cli.animation_options import FrameProgress
    out = io.StringIO()
    progress = FrameProgress("cplus run", "out/run.gif", out)
    for k in range(1, 41):
        progress(k, 40)
    assert out.getvalue().splitlines() == [f"cplus run: animating out/run.gif: frame {k}/40" for k in (10, 20, 30, 40)]
    short, quiet = io.StringIO(), io.StringIO()
    for k in range(1, 11):
        FrameProgress("p", "a.gif", short)(k, 10)       # a short write says nothing
        FrameProgress("p", "a.gif", quiet, quiet=True)(k * 4, 40)
    assert short.getvalue() == quiet.getvalue() == ""


# --------------------------------------------------------------------------- several runs, literal text, cycles

def start_record(goal: str = "g", **extra) -> dict:
    return {"record": "start", "format": ONLINE_FORMAT, "domain": "d.cp", "goal": goal, "executor": "a robot", **extra}


def end_record(cycles: int, **extra) -> dict:
    return {"record": "end", "status": "goal_reached", "message": "goal 'g' reached", "cycles": cycles, "replans": 0,
            "state": {"p": cycles}, "seconds": 1.5 * cycles, **extra}


def lines_of(*records) -> str:
    return "".join((r if isinstance(r, str) else json.dumps(r) + "\n") for r in records)


def three_runs(path: Path) -> Path:
    """A log continued after restarts, written by hand: run 1 ends, run 2 crashed after two
    cycles (no end record), run 3 ends."""
    path.write_text(lines_of(start_record(), cycle(0, {"p": 0}), cycle(1, {"p": 1}), end_record(2),
                             start_record(), cycle(0, {"p": 10}), cycle(1, {"p": 11}),
                             start_record(), cycle(0, {"p": 20}), cycle(1, {"p": 21}), cycle(2, {"p": 22}),
                             end_record(3)))
    return path


def test_a_log_of_several_runs_replays_the_last_unless_told(tmp_path, capsys):
    from cplus.cli.replay import read_runs
    log = three_runs(tmp_path / "runs.jsonl")
    runs = read_runs(str(log))
    assert [(r.number, r.line, len(r.cycles), r.end is not None) for r in runs] == [
        (1, 1, 2, True), (2, 5, 2, False), (3, 8, 3, True)]
    assert read_log(str(log))[1][0]["state"] == {"p": 20}               # the last run
    assert read_log(str(log), 2)[1][0]["state"] == {"p": 10}
    out = tmp_path / "last.gif"
    assert main(["replay", str(log), "--animate", str(out), *SMALL]) == 0
    assert n_frames(out) == 3 + 1
    assert main(["replay", str(log), "--animate", str(tmp_path / "first.gif"), "--run", "1", *SMALL]) == 0
    assert n_frames(tmp_path / "first.gif") == 2 + 1
    one_line_error(capsys, [str(log), "--animate", str(tmp_path / "x.gif"), "--run", "4"],
                   f"--run 4: {log} holds 3 runs")
    assert main(["replay", str(log), "--animate", str(tmp_path / "x.gif"), "--run", "0"]) == 2
    assert "--run: expected a positive integer, got '0'" in capsys.readouterr().err
    assert not (tmp_path / "x.gif").exists()


def test_a_run_without_its_end_record_is_drawn_as_crashed(tmp_path):
    log = three_runs(tmp_path / "runs.jsonl")
    from cplus.cli.replay import pick_run, read_runs
    crashed = pick_run(str(log), read_runs(str(log)), 2)
    frames = frames_of(crashed.cycles, crashed.end, crashed=True)
    assert [f.cycle for f in frames] == [0, 1, 1] and frames[-1].ended and frames[-1].failed
    assert frames[-1].lines[0] == "the run has no end record: it crashed or was killed"
    assert main(["replay", str(log), "--run", "2", "--animate", str(tmp_path / "crash.gif"), *SMALL]) == 0
    assert n_frames(tmp_path / "crash.gif") == 3


@pytest.mark.parametrize("joined", [False, True])
def test_a_line_cut_off_by_a_crash_ends_its_run(tmp_path, joined):
    """A run killed while writing leaves half a line; the restarted run's start record follows
    it on the next line, or on the same one when the writer did not end the line first."""
    cut = '{"record": "cycle", "cycle": 2, "ti'
    log = tmp_path / "runs.jsonl"
    log.write_text(lines_of(start_record(), cycle(0, {"p": 0}), cycle(1, {"p": 1}), cut + ("" if joined else "\n"),
                            start_record(), cycle(0, {"p": 5}), end_record(1)))
    from cplus.cli.replay import pick_run, read_runs
    runs = read_runs(str(log))
    assert [(len(r.cycles), r.end is not None, r.cut) for r in runs] == [(2, False, 4), (1, True, None)]
    first = pick_run(str(log), runs, 1)
    frames = frames_of(first.cycles, first.end, crashed=True, cut=first.cut)
    assert "its last line (4) is cut off: it was stopped while writing it" in frames[-1].lines
    tail = tmp_path / "tail.jsonl"                        # the last run cut off: drawn up to there
    tail.write_text(lines_of(start_record(), cycle(0, {"p": 0}), cut))
    assert main(["replay", str(tail), "--animate", str(tmp_path / "t.gif"), *SMALL]) == 0
    assert n_frames(tmp_path / "t.gif") == 2


def test_a_run_with_no_cycle_is_named(tmp_path, capsys):
    log = tmp_path / "runs.jsonl"
    log.write_text(lines_of(start_record(), cycle(0, {"p": 0}), end_record(1), start_record()))
    one_line_error(capsys, [str(log), "--animate", str(tmp_path / "a.gif")],
                   f"{log}:4: run 2 of 2 has no cycle to replay (runs with cycles: 1; pick one with --run N)")
    assert main(["replay", str(log), "--animate", str(tmp_path / "a.gif"), "--run", "1", *SMALL]) == 0


MATH = "$\\frac{1}{2$ and $x^$ {\\bf"
"""Text matplotlib's mathtext cannot parse (a socket client can plant it through a rejected request)."""


@pytest.mark.parametrize("arms", [False, True])
def test_text_from_a_log_is_drawn_as_written(tmp_path, capsys, arms):
    """A log's text is never read as mathematics: this crashed the replay in matplotlib's parser."""
    records = arms_log(tmp_path / "arms.jsonl").read_text().splitlines() if arms else None
    log = tmp_path / "math.jsonl"
    if arms:
        start, *rest = (json.loads(r) for r in records)  # type: ignore[union-attr]
        start["goal"] = MATH
        rest[0]["notes"] = [MATH]
        rest[0]["failure"] = MATH
        log.write_text(lines_of(start, *rest))
    else:
        log.write_text(lines_of(start_record(goal=MATH, executor=MATH),
                                cycle(0, {MATH: MATH}, notes=[MATH], executed=[MATH],
                                      goals=[{"id": 1, "request": MATH, "status": "rejected", "reason": MATH}]),
                                end_record(1, message=MATH, status=MATH)))
    out = tmp_path / "math.gif"
    assert main(["replay", str(log), "--animate", str(out), *SMALL]) == 0, capsys.readouterr().err
    assert n_frames(out) >= 2


def test_the_replay_counts_cycles_as_cplus_online_does(tmp_path, capsys):
    """One run, one count: 'goal reached at cycle 8; 8 cycles ran' on both sides."""
    import re
    log = tmp_path / "run.jsonl"
    assert main(["online", str(DELIVERY), "--simulate", "--log", str(log)]) == 0
    said = re.search(r"(\d+ cycles? ran, \d+ replans?)", capsys.readouterr().err)
    assert said is not None
    _, cycles, end = read_log(str(log))
    assert end is not None
    frames = frames_of(cycles, end)
    assert said.group(1) in frames[-1].lines
    assert f"goal 'deliver' reached at cycle {cycles[-1]['cycle']}" in frames[-1].lines


def test_a_servers_goal_records_are_shown_with_the_next_cycle(tmp_path):
    start = {"record": "start", "format": "cplus.online/1", "domain": "domains/mailbot/mailbot.cp", "goal": "serve",
             "serve_format": "cplus.serve/3"}
    goal = {"record": "goal", "id": 1, "request": "deliver(office3,office2)", "status": "active", "slot": 1}
    log = tmp_path / "run.jsonl"
    log.write_text("".join(json.dumps(x) + "\n" for x in [start, cycle(0, {"at": "office1"}), goal,
                                                           cycle(1, {"at": "office1"})]))
    _, cycles, end = read_log(str(log))
    assert end is None and "goals" not in cycles[0] and cycles[1]["goals"] == [goal]


def test_a_compact_log_of_several_runs_is_split_at_its_start_records(tmp_path):
    """The logs are written compact (``{"record":"start",...}``, as cplus.robot writes them): a
    line cut off by a crash, followed by the next run's start record, ends the run before."""
    def compact(obj) -> str:
        return json.dumps(obj, separators=(",", ":")) + "\n"
    text = (compact(start_record()) + compact(cycle(0, {"p": 0})) + compact(cycle(1, {"p": 1}))[:12]
            + compact(start_record()) + compact(cycle(0, {"p": 5})) + compact(end_record(1)))
    log = tmp_path / "compact.jsonl"
    log.write_text(text)
    from cplus.cli.replay import read_runs
    runs = read_runs(str(log))
    assert [(len(r.cycles), r.end is not None, r.cut) for r in runs] == [(1, False, 3), (1, True, None)]
