"""``cplus serve --listen`` under stress, from outside: the server as a process (a simulated robot
whose actions take 10 ms), clients on real TCP connections.

* 200 connections at once: those beyond ``--max-clients`` are refused with a reason, the
  others served, and a client that comes later is served;
* a client that writes and never reads: the other clients are served, cycles go on, the log
  grows, SIGTERM ends the server;
* a line without a newline kept open: the others are served meanwhile, and the line is
  answered once its newline comes;
* malformed lines mixed with good ones in one write (a request that made the old request
  regex quadratic, numbers too large for Python's int parser, nesting too deep for json, not
  UTF-8, a line too long): one answer per line, in order, and the good goals succeed;
* a flood of 10,000 requests from one client: each is answered (beyond its share of open
  goals, refused with the reason), another client's request is taken at once, memory stays
  bounded, and no cycle record lists a goal that did not change;
* signals at random moments, a second signal, a loop that never comes back to stop.

Every test asserts that the server exits (0 on SIGTERM) within a bounded time and leaves a
log of complete JSON lines ending with an end record. Waits are for lines read or states
reached, each bounded by a socket or subprocess timeout; nothing is timed."""
from __future__ import annotations

import json
import os
import random
import signal
import socket
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest
from walltime import ORDERLY_STOP, wall

ROOT = Path(__file__).resolve().parent.parent
MAILBOT = ROOT / "domains" / "mailbot"
DOMAIN = str(MAILBOT / "mailbot.cp")

pytestmark = pytest.mark.slow


class Served:
    """A ``cplus serve`` process listening on a free loopback port; its stderr is read all the
    time (a pipe nobody reads would stall it), and kept."""

    def __init__(self, tmp_path: Path, *extra: str, argv: list[str] | None = None,
                 grace: dict[str, str] = ORDERLY_STOP) -> None:
        self.log = tmp_path / "run.jsonl"
        args = argv or [sys.executable, "-m", "cplus", "serve", DOMAIN]
        self.proc = subprocess.Popen([*args, "--listen", "127.0.0.1:0", "--action-time", "0.01", "--log",
                                      str(self.log), "--quiet", *extra],
                                     env=dict(os.environ, PYTHONUNBUFFERED="1", **grace), stderr=subprocess.PIPE,
                                     text=True, start_new_session=True)
        self.err: list[str] = []
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.err.append(line)
            if "listening on" in line:
                host, port = line.split("listening on ")[1].split()[0].rsplit(":", 1)
                self.address = (host, int(port))
                break
        else:
            raise AssertionError("the server did not start: " + "".join(self.err))
        self._drain = threading.Thread(target=lambda: self.err.extend(self.proc.stderr), daemon=True)  # type: ignore[arg-type]
        self._drain.start()

    def memory_kb(self) -> int:
        """The server's peak resident memory (VmHWM)."""
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
        raise AssertionError("no VmHWM")

    def stop(self, sig: int = signal.SIGTERM) -> int:
        try:
            self.proc.send_signal(sig)
            self.proc.wait(wall(30))
        finally:
            if self.proc.poll() is None:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
            self._drain.join(wall(30))
        return self.proc.returncode

    def log_lines(self) -> list[dict]:
        """The log: complete JSON lines, a start record first and an end record last."""
        text = self.log.read_text()
        assert text.endswith("\n")
        lines = [json.loads(x) for x in text.splitlines()]
        assert lines[0]["record"] == "start" and lines[-1]["record"] == "end"
        assert all(x["record"] in ("cycle", "goal") for x in lines[1:-1])
        return lines

    def __enter__(self) -> Served:
        return self

    def __exit__(self, *exc) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()


