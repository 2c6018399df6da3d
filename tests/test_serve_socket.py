"""The JSON-lines socket of ``cplus serve``: real TCP connections on the loopback interface to a
server running in a thread (a simulated robot whose actions take a few milliseconds), and
``cplus serve`` as a process stopped by SIGTERM."""
from __future__ import annotations

import json
import os
import re
import selectors
import shutil
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest
from walltime import ORDERLY_STOP, wall

from cplus.api import Domain
from cplus.robot.online.loop import OnlineStatus
from cplus.robot.serving import socket_channel
from cplus.robot.serving.goals import GoalBoard, GoalStatus
from cplus.robot.serving.reactive import Server, ServerSettings
from cplus.robot.serving.socket_channel import MAX_LINE, SocketChannel, SocketLimits, parse_listen
from cplus.robot.serving.socket_client import _Client
from cplus.robot.serving.vocabulary import load_requests

ROOT = Path(__file__).resolve().parent.parent
MAILBOT = ROOT / "domains" / "mailbot"


class Client:
    """A line-oriented TCP client."""

    def __init__(self, address: tuple[str, int]) -> None:
        self.sock = socket.create_connection(address, timeout=60)
        self.rfile = self.sock.makefile("rb")

    def send(self, obj) -> None:
        data = obj if isinstance(obj, bytes) else (json.dumps(obj) + "\n").encode()
        self.sock.sendall(data)

    def line(self) -> dict:
        raw = self.rfile.readline()
        assert raw, "the server hung up"
        return json.loads(raw)

    def until(self, kind: str, goal: int | None = None) -> list[dict]:
        """Every line up to the first of ``kind`` (for ``goal``), that one included."""
        out = []
        while True:
            x = self.line()
            out.append(x)
            if x["type"] == kind and (goal is None or x.get("id") == goal):
                return out

    def close(self) -> None:
        self.rfile.close()
        self.sock.close()


@pytest.fixture
def server():
    d = Domain.load(str(MAILBOT / "mailbot.cp"))
    srv = Server(d, load_requests(str(MAILBOT / "requests.toml"), d), ServerSettings(action_time=0.005, idle_poll_s=0.01))
    address = srv.listen("127.0.0.1", 0)
    box: list = []
    thread = threading.Thread(target=lambda: box.append(srv.run()), daemon=True)
    thread.start()
    srv.address = address
    yield srv
    srv.stop()
    thread.join(wall(30))
    assert box and box[0].status is OnlineStatus.STOPPED


def test_a_request_is_answered_with_its_id_status_feedback_and_result(server):
    c = Client(server.address)
    c.send({"request": "deliver(office3,office2)"})
    lines = c.until("result", 1)
    assert lines[0] == {"type": "goal", "id": 1, "request": "deliver(office3,office2)", "status": "pending"}
    assert lines[1]["type"] == "status" and lines[1]["status"] == "active" and lines[1]["slot"] == 1
    feedback = [x for x in lines if x["type"] == "feedback"]
    assert [x["executed"] for x in feedback] == [["move(office2)"], ["move(office3)"], ["pickup(1)"],
                                                 ["move(office2)"], ["deliver(1)"]]
    assert feedback[0]["plan"] == [["move(office3)"], ["pickup(1)"], ["move(office2)"], ["deliver(1)"]]
    assert feedback[-1]["plan"] == [] and all(x["id"] == 1 for x in feedback)
    assert lines[-1]["status"] == "succeeded" and lines[-1]["done_cycle"] == feedback[-1]["cycle"] + 1
    c.send({"status": 1})
    assert c.line()["status"] == "succeeded"
    c.close()


