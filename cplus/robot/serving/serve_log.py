"""A server's log: the online loop's ``cplus.online/1`` log with the goals' records, durable, and
continued across restarts (``cplus serve --log FILE``).

What a client is told must never be ahead of the log: a server that is killed and started
again finds in its log every goal a client heard of. So

* **a goal record is written when the goal changes**, ``{"record": "goal", "id", "request",
  "status", ...}`` (the goal as :meth:`Goal.to_json` gives it), under the board's lock, before
  anyone can be told (a socket's acknowledgement, a status query, the dispatcher's news), and
  flushed to the operating system at once: a crash of the process loses nothing a client saw;
* **a final status is also made durable** (``fsync``) before its result goes to the goal's
  client: the dispatcher syncs the log before it delivers a batch with a final status (with
  no lock of the board held: an ``fsync`` takes a fraction of a millisecond here, tens under
  load, and must not hold the loop or the channels);
* **an existing log is continued** (:func:`open_log`): a new start record is appended, its
  ``first_goal_id`` one more than the last goal id the file names, so goal ids are never
  reused (``{"status": 2}`` after a restart still means the goal 2 that a client was told
  of; it belongs to an earlier run, whose records have it). A last line cut off by a crash (no
  newline at the end of the file) is removed first, and the new start record says so
  (``"repaired"``). A file that is not a ``cplus.online/1`` log is refused (:class:`LogRefused`),
  unless the caller asks to overwrite it.

So a log continued after restarts holds several runs: each begins with its own start record
and, unless it crashed, ends with its end record (``cplus replay`` draws the last one unless
``--run N`` picks another).

Lock order: the board's lock, then the log's (:class:`ServeLog` is called by the board under
its lock, and never calls the board with its own lock held).
"""
from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TextIO

from cplus.robot.online import ONLINE_FORMAT, JsonLinesLog, RunResult
from cplus.robot.serving.goals import Goal, GoalBoard, GoalRecorder

__all__ = ["SERVE_LOG", "LogHistory", "LogRefused", "ServeLog", "open_log"]

SERVE_LOG = "cplus.serve/3"
"""What a server adds to the ``cplus.online/1`` log (the start record's ``serve_format``).
Version 3 writes a goal record whenever a goal changes (version 2 listed in each cycle record
the goals that changed since the record before, so the log ran up to a whole idle period
behind the clients; version 1 listed every open goal in every cycle record)."""

_FIRST_LINE = 1 << 20
"""How much of a file is read to find its first line (a start record is a few KiB)."""
_BLOCK = 1 << 16


class LogRefused(Exception):
    """An existing file that the log must not be appended to; the message says why and what to do."""


@dataclass(frozen=True)
class LogHistory:
    """What an existing log holds that the new run goes on from.

    Attributes:
        last_goal_id: the highest goal id the file names (0: none); the new run's ids start
            one above it.
        repaired: bytes of a last line cut off by a crash, removed before the new start record.
    """

    last_goal_id: int = 0
    repaired: int = 0


def open_log(path: str, overwrite: bool = False) -> tuple[TextIO, LogHistory | None]:
    """Open ``path`` for a server's log: a new file, or an existing ``cplus.online/1`` log to
    continue (then its :class:`LogHistory`), or any file at all when ``overwrite``.

    Raises:
        LogRefused: the file exists and is not a ``cplus.online/1`` log (and not ``overwrite``).
        OSError: it cannot be read or written.
    """
    if overwrite or not os.path.exists(path) or os.path.getsize(path) == 0:
        return open(path, "w", encoding="utf-8"), None
    with open(path, "rb") as f:
        head = f.read(_FIRST_LINE)
    first = head.split(b"\n", 1)[0]
    try:
        record = json.loads(first)
    except ValueError:
        record = None
    if not isinstance(record, dict) or record.get("record") != "start" or record.get("format") != ONLINE_FORMAT:
        raise LogRefused(f"{path} is not a {ONLINE_FORMAT} log (its first line is not a run's start record): give "
                         "another file, or --log-overwrite to replace it")
    with open(path, "r+b") as f:
        size = f.seek(0, os.SEEK_END)
        end = _last_newline(f, size)
        repaired = size - end
        if repaired:                      # a line cut off by a crash: not JSON, not a record
            f.truncate(end)
        last = _last_goal_id(f, end)
    return open(path, "a", encoding="utf-8"), LogHistory(last, repaired)


def _last_newline(f, size: int) -> int:
    """The offset just after the file's last newline (0: none)."""
    pos = size
    while pos > 0:
        start = max(0, pos - _BLOCK)
        f.seek(start)
        chunk = f.read(pos - start)
        i = chunk.rfind(b"\n")
        if i >= 0:
            return start + i + 1
        pos = start
    return 0


def _lines_backwards(f, end: int):
    """The file's lines up to ``end``, last first (as bytes, without their newlines)."""
    pos, tail = end, b""
    while pos > 0:
        start = max(0, pos - _BLOCK)
        f.seek(start)
        chunk = f.read(pos - start) + tail
        lines = chunk.split(b"\n")
        tail = lines[0]
        for line in reversed(lines[1:]):
            if line:
                yield line
        pos = start
    if tail:
        yield tail


