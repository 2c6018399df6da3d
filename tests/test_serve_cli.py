"""``cplus serve`` from the command line: the paper's scenario from a script with its log, and
bad inputs (one line or a located error, exit 2, never a traceback)."""
from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from walltime import wall

from cplus.cli import main

ROOT = Path(__file__).resolve().parent.parent
MAILBOT = ROOT / "domains" / "mailbot"
DOMAIN = str(MAILBOT / "mailbot.cp")


def test_the_papers_scenario_from_a_script(tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    code = main(["serve", DOMAIN, "--script", str(MAILBOT / "table1.jsonl"), "--action-time", "0", "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 0
    assert "cplus serve: goal 1 deliver(office3,office2): active (slot 1)" in err
    assert "cplus serve: goal 1 deliver(office3,office2): preempted" in err
    assert "cplus serve: goal 2 deliver(office3,office4): succeeded" in err
    assert "goal_reached: goal 'serve' holds at cycle 7 and no more events will come" in err
    assert err.count("cycle 3 [") == 1            # an idle cycle is shown once
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert lines[0]["accepts"] == "deliver(office,office)" and lines[0]["requests"].endswith("requests.toml")
    cycles = [x for x in lines if x["record"] == "cycle"]
    assert [x["executed"] for x in cycles] == [[], ["move(office2)"], ["move(office3)"], [], ["pickup(2)"],
                                               ["move(office4)"], ["deliver(2)"], []]
    assert cycles[1]["plan"] == [["move(office2)"], ["move(office3)"], ["pickup(1)"], ["move(office2)"],
                                 ["deliver(1)"]]
    assert cycles[3]["plan"] == [] and cycles[3]["events"] == ["cancel(1)"]
    assert cycles[4]["plan"] == [["pickup(2)"], ["move(office4)"], ["deliver(2)"]]
    assert [(g["id"], g["status"]) for g in lines[-1]["goals"]] == [(1, "preempted"), (2, "succeeded")]


def run_bad(args, capsys) -> str:
    code = main(["serve", *args])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    return err


def test_bad_options_and_files_are_one_line_errors(tmp_path, capsys):
    assert run_bad([DOMAIN, "--listen", "0.0.0.0:7070"], capsys) == (
        "cplus serve: error: --listen: 0.0.0.0 is not a loopback address: the socket has no authentication, so it "
        "listens on loopback addresses only (127.0.0.0/8 or ::1)\n")
    assert run_bad([DOMAIN, "--listen", "7070"], capsys).startswith("cplus serve: error: --listen: expected HOST:PORT")
    assert run_bad([DOMAIN, "--brick", "robot=/dev/null"], capsys) == (
        "cplus serve: error: --brick needs --robot (the binding file that names the bricks)\n")
    lone = tmp_path / "lone.cp"
    lone.write_text((MAILBOT / "mailbot.cp").read_text().replace("'core.cp'", repr(str(MAILBOT / "core.cp"))))
    assert "no requests.toml beside" in run_bad([str(lone), "--script", str(MAILBOT / "table1.jsonl")], capsys)
    err = run_bad([DOMAIN, "--goal", "nosuch", "--script", str(MAILBOT / "table1.jsonl")], capsys)
    assert err == "cplus serve: error: --goal nosuch: no query with label 'nosuch' (this file's labels: serve)\n"
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"cycle": 1, "request": "deliver(office3,office2)"}\n{"cycle": 2, "cancel": "one"}\n')
    assert run_bad([DOMAIN, "--script", str(bad)], capsys).startswith(
        f"{bad}:2:1: error: \"cancel\" must be a goal id")
    requests = tmp_path / "requests.toml"
    requests.write_text((MAILBOT / "requests.toml").read_text().replace('"package"', '"parcel"'))
    assert run_bad([DOMAIN, "--requests", str(requests), "--script", str(bad)], capsys).startswith(
        f"{requests}:5:1: error: unknown sort 'parcel'")
    assert run_bad([DOMAIN, "--script", str(tmp_path / "none.jsonl")], capsys).startswith(
        "cplus serve: error: cannot read script")
    assert "expected seconds >= 0" in run_bad([DOMAIN, "--action-time", "-1"], capsys)


def test_an_address_in_use_is_an_error(capsys):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        err = run_bad([DOMAIN, "--listen", f"127.0.0.1:{port}"], capsys)
    assert err.startswith(f"cplus serve: error: cannot listen on 127.0.0.1:{port}: ")


def cli(args, env=None, timeout=120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cplus", "serve", *args], capture_output=True, text=True,
                          timeout=wall(timeout), env=env)


@pytest.mark.parametrize("value", ["x", "0", "601"])
def test_a_stop_grace_that_is_not_seconds_is_refused_before_the_server_starts(tmp_path, value):
    log = tmp_path / "run.jsonl"
    r = cli([DOMAIN, "--listen", "127.0.0.1:0", "--log", str(log)], env=dict(os.environ, CPLUS_STOP_GRACE=value))
    assert r.returncode == 2
    assert r.stderr == ("cplus serve: error: CPLUS_STOP_GRACE must be a number of seconds > 0 and at most 600, "
                        f"got {value!r}\n")
    assert not log.exists()


def test_ros_absent_is_a_clear_message(tmp_path):
    fake = tmp_path / "noros"
    fake.mkdir()
    (fake / "rospy.py").write_text("raise ImportError('no ROS here', name='rospy')\n")
    env = dict(os.environ, PYTHONPATH=str(fake), ROS_MASTER_URI="http://127.0.0.1:9")
    r = cli([DOMAIN, "--ros"], env)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.startswith("cplus serve: error: --ros needs ROS 1 for Python 3.")
    assert "(cannot import rospy): apt-get install ros-core python3-rospy python3-actionlib" in r.stderr


def test_ros_without_a_master_is_a_clear_message():
    if not Path("/usr/lib/python3/dist-packages/rospy").is_dir():
        pytest.skip("ROS 1 is not installed (.ci/run installs it)")
    with socket.socket() as s:                  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_HOSTNAME="127.0.0.1")
    r = cli([DOMAIN, "--ros"], env)
    assert r.returncode == 2
    assert r.stderr == (f"cplus serve: error: --ros: no ROS master answers at http://127.0.0.1:{port}: start roscore "
                        "(roscore -p PORT) or fix ROS_MASTER_URI\n")
    env.pop("ROS_MASTER_URI")
    r = cli([DOMAIN, "--ros"], env)
    assert r.returncode == 2 and "ROS_MASTER_URI is not set" in r.stderr


def test_nothing_imports_ros_but_the_bridge():
    """ROS is an optional extra: no module of the project imports rospy or the bridge, except
    the bridge itself and the command's --ros path."""
    imports = re.compile(r"^\s*(from\s+(\S+)\s+import\s+(.+)|import\s+(.+))$", re.M)
    offenders = []
    for path in (ROOT / "cplus").rglob("*.py"):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("cplus/robot/serving/ros/") or rel == "cplus/robot/serving/ros_bridge.py":
            continue
        for m in imports.finditer(path.read_text()):
            names = " ".join(x for x in m.groups()[1:] if x)
            if re.search(r"\b(rospy|actionlib|genpy|genmsg|rosgraph|ros_bridge|cplus_msgs)\b", names):
                offenders.append((rel, m.group(0).strip()))
    assert offenders == [("cplus/cli/serve.py", "from cplus.robot.serving import ros_bridge")] * 2
    r = subprocess.run([sys.executable, "-c", "import sys, cplus.cli.serve, cplus.robot.serving.reactive; "
                        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('rospy', 'actionlib', 'genpy')))"],
                       capture_output=True, text=True, timeout=wall(60))
    assert r.stdout.strip() == "[]"