def test_bad_lines_get_an_error_and_the_connection_goes_on(server):
    c = Client(server.address)
    c.send(b"deliver(office3,office2)\n")
    assert c.line() == {"type": "error", "message": "not JSON: Expecting value at column 1"}
    c.send({"request": 7})
    assert c.line()["message"].startswith("\"request\" must be a string")
    c.send({"cancel": 99})
    assert c.line() == {"type": "error", "message": "no goal 99"}
    c.send({"request": "x", "cancel": 1})
    assert c.line()["message"].startswith("send one of")
    c.send(b"\xff\xfe\n")
    assert c.line() == {"type": "error", "message": "not UTF-8 text"}
    c.send(b"x" * 70000 + b"\n")
    assert c.line()["message"] == "line longer than 65536 bytes, dropped"
    c.send({"request": "deliver(office3,office9)"})
    assert c.line() == {"type": "goal", "id": 1, "request": "deliver(office3,office9)", "status": "rejected",
                        "reason": "office9 is not an office (office1, office2, office3, office4)"}
    c.send({"request": "deliver(office1,office2)"})
    assert c.until("result", 2)[-1]["status"] == "succeeded"
    c.close()


def test_a_client_that_disconnects_mid_goal_leaves_it_running(server):
    a = Client(server.address)
    a.send({"request": "deliver(office4,office1)"})
    assert a.line()["status"] == "pending"
    assert a.until("feedback", 1)[-1]["cycle"] >= 1
    a.close()                                   # gone, with its goal in flight
    b = Client(server.address)
    b.send({"request": "deliver(office2,office3)"})
    b.until("result", 2)
    while True:                                 # goal 1 finishes although nobody listens
        b.send({"status": 1})
        x = b.line()
        if x["status"] not in ("pending", "active"):
            break
    assert x["status"] == "succeeded"
    assert server.board.goals[1].status.value == "succeeded"
    b.close()


def test_a_client_cancels_a_goal_and_its_owner_hears_the_preemption(server):
    owner, other = Client(server.address), Client(server.address)
    owner.send({"request": "deliver(office4,office1)"})
    owner.until("feedback", 1)
    other.send({"cancel": 1})
    reply = other.line()
    assert reply["type"] == "cancel" and reply["id"] == 1 and reply["status"] in ("preempting", "preempted")
    lines = owner.until("result", 1)
    assert lines[-1]["status"] == "preempted" and lines[-1]["reason"] == "cancelled"
    other.send({"cancel": 1})                   # a final goal stays as it is
    assert other.line()["status"] == "preempted"
    owner.close()
    other.close()


def test_a_cancellation_is_answered_before_the_result_it_causes():
    """A pending goal is recalled at once, and the board's dispatcher tells its owner while the
    I/O thread is still answering the cancel line: the answer comes first all the same. No
    loop runs here, so every goal stays pending until it is cancelled."""
    from cplus.robot.serving.goals import GoalBoard
    from cplus.robot.serving.socket_channel import SocketChannel
    d = Domain.load(str(MAILBOT / "mailbot.cp"))
    board = GoalBoard(load_requests(str(MAILBOT / "requests.toml"), d))
    channel = SocketChannel(board)
    c = Client(channel.start())
    try:
        for gid in range(1, 31):
            c.send({"request": "deliver(office3,office2)"})
            assert c.line() == {"type": "goal", "id": gid, "request": "deliver(office3,office2)", "status": "pending"}
            c.send({"cancel": gid})
            answer, result = c.line(), c.line()
            assert (answer["type"], answer["id"], answer["status"]) == ("cancel", gid, "recalled")
            assert (result["type"], result["id"], result["status"]) == ("result", gid, "recalled")
            assert result["reason"] == "cancelled by 127.0.0.1:" + str(c.sock.getsockname()[1]) + " before it started"
    finally:
        c.close()
        channel.close()
        board.close()


