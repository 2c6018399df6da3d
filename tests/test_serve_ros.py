"""``cplus serve --ros`` against a real roscore on the loopback interface: an
``actionlib.SimpleActionClient`` sends a goal, hears feedback, cancels it (preempted) and gets
the result; a request the domain cannot express is rejected; a goal succeeds; ROS's
``rostopic`` sends one from the command line. Needs ROS 1 from Debian (.ci/run installs it)."""
from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from walltime import ORDERLY_STOP, wall

ROOT = Path(__file__).resolve().parent.parent
MAILBOT = ROOT / "domains" / "mailbot"
DIST = "/usr/lib/python3/dist-packages"
MSG_PATH = str(ROOT / "cplus" / "robot" / "serving" / "ros")

ROS_INSTALLED = shutil.which("roscore") is not None and Path(DIST, "rospy").is_dir()


def test_ros_is_installed_where_it_is_required():
    """CI sets CPLUS_REQUIRE_ROS=1 after installing ROS: a lost install step fails, not skips."""
    if os.environ.get("CPLUS_REQUIRE_ROS") == "1":
        assert ROS_INSTALLED, "CPLUS_REQUIRE_ROS=1 but ROS 1 (roscore, rospy) is not installed"


needs_ros = pytest.mark.skipif(not ROS_INSTALLED, reason="ROS 1 is not installed (.ci/run installs it)")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def process_tree(pid: int) -> list[int]:
    """``pid`` and every process below it (roslaunch starts the master in a session of its own)."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(children.get(p, []))
    return out


@contextlib.contextmanager
def ros_master(home: Path, port: int | None = None, kill: bool = False):
    """A roscore on a loopback port (a free one by default), its logs in ``home``; yields the
    environment that names it. ``kill``: it ends by SIGKILL (a crash), not SIGINT."""
    port = port or free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{port}", ROS_HOSTNAME="127.0.0.1",
               ROS_HOME=str(home), ROS_LOG_DIR=str(home / "log"))
    proc = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + wall(60)
        while True:                                  # the master answers XML-RPC on its port
            assert proc.poll() is None, "roscore exited"
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    break
            except OSError:
                assert time.monotonic() < deadline, "roscore did not start"
                time.sleep(0.2)
        yield env
    finally:
        if kill:                                     # a crash: roslaunch and the master and rosout it started
            for pid in process_tree(proc.pid):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
        else:
            os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(wall(30))
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


@pytest.fixture(scope="module")
def roscore(tmp_path_factory):
    with ros_master(tmp_path_factory.mktemp("ros")) as env:
        yield env


CLIENT = textwrap.dedent("""
    import json, sys, time
    import os
    def wall(seconds):   # tests/walltime.py's scale, which conftest exports
        return seconds * float(os.environ.get("CPLUS_TEST_TIME_SCALE", "1"))
    import rospy, actionlib
    from actionlib_msgs.msg import GoalStatus
    from cplus_msgs.msg import ServeAction, ServeGoal
    ns = sys.argv[1]
    rospy.init_node("cplus_test_client", anonymous=True, disable_signals=True)
    client = actionlib.SimpleActionClient(ns, ServeAction)
    out = {"server": client.wait_for_server(rospy.Duration(60))}
    def result(r):
        return {"id": r.id, "status": r.status, "reason": r.reason, "cycle": r.cycle, "done_cycle": r.done_cycle}
    feedback = []
    client.send_goal(ServeGoal(request="deliver(office4,office1)"),
                     feedback_cb=lambda f: feedback.append({"id": f.id, "cycle": f.cycle,
                                                            "executed": list(f.executed), "plan": list(f.plan)}))
    deadline = time.monotonic() + wall(60)
    while not feedback and time.monotonic() < deadline:
        time.sleep(0.02)
    out["active"] = client.get_state() == GoalStatus.ACTIVE
    client.cancel_goal()
    client.wait_for_result(rospy.Duration(60))
    out["cancelled"] = {"state": client.get_state(), "text": client.get_goal_status_text(),
                        "result": result(client.get_result())}
    out["feedback"] = feedback[0]
    client.send_goal(ServeGoal(request="deliver(office4,basement)"))
    client.wait_for_result(rospy.Duration(60))
    out["rejected"] = {"state": client.get_state(), "text": client.get_goal_status_text(),
                       "result": result(client.get_result())}
    client.send_goal(ServeGoal(request="deliver(office2,office3)"))
    client.wait_for_result(rospy.Duration(60))
    out["succeeded"] = {"state": client.get_state(), "result": result(client.get_result())}
    print(json.dumps(out))