def test_numbers_too_large_or_not_ascii_are_one_line_errors(tmp_path, capsys):
    script = str(MAILBOT / "table1.jsonl")
    assert run_bad([DOMAIN, "--listen", "127.0.0.1:\uff17\uff10\uff17\uff10"], capsys).startswith(
        "cplus serve: error: --listen: expected HOST:PORT")
    assert run_bad([DOMAIN, "--listen", "127.0.0.1:" + "7" * 30], capsys).startswith(
        "cplus serve: error: --listen: expected HOST:PORT")
    for option, value, message in (("--action-time", "1e300", "at most 3600 seconds"),
                                   ("--budget", "9" * 30, "at most 1e+12 propagations"),
                                   ("--horizon", "1000000000", "at most 1000 steps"),
                                   ("--max-horizon", "1000000000", "at most 1000 steps"),
                                   ("--max-clients", "0", "expected a positive integer"),
                                   ("--max-client-goals", "9" * 30, "at most 100000 goals")):
        err = run_bad([DOMAIN, "--script", script, option, value], capsys)
        assert err.startswith("cplus serve: error: argument") and message in err and err.count("\n") == 1, err
    err = run_bad([DOMAIN, "--ros", "--ros-name", "two words"], capsys)
    assert err == ("cplus serve: error: --ros-name: 'two words' is not a ROS name (letters, digits and _, parts "
                   "separated by /, each starting with a letter)\n")
    big = tmp_path / "far.jsonl"
    big.write_text('{"cycle": 1000000000000000000, "request": "deliver(office1,office2)"}\n')
    assert run_bad([DOMAIN, "--script", str(big)], capsys).startswith(f"{big}:1:1: error: \"cycle\" must be an "
                                                                      "integer from 1")
    requests = tmp_path / "requests.toml"
    requests.write_text((MAILBOT / "requests.toml").read_text().replace("$2", "$" + "9" * 20))
    assert run_bad([DOMAIN, "--requests", str(requests), "--script", script], capsys).startswith(
        f"{requests}:11:")