def test_an_ipv6_address_is_printed_as_listen_takes_it():
    from cplus.cli.serve import address_text
    assert address_text("::1", 39429) == "[::1]:39429" and address_text("127.0.0.1", 7070) == "127.0.0.1:7070"
    assert parse_listen(address_text("::1", 39429)) == ("::1", 39429)
    try:
        socket.create_server(("::1", 0), family=socket.AF_INET6).close()
    except OSError:
        pytest.skip("no IPv6 loopback here")
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "mailbot.cp"), "--listen",
                             "[::1]:0"], stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1", **ORDERLY_STOP))
    try:
        assert proc.stderr is not None
        line = next(x for x in proc.stderr if "listening on" in x)
        printed = line.split("listening on ")[1].split()[0]
        assert printed.startswith("[::1]:") and parse_listen(printed)[0] == "::1"
        c = Client(("::1", parse_listen(printed)[1]))
        c.send({"status": 1})
        assert c.line() == {"type": "error", "message": "no goal 1"}
        c.close()
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=wall(60))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0


def test_listen_addresses_are_loopback_only():
    assert parse_listen("127.0.0.2:0") == ("127.0.0.2", 0)
    with pytest.raises(ValueError) as e:
        parse_listen("0.0.0.0:7070")
    assert str(e.value) == ("0.0.0.0 is not a loopback address: the socket has no authentication, so it listens on "
                            "loopback addresses only (127.0.0.0/8 or ::1)")
    assert parse_listen("127.0.0.1:0") == ("127.0.0.1", 0)
    assert parse_listen("localhost:7070") == ("127.0.0.1", 7070)
    assert parse_listen("[::1]:7070") == ("::1", 7070)
    for bad in ("0.0.0.0:7070", "192.168.1.2:80", "example.org:80", "127.0.0.1", "127.0.0.1:99999", ":80"):
        with pytest.raises(ValueError):
            parse_listen(bad)


@pytest.mark.slow
def test_the_command_serves_a_socket_until_sigterm(tmp_path):
    log = tmp_path / "run.jsonl"
    env = dict(os.environ, PYTHONUNBUFFERED="1", **ORDERLY_STOP)
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "serve", str(MAILBOT / "mailbot.cp"), "--listen",
                             "127.0.0.1:0", "--action-time", "1", "--log", str(log)],
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        address = None
        for line in proc.stderr:
            if "listening on" in line:
                host, port = line.split("listening on ")[1].split()[0].rsplit(":", 1)
                address = (host, int(port))
                break
        assert address is not None
        c = Client(address)
        c.send({"request": "deliver(office3,office9)"})
        assert c.line()["status"] == "rejected"
        c.send({"request": "deliver(office1,office4)"})        # five actions of a second each
        c.until("feedback", 2)
        proc.send_signal(signal.SIGTERM)        # the goal in flight is aborted, the client told
        last = c.until("result", 2)[-1]
        assert last["status"] == "aborted" and last["reason"].startswith("the server stopped (ended on request at cycle ")
        _, rest = proc.communicate(timeout=wall(60))
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    assert lines[0]["record"] == "start" and lines[-1]["record"] == "end"
    assert lines[-1]["status"] == "stopped"
    assert [(g["id"], g["status"]) for g in lines[-1]["goals"]] == [(1, "rejected"), (2, "aborted")]
    assert "aborted" in rest and "stopped" in rest
    end = re.search(r"cplus serve: stopped: ended on request at cycle (\d+); (\d+) cycles? ran, ", rest)
    assert end and end[1] == end[2], rest      # one word for how it ended, one count of cycles


def test_the_python_line_of_docs_serve_talks_to_the_socket(server):
    """The docs' way without netcat: Python alone, run as written (the port is the test's)."""
    doc = (ROOT / "docs" / "serve.md").read_text()
    line = next(x for x in doc.splitlines() if x.startswith("python3 -c 'import json, socket;"))
    assert "| nc -q 30 127.0.0.1 7070" in doc and "| socat -t 30 - TCP:127.0.0.1:7070" in doc
    code = line[len("python3 -c '"):-1].replace("7070", str(server.address[1]))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=wall(120))
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in r.stdout.splitlines()]
    assert lines[0] == {"type": "goal", "id": 1, "request": "deliver(office3,office2)", "status": "pending"}
    assert lines[-1]["type"] == "result" and lines[-1]["status"] == "succeeded"