class Client:
    def __init__(self, address: tuple[str, int], timeout: float = 60, rcvbuf: int | None = None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        if rcvbuf is not None:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
        self.sock.settimeout(timeout)
        self.sock.connect(address)
        self.rfile = self.sock.makefile("rb")

    def send(self, obj) -> None:
        self.sock.sendall(obj if isinstance(obj, bytes) else (json.dumps(obj) + "\n").encode())

    def line(self) -> dict | None:
        raw = self.rfile.readline()
        return json.loads(raw) if raw else None

    def until(self, kind: str, goal: int | None = None) -> list[dict]:
        out = []
        while True:
            x = self.line()
            assert x is not None, f"the server hung up before a {kind} line: {out[-5:]}"
            out.append(x)
            if x["type"] == kind and (goal is None or x.get("id") == goal):
                return out

    def close(self) -> None:
        self.rfile.close()
        self.sock.close()


def final_statuses(lines: list[dict]) -> dict[int, str]:
    last: dict[int, str] = {}
    for line in lines:
        for g in [line] if line["record"] == "goal" else line.get("goals", []):
            last[g["id"]] = g["status"]
    return last


FINAL = {"succeeded", "preempted", "recalled", "aborted", "rejected"}


def test_two_hundred_connections_at_once(tmp_path):
    with Served(tmp_path, "--max-clients", "50") as server:
        clients = [Client(server.address) for _ in range(200)]
        refused = served = 0
        for c in clients:                      # every connection is open at once
            c.send({"request": "deliver(office1,office2)"})
        for c in clients:
            first = c.line()
            if first is not None and first["type"] == "error":
                assert first["message"].startswith("too many connections (50 at most)")
                assert c.line() is None        # then the server hangs up
                refused += 1
            else:
                assert first is not None and first["type"] == "goal", first
                served += 1
        assert (served, refused) == (50, 150)
        for c in clients:
            c.close()
        for _ in range(1000):                  # a later client is served (once the server saw the others go)
            late = Client(server.address)
            late.send({"request": "deliver(office2,office1)"})
            goal = late.line()
            assert goal is not None
            if goal["type"] == "goal":
                break
            late.close()
        assert goal["type"] == "goal"
        assert late.until("result", goal["id"])[-1]["status"] in ("succeeded", "aborted")
        late.close()
        assert server.stop() == 0
        lines = server.log_lines()
    assert set(final_statuses(lines).values()) <= FINAL


def test_a_client_that_never_reads_stalls_nobody(tmp_path):
    with Served(tmp_path) as server:
        mute = Client(server.address, timeout=3, rcvbuf=4096)
        mute.send({"request": "deliver(office4,office1)"})
        written = [0]

        def flood() -> None:                   # requests and status queries until the server stops reading
            line = (b'{"status": 1}\n' * 100 + b'{"request": "deliver(office4,office1)"}\n') * 10
            try:
                while written[0] < 40_000_000:
                    mute.sock.sendall(line)
                    written[0] += len(line)
            except OSError:                    # the send blocked (timeout), or the server hung up
                pass
        writer = threading.Thread(target=flood, daemon=True)
        writer.start()
        writer.join(wall(120))
        assert not writer.is_alive()
        other = Client(server.address)
        ids = []
        for text in ("deliver(office1,office3)", "deliver(office3,office1)"):
            other.send({"request": text})
            goal = other.line()
            assert goal is not None and goal["status"] == "pending"
            ids.append(goal["id"])
            assert other.until("result", goal["id"])[-1]["status"] == "succeeded"
        other.close()
        assert server.stop() == 0
        mute.close()
        lines = server.log_lines()
    finals = final_statuses(lines)
    assert [finals[i] for i in ids] == ["succeeded", "succeeded"] and set(finals.values()) <= FINAL
    assert sum(1 for x in lines if x["record"] == "cycle") > 5


def test_a_line_without_a_newline_kept_open(tmp_path):
    with Served(tmp_path) as server:
        slow = Client(server.address)
        slow.send(b'{"request": "deliver(office1,')
        other = Client(server.address)
        other.send({"request": "deliver(office2,office3)"})
        goal = other.line()
        assert goal is not None and goal["id"] == 1
        assert other.until("result", 1)[-1]["status"] == "succeeded"
        slow.send(b'office4)"}\n')
        assert slow.line() == {"type": "goal", "id": 2, "request": "deliver(office1,office4)", "status": "pending"}
        assert slow.until("result", 2)[-1]["status"] == "succeeded"
        other.close()
        slow.close()
        assert server.stop() == 0
        server.log_lines()


def test_malformed_lines_mixed_with_good_ones(tmp_path):
    lines = [
        b'{"request": "deliver(office1,office2)"}',
        b"not json",
        b'{"request": "deliver' + b" " * 60_000 + b'x"}',           # quadratic in the old request regex
        b'{"status": 1' + b"0" * 5000 + b"}",                       # beyond Python's int digits limit
        b"[" * 30_000 + b"]" * 30_000,                               # beyond json's recursion
        b"\xff\xfe",
        b'{"cancel": 1e400}',
        b'{"request": "deliver(office3,office9)"}',
        b'{"request": "deliver(office\xd9\xa3,office2)"}',           # an Arabic-Indic digit
        b'{"request": "deliver(office2,office1)"}',
        b"x" * 70_000,
    ]
    with Served(tmp_path) as server:
        c = Client(server.address)
        c.send(b"\n".join(lines) + b"\n")
        answers = []
        while len(answers) < len(lines):
            x = c.line()
            assert x is not None
            if x["type"] in ("goal", "error"):
                answers.append(x)
        kinds = [(x["type"], x.get("status")) for x in answers]
        assert kinds == [("goal", "pending"), ("error", None), ("goal", "rejected"), ("error", None), ("error", None),
                         ("error", None), ("error", None), ("goal", "rejected"), ("goal", "rejected"),
                         ("goal", "pending"), ("error", None)]
        assert answers[1]["message"].startswith("not JSON")
        assert "characters" in answers[2]["reason"]
        assert answers[3]["message"].startswith("not JSON") and "digits" in answers[3]["message"]
        assert answers[4]["message"].startswith("not JSON") and "nested" in answers[4]["message"]
        assert answers[5]["message"] == "not UTF-8 text"
        assert answers[6]["message"] == "\"cancel\" takes a goal id (an integer)"
        assert answers[10]["message"] == "line longer than 65536 bytes, dropped"
        ids = [answers[0]["id"], answers[9]["id"]]
        results = {}
        while len(results) < 2:
            x = c.line()
            assert x is not None
            if x["type"] == "result":
                results[x["id"]] = x["status"]
        assert results == {ids[0]: "succeeded", ids[1]: "succeeded"}
        c.close()
        assert server.stop() == 0
        server.log_lines()


def test_a_flood_of_ten_thousand_requests(tmp_path):
    with Served(tmp_path, "--max-client-goals", "8") as server:
        flood = Client(server.address)
        answers: list[dict] = []

        def read() -> None:
            while True:
                x = flood.line()
                if x is None:
                    return
                if x["type"] == "goal":
                    answers.append(x)
                    if len(answers) == 10_000:
                        return
        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        flood.send(b'{"request": "deliver(office1,office4)"}\n' * 10_000)
        other = Client(server.address)
        other.send({"request": "deliver(office4,office1)"})
        ack = other.line()
        assert ack is not None and ack["type"] == "goal" and ack["status"] == "pending"
        assert other.until("result", ack["id"])[-1]["status"] == "succeeded"
        reader.join(wall(300))
        assert len(answers) == 10_000
        refused = [x for x in answers if x["status"] == "rejected"]
        assert refused and all(x["reason"].startswith("this client has 8 goals open") for x in refused)
        memory = server.memory_kb()
        other.close()
        assert server.stop() == 0
        flood.close()
        lines = server.log_lines()
    assert memory < 400_000, f"{memory} kB"
    # a goal record says what changed: a goal appears once per status it took, not once per cycle
    seen: dict[int, int] = {}
    for line in lines[1:-1]:
        if line["record"] == "goal":
            seen[line["id"]] = seen.get(line["id"], 0) + 1
    assert max(seen.values()) <= 4
    assert set(final_statuses(lines).values()) <= FINAL


def busy_client(address, stop: threading.Event) -> None:
    """Requests and cancellations while the server runs, until it hangs up."""
    try:
        c = Client(address, timeout=10)
        i = 0
        while not stop.is_set():
            c.send({"request": f"deliver(office{1 + i % 4},office{1 + (i + 1) % 4})"})
            x = c.line()
            if x is None:
                return
            if i % 3 == 0 and x.get("id"):
                c.send({"cancel": x["id"]})
            i += 1
    except (OSError, ValueError):
        return


@pytest.mark.parametrize("seed", range(4))
def test_signals_at_random_moments(tmp_path, seed):
    rng = random.Random(seed)
    with Served(tmp_path) as server:
        stop = threading.Event()
        clients = [threading.Thread(target=busy_client, args=(server.address, stop), daemon=True) for _ in range(3)]
        for t in clients:
            t.start()
        # a random moment: after a random number of progress events of the log
        wanted = rng.randint(1, 30)
        for _ in range(6000):                  # polling the log file, a minute at most
            if server.log.read_text().count('"record":"cycle"') >= wanted or server.proc.poll() is not None:
                break
            threading.Event().wait(0.01)
        code = server.stop(rng.choice([signal.SIGTERM, signal.SIGINT]))
        stop.set()
        for t in clients:
            t.join(wall(30))
        assert code == 0, "".join(server.err[-20:])
        lines = server.log_lines()
    assert lines[-1]["status"] == "stopped"
    finals = final_statuses(lines)
    assert set(finals.values()) <= FINAL, finals


def test_a_second_signal_ends_at_once(tmp_path):
    with Served(tmp_path) as server:
        server.proc.send_signal(signal.SIGTERM)
        code = server.stop(signal.SIGTERM)
        assert code in (0, 124)                # 0 when the first had ended the run already
        text = server.log.read_text()
    assert text.endswith("\n") and all(json.loads(x) for x in text.splitlines())


STUCK = textwrap.dedent("""
    import sys, threading
    from cplus.robot.online import executors
    def stuck(self, step):                  # a robot that never comes back, whatever it is told
        print("stuck in", [a.text for a in step.acts], file=sys.stderr, flush=True)
        threading.Event().wait()
    executors.SimulatedExecutor.execute = stuck
    from cplus.cli import main
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.parametrize("signals", [1, 2])
def test_a_loop_that_never_comes_back_is_ended_by_the_watchdog(tmp_path, signals):
    """Forced after ``CPLUS_STOP_GRACE`` seconds (0.5 here) by one signal, at once by two."""
    with Served(tmp_path, argv=[sys.executable, "-c", STUCK, "serve", DOMAIN],
                grace={"CPLUS_STOP_GRACE": "0.5"}) as server:
        c = Client(server.address)
        c.send({"request": "deliver(office1,office2)"})
        assert c.until("status")[-1]["status"] == "active"
        for _ in range(6000):                  # until the robot is on its first action (a minute at most)
            if any(line.startswith("stuck in") for line in server.err):
                break
            threading.Event().wait(0.01)
        assert any(line.startswith("stuck in") for line in server.err)
        server.proc.send_signal(signal.SIGTERM)
        if signals == 2:
            server.proc.send_signal(signal.SIGINT)
        server.proc.wait(wall(30))
        c.close()
        assert server.proc.returncode == (143 if signals == 1 else 124)
        lines = server.log_lines()
    assert lines[-1]["status"] == "stopped"
    assert lines[-1]["message"] == ("forced 0.5 s after the signal" if signals == 1 else "forced by a second signal")
    assert final_statuses(lines) == {1: "aborted"}


INSIDE_LOCK = textwrap.dedent("""
    import os, signal, sys
    from cplus.robot.serving import goals
    poll = goals.GoalBoard.poll
    sent = []
    def poll_with_a_signal(self, cycle):      # SIGTERM arrives while the main thread holds the board's lock
        if cycle == 3 and not sent:
            sent.append(1)
            with self._lock:
                os.kill(os.getpid(), signal.SIGTERM)
                for _ in range(1000):         # the handler runs between these bytecodes, lock held
                    pass
        return poll(self, cycle)
    goals.GoalBoard.poll = poll_with_a_signal
    from cplus.cli import main
    sys.exit(main(sys.argv[1:]))
""")


def test_a_signal_while_the_main_thread_holds_the_boards_lock(tmp_path):
    """A handler that stopped the server took the board's lock in the thread that held it (an
    idle server's poll): the main thread and the watchdog behind it waited for ever."""
    with Served(tmp_path, argv=[sys.executable, "-c", INSIDE_LOCK, "serve", DOMAIN]) as server:
        c = Client(server.address)
        c.send({"request": "deliver(office1,office2)"})
        assert server.proc.wait(wall(30)) == 0
        c.close()
        lines = server.log_lines()
    assert lines[-1]["status"] == "stopped"
