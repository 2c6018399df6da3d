"""``cplus serve --log`` survives a crash: SIGKILL at random moments while a client sends
requests, cancellations and status queries, then the same command line again, 20 times. Every
goal the client was told of is in the log, every result it heard is the goal's final status
there, goal ids are never reused across the runs, and every line is JSON (a line cut off by
the kill is removed when the log is continued). The moment of each kill is counted in lines
the client received, not in seconds, so the machine's load changes nothing but the run time."""
from __future__ import annotations

import json
import os
import random
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from walltime import ORDERLY_STOP

ROOT = Path(__file__).resolve().parent.parent
DOMAIN = str(ROOT / "domains" / "mailbot" / "mailbot.cp")
OFFICES = ["office1", "office2", "office3", "office4"]

pytestmark = [pytest.mark.slow, pytest.mark.timeout(1200)]


def start(log: Path) -> tuple[subprocess.Popen, int]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), **ORDERLY_STOP}
    proc = subprocess.Popen([sys.executable, "-m", "cplus", "serve", DOMAIN, "--listen", "127.0.0.1:0", "--log",
                             str(log), "--action-time", "0.005", "--quiet"], stderr=subprocess.PIPE, text=True,
                            env=env)
    assert proc.stderr is not None
    for line in proc.stderr:
        m = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
        if m:
            return proc, int(m.group(1))
    raise AssertionError(f"the server did not start (exit {proc.wait()})")


def traffic(port: int, rng: random.Random, budget: int, told: dict[int, str], results: dict[int, str]) -> None:
    """Requests, cancellations and status queries, each read up to its answer (with the goals'
    news that comes before it), until ``budget`` lines have come back."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=60)
    f = sock.makefile("r", encoding="utf-8")
    mine: list[int] = []
    seen = 0
    try:
        while seen < budget:
            what = rng.random()
            if what < 0.5 or not mine:
                a, b = rng.sample(OFFICES, 2)
                sent, answer = {"request": f"deliver({a},{b})"}, "goal"
            elif what < 0.75:
                sent, answer = {"cancel": rng.choice(mine)}, "cancel"
            else:
                sent, answer = {"status": rng.choice(mine)}, "status"
            sock.sendall((json.dumps(sent) + "\n").encode())
            while seen < budget:
                line = f.readline()
                if not line:
                    return
                seen += 1
                msg = json.loads(line)
                if msg["type"] == "goal":
                    mine.append(msg["id"])
                if msg["type"] in ("goal", "status", "cancel", "result"):
                    told[msg["id"]] = msg["status"]
                    if msg["status"] in ("succeeded", "preempted", "recalled", "aborted", "rejected"):
                        results[msg["id"]] = msg["status"]
                if msg["type"] in (answer, "error"):
                    break
    finally:
        sock.close()


def records(log: Path, allow_cut: bool) -> list[dict]:
    text = log.read_text()
    lines = text.split("\n")
    assert lines[-1] == "" or allow_cut, "the log does not end with a whole line"
    out = []
    for line in lines[:-1]:
        out.append(json.loads(line))             # every whole line is JSON
    return out


def test_sigkill_at_random_moments_loses_nothing_a_client_was_told(tmp_path):
    log = tmp_path / "serve.jsonl"
    rng = random.Random(29)
    told: dict[int, str] = {}
    results: dict[int, str] = {}
    for run in range(20):
        proc, port = start(log)
        try:
            traffic(port, rng, rng.randint(1, 60), told, results)
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait(60)
            assert proc.stderr is not None
            proc.stderr.close()
        lines = records(log, allow_cut=True)
        goals = [x for x in lines if x["record"] == "goal"]
        created = [x["id"] for x in goals if x["status"] in ("pending", "rejected") and "slot" not in x
                   and x.get("cycle") is None]
        assert len(created) == len(set(created)), f"run {run}: an id was given twice"
        assert created == sorted(created)
        last = {x["id"]: x["status"] for x in goals}
        assert set(told) <= set(last), f"run {run}: goals a client was told of are not in the log"
        for gid, status in results.items():
            assert last[gid] == status, f"run {run}: goal {gid} was {status} for its client, {last[gid]} in the log"
    proc, port = start(log)                         # once more, and an orderly end
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(60) == 0
    assert proc.stderr is not None
    proc.stderr.close()
    lines = records(log, allow_cut=False)
    starts = [x for x in lines if x["record"] == "start"]
    assert len(starts) == 21 and starts[-1]["continues"] is True
    assert [x["first_goal_id"] for x in starts] == sorted(x["first_goal_id"] for x in starts)
    assert lines[-1]["record"] == "end" and results