@pytest.mark.parametrize("tool", ["nc -q 30", "socat -t 30"])
def test_the_docs_nc_and_socat_lines_hear_their_goal_to_its_result(server, tool):
    """A client that shuts its writing side after its request (netcat's -q, socat's -t) gets its
    goal's lines until the result, then the server hangs up: the docs' lines, run as written."""
    program = tool.split()[0]
    if shutil.which(program) is None:
        pytest.skip(f"{program} is not installed (.ci/run installs it)")
    doc = (ROOT / "docs" / "serve.md").read_text()
    line = next(x for x in doc.splitlines() if x.startswith("printf ") and f"| {tool} " in x)
    command = line.replace("7070", str(server.address[1]))
    r = subprocess.run(["sh", "-c", command], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in r.stdout.splitlines()]
    assert lines[0] == {"type": "goal", "id": 1, "request": "deliver(office3,office2)", "status": "pending"}
    assert [x["status"] for x in lines if x["type"] == "status"] == ["active"]
    assert [x["type"] for x in lines].count("feedback") >= 5
    assert lines[-1]["type"] == "result" and lines[-1]["status"] == "succeeded"


def test_a_half_closed_client_keeps_hearing_its_goals_then_the_server_hangs_up(server):
    a = Client(server.address)
    a.send({"request": "deliver(office4,office1)"})
    a.send({"request": "deliver(office2,office3)"})
    a.send({"status": 1})
    a.sock.shutdown(socket.SHUT_WR)             # nothing more to say; still listening
    got = []
    while raw := a.rfile.readline():            # until the server hangs up
        got.append(json.loads(raw))
    assert [x["id"] for x in got if x["type"] == "goal"] == [1, 2]
    results = {x["id"]: x["status"] for x in got if x["type"] == "result"}
    assert results == {1: "succeeded", 2: "succeeded"} and got[-1]["type"] == "result"
    a.close()
    # a client that hangs up altogether is let go too (its goal goes on)
    b = Client(server.address)
    b.send({"request": "deliver(office1,office2)"})
    assert b.line()["status"] == "pending"
    b.close()
    c = Client(server.address)
    while True:
        c.send({"status": 3})
        if c.line()["status"] == "succeeded":
            break
    c.close()


# ---------------------------------------------------------------- the channel's limits, unit by unit
# A channel not started, its I/O thread's steps (_read, _work) called here on one end of a
# socketpair; the other end is the client. The board is a bare GoalBoard (no loop).

@pytest.fixture(scope="module")
def mailbot():
    d = Domain.load(str(MAILBOT / "mailbot.cp"))
    return load_requests(str(MAILBOT / "requests.toml"), d)


@pytest.fixture
def unit(mailbot):
    board = GoalBoard(mailbot)
    channel = SocketChannel(board, limits=SocketLimits(lines_per_round=64))
    channel._sel = selectors.DefaultSelector()
    ours, theirs = socket.socketpair()
    ours.setblocking(False)
    theirs.settimeout(wall(30))
    client = _Client(channel, ours, "peer")
    channel._clients.add(client)
    yield SimpleNamespace(board=board, channel=channel, client=client, peer=theirs,
                          answers=lambda: [json.loads(x) for x in bytes(client.out).splitlines()])
    client.close()
    theirs.close()
    channel._sel.close()
    board.close()


def test_a_line_of_max_line_bytes_is_taken_and_one_byte_more_is_dropped(unit):
    c = unit.client
    c.inbuf += b"a" * MAX_LINE + b"\n" + b"b" * (MAX_LINE + 1) + b"\n" + b"c\n"
    assert c.next_line() == b"a" * MAX_LINE
    assert c.next_line() == b"c" and c.next_line() is None
    assert unit.answers() == [{"type": "error", "message": f"line longer than {MAX_LINE} bytes, dropped"}]