""")


def client_python() -> list[str]:
    """Debian's Python runs rospy as installed; another one needs dist-packages on its path."""
    return ["/usr/bin/python3"] if Path("/usr/bin/python3").exists() else [sys.executable]


@pytest.mark.slow
@needs_ros
def test_an_actionlib_client_sends_hears_cancels_and_gets_results(roscore, tmp_path):
    log = tmp_path / "run.jsonl"
    server = subprocess.Popen([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "mailbot.cp"), "--ros",
                               "--ros-name", "mailbot", "--action-time", "0.3", "--log", str(log)],
                              env=dict(roscore, PYTHONUNBUFFERED="1", **ORDERLY_STOP), stderr=subprocess.PIPE, text=True)
    try:
        for line in server.stderr:
            if "ROS action server" in line:
                break
        assert line.startswith("cplus serve: ROS action server /mailbot (cplus_msgs/Serve) at http://127.0.0.1:")
        env = dict(roscore, PYTHONPATH=os.pathsep.join([MSG_PATH, DIST]))
        r = subprocess.run([*client_python(), "-c", CLIENT, "/mailbot"], env=env, capture_output=True, text=True,
                           timeout=wall(300))
        assert r.returncode == 0, r.stderr
        out = json.loads(r.stdout.strip().splitlines()[-1])
        assert out["server"] and out["active"]
        fb = out["feedback"]
        assert fb["id"] == 1 and fb["cycle"] >= 1 and len(fb["executed"]) == 1 and fb["executed"][0].startswith("move")
        assert fb["plan"][-1] == "deliver(1)"
        PREEMPTED, SUCCEEDED, REJECTED = 2, 3, 5    # actionlib_msgs/GoalStatus
        assert out["cancelled"]["state"] == PREEMPTED
        assert out["cancelled"]["result"]["id"] == 1 and out["cancelled"]["result"]["status"] == "preempted"
        assert out["rejected"]["state"] == REJECTED
        assert out["rejected"]["text"] == "basement is not an office (office1, office2, office3, office4)"
        assert out["rejected"]["result"] == {"id": 2, "status": "rejected", "cycle": 0, "done_cycle": 0,
                                             "reason": out["rejected"]["text"]}
        assert out["succeeded"]["state"] == SUCCEEDED and out["succeeded"]["result"]["status"] == "succeeded"
        assert out["succeeded"]["result"]["id"] == 3 and out["succeeded"]["result"]["done_cycle"] > 0

        # from the command line: rostopic publishes a goal of the type generated at run time
        env = dict(roscore, PYTHONPATH=MSG_PATH)
        pub = subprocess.run(["rostopic", "pub", "-1", "/mailbot/goal", "cplus_msgs/ServeActionGoal",
                              '{goal_id: {id: "from-the-shell"}, goal: {request: "deliver(office1,office2)"}}'],
                             env=env, capture_output=True, text=True, timeout=wall(120))
        assert pub.returncode == 0, pub.stderr
        for line in server.stderr:
            if "goal 4 deliver(office1,office2): succeeded" in line:
                break
        server.send_signal(signal.SIGTERM)
        server.wait(wall(60))
    finally:
        if server.poll() is None:
            server.kill()
            server.wait()
    assert server.returncode == 0
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert [(g["id"], g["status"]) for g in lines[-1]["goals"]] == [(1, "preempted"), (2, "rejected"),
                                                                    (3, "succeeded"), (4, "succeeded")]