def _last_goal_id(f, end: int) -> int:
    """The highest goal id the log names: read from the end back to the start record of the
    last run that says where its ids began (a run's ids only grow, and each run starts above
    every earlier one), or through the whole file for a log without one."""
    best = 0
    for raw in _lines_backwards(f, end):
        try:
            record = json.loads(raw)
        except ValueError:
            continue
        if not isinstance(record, dict):
            continue
        kind = record.get("record")
        if kind == "goal":
            best = max(best, _int(record.get("id")))
        elif kind in ("cycle", "end"):    # cplus.serve/2 named goals in cycle records; end records do
            for g in record.get("goals") or []:
                if isinstance(g, dict):
                    best = max(best, _int(g.get("id")))
        elif kind == "start" and isinstance(record.get("first_goal_id"), int):
            return max(best, _int(record["first_goal_id"]) - 1)
    return best


def _int(value: object) -> int:
    return value if isinstance(value, int) and not isinstance(value, bool) else 0


class ServeLog(JsonLinesLog, GoalRecorder):
    """The ``cplus.online/1`` log of a server: its start record (with ``serve_format``,
    ``first_goal_id`` and, for a continued log, ``"continues": true``), a goal record at each
    goal change, the loop's cycle records, and an end record with every goal still remembered
    and the counts of all (``goal_counts``).

    Given the loop (``Server.log_to`` does that), the start record is written at once, so that
    a request that arrives before the run starts is recorded after it; without it, when the
    run starts, and goal changes before that wait for it. Lines are written under the log's
    lock, so that the watchdog's end record (:meth:`end_now`) is never interleaved with
    another line, and after an end record nothing more is written.
    """

    def __init__(self, stream: TextIO, board: GoalBoard, extra=None, *, loop=None,
                 history: LogHistory | None = None) -> None:
        head = {"serve_format": SERVE_LOG, "first_goal_id": board.first_id}
        if history is not None:
            head["continues"] = True
            if history.repaired:
                head["repaired"] = (f"removed a last line of {history.repaired} bytes cut off by a crash of the "
                                    "run before")
        super().__init__(stream, {**(extra or {}), **head})
        self.board = board
        self._held: list[str] | None = []    # goal lines that came before the start record
        self.failure = ""                    # the first write that failed (the disk is full ...)
        board.recorder = self
        if loop is not None:
            self.on_start(loop)

    def on_start(self, loop) -> None:
        with self._lock:
            if self._held is None:            # written when the log was made
                return
            self._t0 = time.monotonic()
            held, self._held = self._held, None
            self._emit(json.dumps(self.start_record(loop), separators=(",", ":")) + "\n", held)

    def goal_changed(self, goal: Goal) -> None:
        line = json.dumps({"record": "goal", **goal.to_json()}, separators=(",", ":")) + "\n"
        with self._lock:
            if self._ended:
                return
            if self._held is not None:
                self._held.append(line)
                return
            self._emit(line)

    def _emit(self, line: str, more: Sequence[str] = ()) -> None:
        """Write and flush (the log's lock held); a failure is kept, not raised: the board
        calls this under its lock, and a full disk must not take the server down with it."""
        try:
            self.stream.write(line + "".join(more))
            self.stream.flush()
        except (OSError, ValueError) as exc:
            self.failure = self.failure or str(exc)

    def sync(self) -> None:
        """Make what was written durable (``fsync``; nothing for a stream without a file)."""
        with self._lock:
            try:
                fileno = self.stream.fileno()
            except (AttributeError, OSError, ValueError):
                return
            try:
                os.fsync(fileno)
            except OSError as exc:
                self.failure = self.failure or str(exc)

    def on_end(self, result: RunResult) -> None:
        line = result.to_json()
        line["goals"] = self.board.remembered()
        line["goal_counts"] = self.board.summary()
        self._write(line, end=True)
        self.sync()

    def end_now(self, line: dict, timeout: float) -> bool:
        """Write ``line`` as the end record now (``"forced": true``, with the goals), unless the
        loop already wrote one (:meth:`JsonLinesLog.end_forced` for a server: the watchdog's
        end of a run that did not stop in time); False when the locks could not be had in time
        (a write is stuck: the lines stay as they are)."""
        deadline = time.monotonic() + max(timeout, 0.0)
        goals = self.board.remembered(timeout)          # the board's lock before the log's
        counts = self.board.summary(max(deadline - time.monotonic(), 0.0))
        if not self._lock.acquire(timeout=max(deadline - time.monotonic(), 0.0)):
            return False
        try:
            if not self._ended:
                line = dict(line, forced=True, goals=goals, goal_counts=counts)
                self.stream.write(json.dumps(line, separators=(",", ":")) + "\n")
                self.stream.flush()
                self._ended = True
            return True
        except (OSError, ValueError):         # the file is gone or closed: nothing more to save
            return False
        finally:
            self._lock.release()