def test_an_unfinished_line_may_hold_max_line_bytes_and_no_more(unit):
    c = unit.client
    c.inbuf += b"a" * MAX_LINE                     # not over the limit: kept for its newline
    assert c.next_line() is None and not c.discarding and c.unhandled() == MAX_LINE
    c.inbuf += b"\n"
    assert c.next_line() == b"a" * MAX_LINE and unit.answers() == []
    c.inbuf += b"b" * (MAX_LINE + 1)               # over it: dropped up to its newline
    assert c.next_line() is None and c.discarding and c.unhandled() == 0
    c.inbuf += b"bbb\nc\n"
    assert c.next_line() == b"c" and not c.discarding
    assert unit.answers() == [{"type": "error", "message": f"line longer than {MAX_LINE} bytes, dropped"}]
    c.out.clear()
    c.inbuf += b"\n" + b"d" * (MAX_LINE - 1)      # what is left after a line is what counts
    assert c.next_line() == b"" and c.next_line() is None and not c.discarding
    assert c.unhandled() == MAX_LINE - 1 and unit.answers() == []


def test_a_last_line_without_its_newline_is_answered(unit):
    unit.peer.sendall(b'{"status": 1}\n{"status": 2}')
    unit.peer.shutdown(socket.SHUT_WR)
    while not unit.client.eof:
        unit.channel._read(unit.client)
    unit.channel._work()
    assert unit.client not in unit.channel._clients          # answered, then hung up: no goals of its own
    got = [json.loads(x) for x in unit.peer.makefile("rb").read().splitlines()]
    assert got == [{"type": "error", "message": "no goal 1"}, {"type": "error", "message": "no goal 2"}]


def test_an_unfinished_line_is_given_up_after_line_timeout_not_at_it(unit, monkeypatch):
    now = [1000.0]
    monkeypatch.setattr(socket_channel.time, "monotonic", lambda: now[0])
    timeout = unit.channel.limits.line_timeout
    unit.client.inbuf += b'{"status": 1'
    unit.channel._work()
    now[0] += timeout                              # exactly the limit: still waiting
    unit.channel._work()
    assert not unit.client.hangup and unit.answers() == []
    now[0] += 0.001
    unit.channel._work()
    assert unit.answers() == [{"type": "error", "message": f"a line left without its newline for {timeout:g} s: "
                                                           "disconnected"}]
    assert unit.client.hangup and unit.client.eof


def test_a_client_pauses_once_pause_bytes_are_unsent_or_unread(unit):
    c, limit = unit.client, unit.channel.limits.pause_bytes
    c.out += b"x" * (limit - 1)
    assert not c.busy()
    unit.channel._work()
    assert c.mask == selectors.EVENT_READ | selectors.EVENT_WRITE
    c.out += b"x"                                  # the limit itself: its lines wait
    assert c.busy()
    unit.channel._work()
    assert c.mask == selectors.EVENT_WRITE
    c.out.clear()
    unit.channel.limits = SocketLimits(lines_per_round=1)   # one line a round: the rest stays unread
    for left, mask in ((limit - 1, selectors.EVENT_READ), (limit, 0)):
        c.inbuf, c.pos = bytearray(b"\n" + b" " * (left - 1) + b"\n"), 0
        unit.channel._work()
        assert c.unhandled() == left and c.mask == mask


@pytest.mark.parametrize("value", [True, False, 1.0, "1", None, [1]])
def test_a_goal_id_is_an_integer_and_not_a_boolean(unit, value):
    goal = unit.board.submit("deliver(office1,office2)")
    assert goal.id == 1
    for key in ("cancel", "status"):
        unit.client.handle(json.dumps({key: value}).encode(), unit.board)
    assert unit.answers() == [{"type": "error", "message": f"\"{key}\" takes a goal id (an integer)"}
                              for key in ("cancel", "status")]
    assert goal.status is GoalStatus.PENDING


class LongSelect:
    """The I/O thread's selector with its idle timeout made endless: only a wake (or a socket)
    ends a select that may wait, so a missing wake hangs the test instead of costing 0.5 s."""

    def __init__(self, channel: SocketChannel) -> None:
        self.real = channel._sel.select
        self.entered = threading.Event()
        self.timeouts: list = []
        channel._sel.select = self.select

    def select(self, timeout=None):
        self.timeouts.append(timeout)
        self.entered.set()
        return self.real(None if timeout else 0)