def test_request_text_is_escaped_on_stderr_one_line_whatever_it_holds(tmp_path, capsys):
    # a newline would split the progress line and let a client forge one; a NUL would reach
    # the terminal raw
    forged = 'x\ncplus serve: goal 7 {"cancel": 1}: rejected: forged'
    script = tmp_path / "script.jsonl"
    script.write_text("".join(json.dumps(x) + "\n" for x in [
        {"cycle": 1, "request": forged}, {"cycle": 1, "request": "deliver(office1\x00,office2)"},
        {"cycle": 1, "request": "d\u00e9liver(office1,office2)"}]))
    assert main(["serve", DOMAIN, "--script", str(script), "--action-time", "0"]) == 0
    err = capsys.readouterr().err
    goals = [line for line in err.splitlines() if line.startswith("cplus serve: goal ")]
    assert goals == [
        "cplus serve: goal 1 x\\ncplus serve: goal 7 {\"cancel\": 1}: rejected: forged: rejected: cannot read "
        "'x\\ncplus serve: goal 7 {\"cancel\": 1}: rejected: forged' as a request such as deliver(office,office)",
        "cplus serve: goal 2 deliver(office1\\x00,office2): rejected: office1\\x00 is not an office (office1, office2, "
        "office3, office4)",
        "cplus serve: goal 3 d\\xe9liver(office1,office2): rejected: cannot read 'd\\xe9liver(office1,office2)' as "
        "a request such as deliver(office,office)"]
    assert "\x00" not in err


def run_script(log, capsys, *more) -> tuple[int, str]:
    code = main(["serve", DOMAIN, "--script", str(MAILBOT / "table1.jsonl"), "--action-time", "0", "--log", str(log),
                 *more])
    return code, capsys.readouterr().err


def test_a_log_is_continued_with_a_new_run_and_goal_ids_go_on(tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    assert run_script(log, capsys)[0] == 0
    first = log.read_bytes()
    code, err = run_script(log, capsys)
    assert code == 0
    assert "cplus serve: goal 3 deliver(office3,office2): active (slot 1)" in err      # ids go on
    assert "cplus serve: goal 3 deliver(office3,office2): preempted" in err          # the script's own first
    assert log.read_bytes().startswith(first)
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    starts = [i for i, x in enumerate(lines) if x["record"] == "start"]
    ends = [i for i, x in enumerate(lines) if x["record"] == "end"]
    assert len(starts) == 2 and len(ends) == 2 and ends[0] == starts[1] - 1
    assert lines[starts[0]]["first_goal_id"] == 1 and "continues" not in lines[starts[0]]
    assert lines[starts[1]]["first_goal_id"] == 3 and lines[starts[1]]["continues"] is True
    created = [x["id"] for x in lines if x["record"] == "goal" and x["status"] == "pending"]
    assert created == [1, 2, 3, 4]
    # a crash left a line cut off: it is removed, and the new run says so
    with open(log, "a") as f:
        f.write('{"record":"goal","id":5,"requ')
    code, err = run_script(log, capsys)
    assert code == 0
    lines = [json.loads(x) for x in log.read_text().splitlines()]       # every line JSON again
    start = [x for x in lines if x["record"] == "start"][-1]
    assert start["first_goal_id"] == 5 and start["repaired"] == (
        "removed a last line of 29 bytes cut off by a crash of the run before")


def test_a_log_of_another_kind_is_refused_unless_overwritten(tmp_path, capsys):
    log = tmp_path / "notes.txt"
    log.write_text("my notes\n")
    code, err = run_script(log, capsys)
    assert code == 2 and err == (f"cplus serve: error: --log: {log} is not a cplus.online/1 log (its first line is "
                                 "not a run's start record): give another file, or --log-overwrite to replace it\n")
    assert log.read_text() == "my notes\n"
    code, err = run_script(log, capsys, "--log-overwrite")
    assert code == 0 and json.loads(log.read_text().splitlines()[0])["first_goal_id"] == 1
    assert run_bad([DOMAIN, "--log-overwrite"], capsys) == "cplus serve: error: --log-overwrite needs --log FILE\n"