STATES = textwrap.dedent("""
    import json, sys, time
    import os
    def wall(seconds):   # tests/walltime.py's scale, which conftest exports
        return seconds * float(os.environ.get("CPLUS_TEST_TIME_SCALE", "1"))
    import rospy, actionlib
    from actionlib import CommState
    from actionlib_msgs.msg import GoalStatus
    from cplus_msgs.msg import ServeAction, ServeGoal
    ns = sys.argv[1]
    rospy.init_node("cplus_test_states", anonymous=True, disable_signals=True)
    ac = actionlib.ActionClient(ns, ServeAction)
    assert ac.wait_for_server(rospy.Duration(60))
    requests = ["deliver(office4,office1)", "deliver(office3,office1)", "deliver(office2,office1)",
                "deliver(office1,office4)", "deliver(office1,office3)"]
    goals = [ac.send_goal(ServeGoal(request=r)) for r in requests]

    def wait(pred):
        deadline = time.monotonic() + wall(120)
        while not pred():
            assert time.monotonic() < deadline, [g.get_goal_status() for g in goals]
            time.sleep(0.02)

    # three in flight (three packages at most), two pending; each acknowledged by the server
    wait(lambda: [g.get_goal_status() for g in goals] == [GoalStatus.ACTIVE] * 3 + [GoalStatus.PENDING] * 2
         and all(g.get_comm_state() != CommState.WAITING_FOR_GOAL_ACK for g in goals))
    goals[3].cancel()                       # still pending: recalled
    wait(lambda: goals[3].get_comm_state() == CommState.DONE)

    def final(g):
        r = g.get_result()
        return {"state": g.get_goal_status(), "text": g.get_goal_status_text(),
                "result": None if r is None else {"status": r.status, "reason": r.reason}}
    out = {"recalled": final(goals[3])}
    print("ready", flush=True)              # the test stops the server now
    wait(lambda: all(g.get_comm_state() == CommState.DONE for g in goals))
    out["active"], out["pending"] = final(goals[0]), final(goals[4])
    print(json.dumps(out), flush=True)
""")