def test_close_wakes_the_io_thread(mailbot):
    board = GoalBoard(mailbot)
    channel = SocketChannel(board)
    channel.start()
    spy = LongSelect(channel)
    Client(channel.address).close()               # a round, so that the endless select is entered
    assert spy.entered.wait(wall(30))
    channel.close(timeout=wall(30))
    assert not channel._thread.is_alive(), "close() left the I/O thread in its select"
    assert 0.5 in spy.timeouts and all(t in (0, 0.5) for t in spy.timeouts)   # idle: it waits, never spins
    board.close()


def test_what_is_queued_for_a_client_is_sent_before_the_channel_hangs_up(unit):
    unit.client.answer({"type": "error", "message": "last words"})
    unit.channel._shutdown()
    assert unit.peer.makefile("rb").read() == b'{"type":"error","message":"last words"}\n'
    assert unit.client.closed


def test_lines_beyond_a_round_are_handled_without_waiting_for_the_next_select(mailbot):
    board = GoalBoard(mailbot)
    channel = SocketChannel(board, limits=SocketLimits(lines_per_round=2))
    channel.start()
    LongSelect(channel)
    c = Client(channel.address)
    c.sock.settimeout(wall(30))
    c.send(b"".join(b'{"status": %d}\n' % i for i in range(1, 8)))    # 7 lines in one send
    assert [c.line() for _ in range(7)] == [{"type": "error", "message": f"no goal {i}"} for i in range(1, 8)]
    c.close()
    channel.close(timeout=wall(30))
    board.close()


def test_listen_ports_are_0_to_65535():
    assert parse_listen("127.0.0.1:65535") == ("127.0.0.1", 65535)
    assert parse_listen("127.0.0.1:0") == ("127.0.0.1", 0)
    assert parse_listen("[::1]:00001") == ("::1", 1)
    for bad in ("127.0.0.1:65536", "127.0.0.1:065535", "127.0.0.1:-1", "127.0.0.1:", "127.0.0.1"):
        with pytest.raises(ValueError, match="expected HOST:PORT"):
            parse_listen(bad)


def test_a_client_is_disconnected_past_out_bytes_unsent_not_at_it(unit):
    c = unit.client
    line = len(json.dumps({"type": "error", "message": "x"}, separators=(",", ":"))) + 1
    unit.channel.limits = SocketLimits(out_bytes=2 * line)
    c.answer({"type": "error", "message": "x"})
    c.answer({"type": "error", "message": "x"})   # exactly out_bytes kept: still a client
    assert len(c.out) == 2 * line and not c.overflow
    c.answer({"type": "error", "message": "x"})   # one line more: it does not read, it goes
    assert c.overflow and len(c.out) == 2 * line
    unit.channel._work()
    assert unit.client not in unit.channel._clients
    got = unit.peer.makefile("rb").read()
    assert got.endswith(b'{"type":"error","message":"answers not read (more than %d bytes waiting): '
                        b'disconnected; your goals go on"}\n' % (2 * line))


def test_a_connection_beyond_the_limit_is_told_why_and_closed(mailbot):
    board = GoalBoard(mailbot)
    channel = SocketChannel(board, limits=SocketLimits(clients=2))
    channel.start()
    a, b = Client(channel.address), Client(channel.address)
    for c in (a, b):                              # both taken: each is answered
        c.send({"status": 1})
        assert c.line() == {"type": "error", "message": "no goal 1"}
    extra = Client(channel.address)
    extra.sock.settimeout(wall(30))
    assert extra.line() == {"type": "error", "message": "too many connections (2 at most): try again when "
                                                        "another client has hung up"}
    assert extra.rfile.readline() == b"" and channel.refused == 1
    extra.close()
    a.close()
    channel.close(timeout=wall(30))
    board.close()
