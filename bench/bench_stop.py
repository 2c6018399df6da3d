"""Measure Ctrl-C of ``cplus run`` under load: how long the stop takes and which path it took.

``--runs`` times (default 20): start ``cplus run domains/payload/payload.cp --out TMP``
(planning, then two emulated bricks on simulated time; ``--command`` for another, e.g. ``cplus
online``), send SIGINT (or ``--signal
TERM``) at a moment drawn uniformly from the whole job (planning, writing, execution; its
length is measured first, by one run to the end under the same load) and time from the signal
to the process's end (``--after TEXT``: at a moment drawn from the ``--within`` seconds after
a line with TEXT, e.g. ``running``, to look at the execution alone). Per run: the moment, what the job was doing then (the last line on
stderr), the stop time, the exit code, whether the shutdown watchdog's forced path ran
(``the orderly stop took more than``) and whether the execution log is whole (it is written
whole or not at all: a log that exists must parse). Then the summary: how many runs took the
forced path, the median and the maximum stop time, and the load average meanwhile.

``--busy N`` runs it all under N busy processes (``bench/busy.py``). Nothing is asserted.

The child gets SIGINT as a terminal's Ctrl-C would (default disposition, even when this
script runs in the background).

Usage: ``python bench/bench_stop.py [--busy 12] [--runs 20] [--seed 0] [--signal INT|TERM]
[--after TEXT --within SECONDS] [--command ARGS --log NAME]``.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from busy import Busy, load_text  # noqa: E402

FORCED = "the orderly stop took more than"


RUN = "run domains/payload/payload.cp --out {out}"


def command(template: str, out: str) -> list[str]:
    return [sys.executable, "-m", "cplus", *template.format(out=out).split()]


def log_whole(path: Path) -> bool | None:
    """None: no log; whether it parses (JSON, or JSON lines ending with an end record)."""
    if not path.exists():
        return None
    text = path.read_text(encoding="utf-8")
    try:
        if path.suffix == ".jsonl":
            return text.endswith("\n") and json.loads(text.splitlines()[-1]).get("record") == "end" \
                and all(json.loads(line) is not None for line in text.splitlines())
        json.loads(text)
        return True
    except (ValueError, IndexError):
        return False


def env() -> dict[str, str]:
    e = dict(os.environ)
    e["PYTHONPATH"] = str(ROOT) + (os.pathsep + e["PYTHONPATH"] if e.get("PYTHONPATH") else "")
    return e


def whole_run(template: str) -> float:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.monotonic()
        subprocess.run(command(template, out), env=env(), cwd=ROOT, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, check=True)
        return time.monotonic() - t0


def as_in_a_terminal() -> None:
    """In the child: SIGINT as a terminal's Ctrl-C finds it (this script may run in the
    background, where SIGINT is ignored, and a child inherits that)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def one(template: str, log: str, at: float, signum: int, after: str | None) -> dict[str, object]:
    with tempfile.TemporaryDirectory() as out:
        proc = subprocess.Popen(command(template, out), env=env(), cwd=ROOT, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True, preexec_fn=as_in_a_terminal)
        lines: list[str] = []
        marked = threading.Event()

        def read() -> None:
            for line in proc.stderr:  # type: ignore[union-attr]
                lines.append(line)
                if after is not None and after in line:
                    marked.set()
            marked.set()
        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        t0 = time.monotonic()
        if after is not None:
            marked.wait()
        try:
            proc.wait(at)
            sent = None            # it ended before the moment came
        except subprocess.TimeoutExpired:
            doing = lines[-1].strip() if lines else "(nothing on stderr yet)"
            sent = time.monotonic()
            proc.send_signal(signum)
        code = proc.wait()
        ended = time.monotonic()
        reader.join()
        whole = log_whole(Path(out, log))
        return {"at": round(at, 2), "sent": sent is not None,
                "doing": doing if sent is not None else "(ended first)",
                "stop_s": None if sent is None else ended - sent, "code": code,
                "forced": any(FORCED in line for line in lines), "log": whole,
                "elapsed": ended - t0, "tail": "".join(lines[-3:])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--busy", type=int, default=0, help="busy processes meanwhile (bench/busy.py)")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--signal", choices=("INT", "TERM"), default="INT")
    ap.add_argument("--command", default=RUN, metavar="ARGS",
                    help=f"the cplus command, {{out}} for a fresh folder (default {RUN!r}; e.g. "
                         "'online domains/delivery/delivery.cp --log {out}/run.jsonl')")
    ap.add_argument("--log", default="execution.json", metavar="NAME",
                    help="the log in {out} that must be whole (JSON, or JSON lines with an end record)")
    ap.add_argument("--after", metavar="TEXT",
                    help="draw the moment from the --within seconds after a line with TEXT on stderr (e.g. "
                         "'running' for the execution), not from the whole job")
    ap.add_argument("--within", type=float, default=5.0, metavar="SECONDS")
    args = ap.parse_args()
    signum = signal.SIGINT if args.signal == "INT" else signal.SIGTERM
    rng = random.Random(args.seed)
    loads: list[float] = []
    with Busy(args.busy):
        time.sleep(2 if args.busy else 0)
        whole = whole_run(args.command)
        print(f"one whole run: {whole:.1f} s ({args.busy} busy, {load_text()})", flush=True)
        results = []
        print(f"{'#':>3} {'at s':>6} {'stop s':>7} {'code':>4} {'forced':>6} {'log':>5}  doing", flush=True)
        for k in range(args.runs):
            at = rng.uniform(0.0, args.within) if args.after else rng.uniform(0.2, whole)
            r = one(args.command, args.log, at, signum, args.after)
            loads.append(os.getloadavg()[0])
            results.append(r)
            stop = "-" if r["stop_s"] is None else f"{r['stop_s']:.2f}"
            print(f"{k:>3} {r['at']:>6} {stop:>7} {r['code']:>4} {str(r['forced']):>6} {str(r['log']):>5}  "
                  f"{r['doing']}", flush=True)
            if r["sent"] and r["code"] != 128 + signum:
                print("      stderr ends: " + str(r["tail"]).rstrip().replace("\n", "\n      "), flush=True)
    stops = [float(r["stop_s"]) for r in results if r["stop_s"] is not None]  # type: ignore[arg-type]
    forced = sum(1 for r in results if r["forced"])
    codes = sorted({int(r["code"]) for r in results if r["sent"]})  # type: ignore[call-overload]
    broken = sum(1 for r in results if r["log"] is False)
    print(f"\n{len(stops)} of {args.runs} runs signalled (SIG{args.signal}), {args.busy} busy processes, "
          f"load average {min(loads):.1f}..{max(loads):.1f} (1 min)")
    if stops:
        print(f"forced path: {forced}; stop time median {statistics.median(stops):.2f} s, "
              f"max {max(stops):.2f} s; exit codes {codes}; broken logs: {broken}")


if __name__ == "__main__":
    main()
