"""Load the machine with N CPU-bound processes, on their own or for the length of a command.

``python bench/busy.py N`` starts N busy processes and keeps them until SIGINT or SIGTERM;
``python bench/busy.py N -- CMD ARG...`` keeps them while CMD runs, then stops them and exits
with CMD's exit code (a signal to this process reaches CMD as well, since it shares the
terminal's process group, and the load ends with it). Either way the load average is printed
on stderr when the load starts and every ``--report`` seconds, and at the end, so a note can
say what the machine saw.

Each busy process is ``python -c`` running a loop that checks every few milliseconds whether
its parent still lives: if this script is killed outright (SIGKILL, a crashed shell) the busy
processes end on their own within a second, instead of loading the machine for ever.

Why processes and not threads: a thread of this interpreter shares one lock; N processes keep
N cores' worth of runnable work, which is what a loaded build machine looks like to the
scheduler (the load average counts runnable processes).

Examples::

    python bench/busy.py 12 &                        # 12 busy processes until killed
    python bench/busy.py 12 -- python -m pytest -q -n 2 tests/test_interrupts.py
    CPLUS_TEST_TIME_SCALE=8 python bench/busy.py 24 -- python -m pytest -q -n 2

Nothing is measured or asserted here; ``bench/bench_stop.py`` uses it to measure Ctrl-C.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import threading
import time

# Busy, and gone within a second once the parent is: os.getppid() changes when it dies.
_LOOP = ("import os\n"
         "p = os.getppid()\n"
         "while os.getppid() == p:\n"
         "    for _ in range(200000): pass\n")


class Busy:
    """N busy processes while the context lasts (``n`` may be 0)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.procs: list[subprocess.Popen[bytes]] = []

    def __enter__(self) -> Busy:
        for _ in range(self.n):
            # their own process group: the terminal's Ctrl-C is for the command, not for them
            self.procs.append(subprocess.Popen([sys.executable, "-c", _LOOP], start_new_session=True,
                                               stdin=subprocess.DEVNULL))
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def stop(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.procs = []


def load_text() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f}, {five:.2f}, {fifteen:.2f} on {os.cpu_count()} cores"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    command: list[str] = []
    if "--" in argv:
        i = argv.index("--")
        argv, command = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(prog="bench/busy.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("n", type=int, help="how many busy processes")
    ap.add_argument("--report", type=float, default=60.0, metavar="SECONDS",
                    help="print the load average this often (default 60; 0: only at the start and end)")
    args = ap.parse_args(argv)
    if args.n < 0:
        ap.error("N must be 0 or more")
    stop = threading.Event()

    def report() -> None:
        while args.report > 0 and not stop.wait(args.report):
            print(f"busy.py: {args.n} busy, {load_text()}", file=sys.stderr, flush=True)

    def on_signal(signum: int, _frame: object) -> None:
        stop.set()

    code = 0
    with Busy(args.n):
        print(f"busy.py: {args.n} busy processes started, {load_text()}", file=sys.stderr, flush=True)
        threading.Thread(target=report, daemon=True).start()
        start = time.monotonic()
        if command:
            proc = subprocess.Popen(command)
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # the command gets it and ends
            signal.signal(signal.SIGTERM, lambda s, f: proc.send_signal(s))
            try:
                code = proc.wait()
            finally:
                signal.signal(signal.SIGINT, previous)
        else:
            signal.signal(signal.SIGINT, on_signal)
            signal.signal(signal.SIGTERM, on_signal)
            while not stop.wait(3600):
                pass
        stop.set()
        print(f"busy.py: {args.n} busy processes stopped after {time.monotonic() - start:.0f} s, "
              f"{load_text()}", file=sys.stderr, flush=True)
    return code if code >= 0 else 128 - code


if __name__ == "__main__":
    sys.exit(main())