@pytest.mark.slow
@needs_ros
def test_recalled_and_pending_at_the_stop_are_the_states_docs_serve_says(roscore, tmp_path):
    """A goal cancelled while pending is RECALLED (result status "recalled"); when the server
    stops, an active goal is ABORTED and a pending one REJECTED (actionlib aborts active goals
    only), both with result status "aborted": the states docs/serve.md gives."""
    doc = " ".join((ROOT / "docs" / "serve.md").read_text().split())
    assert "a goal still pending when the server stops is REJECTED for actionlib (which aborts active goals only), " \
           "with the result status `aborted` and the reason" in doc
    assert "client.cancel_goal() # the goal ends PREEMPTED or RECALLED (the log says which)" in doc
    assert ("| RECALLED (8) | `status \"recalled\"`, `reason \"cancelled by ros before it started\"` | cancelled "
            "while pending in the server |") in doc
    server = subprocess.Popen([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "mailbot.cp"), "--ros",
                               "--ros-name", "states", "--action-time", "1"],
                              env=dict(roscore, PYTHONUNBUFFERED="1", **ORDERLY_STOP), stderr=subprocess.PIPE, text=True)
    client = None
    try:
        for line in server.stderr:
            if "ROS action server" in line:
                break
        env = dict(roscore, PYTHONPATH=os.pathsep.join([MSG_PATH, DIST]))
        client = subprocess.Popen([*client_python(), "-c", STATES, "/states"], env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
        assert client.stdout is not None
        assert client.stdout.readline() == "ready\n", client.stderr.read() if client.stderr else ""
        server.send_signal(signal.SIGTERM)
        out_text, err_text = client.communicate(timeout=wall(120))
        assert client.returncode == 0, err_text
        server.wait(wall(60))
    finally:
        for proc in (client, server):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
    assert server.returncode == 0
    out = json.loads(out_text.strip().splitlines()[-1])
    ABORTED, REJECTED, RECALLED = 4, 5, 8       # actionlib_msgs/GoalStatus
    assert out["recalled"]["state"] == RECALLED and out["recalled"]["result"]["status"] == "recalled"
    assert out["recalled"]["result"]["reason"].endswith("before it started")
    assert out["active"]["state"] == ABORTED and out["active"]["result"]["status"] == "aborted"
    assert out["pending"]["state"] == REJECTED and out["pending"]["result"]["status"] == "aborted"
    assert out["pending"]["result"]["reason"].startswith("the server stopped (ended on request at cycle ")
    assert out["pending"]["text"] == out["pending"]["result"]["reason"]


ONE_GOAL = textwrap.dedent("""
    import json, sys
    import rospy, actionlib
    from cplus_msgs.msg import ServeAction, ServeGoal
    rospy.init_node("cplus_test_after_restart", anonymous=True, disable_signals=True)
    client = actionlib.SimpleActionClient(sys.argv[1], ServeAction)
    out = {"server": client.wait_for_server(rospy.Duration(60))}
    client.send_goal(ServeGoal(request=sys.argv[2]))
    client.wait_for_result(rospy.Duration(120))
    r = client.get_result()
    out.update(state=client.get_state(), status=r.status if r else None, id=r.id if r else None)
    print(json.dumps(out))
""")


@pytest.mark.slow
@needs_ros
def test_the_server_registers_again_when_the_master_restarts(tmp_path):
    """roscore killed and started again while a goal runs: the server sees that the new master
    does not know it, registers its action server again (one line on stderr), the goal in
    flight finishes, and a new client's goal succeeds."""
    home = tmp_path / "ros"
    port = free_port()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([MSG_PATH, DIST]))
    with ros_master(home, port, kill=True) as master:
        server = subprocess.Popen([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "mailbot.cp"), "--ros",
                                   "--action-time", "0.3", "--listen", "127.0.0.1:0"],
                                  env=dict(master, PYTHONUNBUFFERED="1", **ORDERLY_STOP), stderr=subprocess.PIPE, text=True)
        assert server.stderr is not None
        for line in server.stderr:
            m = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
            if m:
                address = ("127.0.0.1", int(m.group(1)))
            if "ROS action server" in line:
                break
        first = subprocess.Popen([*client_python(), "-c", ONE_GOAL, "/cplus_serve", "deliver(office4,office1)"],
                                 env=dict(env, **{k: master[k] for k in ("ROS_MASTER_URI", "ROS_HOSTNAME")}),
                                 stdout=subprocess.PIPE, text=True)
        for line in server.stderr:
            if "goal 1 deliver(office4,office1): active" in line:
                break
    try:
        with ros_master(home, port) as master:      # the same address, a master that knows nobody
            for line in server.stderr:
                if "registered its action server again" in line:
                    break
            assert "did not know this node (restarted)" in line
            r = subprocess.run([*client_python(), "-c", ONE_GOAL, "/cplus_serve", "deliver(office2,office3)"],
                               env=dict(env, **{k: master[k] for k in ("ROS_MASTER_URI", "ROS_HOSTNAME")}),
                               capture_output=True, text=True, timeout=300)
            assert r.returncode == 0, r.stderr
            out = json.loads(r.stdout.strip().splitlines()[-1])
            assert out == {"server": True, "state": 3, "status": "succeeded", "id": 2}
            with socket.create_connection(address, timeout=60) as s:   # the goal in flight went on
                f = s.makefile("rw")
                while True:
                    f.write(json.dumps({"status": 1}) + "\n")
                    f.flush()
                    got = json.loads(f.readline())
                    if got["status"] != "active":
                        break
            assert got["status"] == "succeeded"
            server.send_signal(signal.SIGTERM)
            assert server.wait(60) == 0
    finally:
        for proc in (server, first):
            if proc.poll() is None:
                proc.kill()
                proc.wait()
