"""The batch's progress on stderr: a bar redrawn in place on a terminal (done, running,
failed, the slowest running job and how long it has run), one line per finished job
otherwise (a log keeps every line; a bar would be one long line of carriage returns)."""
from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    def __init__(self, total: int, done: int = 0, stream=None, tty: bool | None = None, quiet: bool = False) -> None:
        self.total = total
        self.done = done
        self.failed = 0
        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty() if tty is None else tty
        self.quiet = quiet
        self._last = 0.0
        self.running: dict[str, float] = {}

    def start(self, job_id: str) -> None:
        self.running.setdefault(job_id, time.monotonic())

    def line(self) -> str:
        width = 24
        filled = int(width * self.done / self.total) if self.total else width
        text = (f"[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} done, "
                f"{len(self.running)} running, {self.failed} failed")
        if self.running:
            slow, t0 = min(self.running.items(), key=lambda kv: kv[1])
            text += f"; slowest running: {slow} ({time.monotonic() - t0:.1f} s)"
        return text

    def tick(self, force: bool = False) -> None:
        if self.quiet or not self.tty:
            return
        now = time.monotonic()
        if force or now - self._last >= 0.2:
            self._last = now
            self.stream.write("\r\033[K" + self.line())
            self.stream.flush()

    def finished(self, record: dict, failed: bool) -> None:
        self.running.pop(record["id"], None)
        self.done += 1
        self.failed += failed
        if self.quiet:
            return
        if self.tty:
            self.tick(force=True)
            return
        wall = (record.get("times") or {}).get("wall_s")
        length = f" maxstep {record['maxstep']}" if record.get("maxstep") is not None else ""
        took = f" in {wall:.3f} s" if isinstance(wall, (int, float)) else ""
        why = f": {record['error']}" if failed and record.get("error") else ""
        self.stream.write(f"% [{self.done}/{self.total}] {record['id']}: {record['status']}{length}{took}{why}\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty and not self.quiet:
            self.stream.write("\r\033[K" + self.line() + "\n")
            self.stream.flush()
