"""A server's script of requests by cycle (``cplus serve --script FILE``).

It feeds a :class:`~cplus.robot.serving.goals.GoalBoard`, as the socket
(:mod:`cplus.robot.serving.socket_channel`) and ROS actionlib
(:mod:`cplus.robot.serving.ros_bridge`) do.

**The script** (``--script FILE``) is JSON lines, one per request or cancellation::

    {"cycle": 1, "request": "deliver(office3,office2)"}
    {"cycle": 3, "cancel": 1}

A script cancels its own requests by their rank: ``{"cancel": 2}`` is the script's second
request, whatever id the server gave it (ids are 1, 2, ... in the order requests arrive from
every channel, and go on from a continued log's last one). An entry at cycle ``k`` arrives before the actions of cycle ``k`` are chosen and
takes effect at cycle ``k`` (the transition that ended there). Scripted runs are
deterministic: the loop never waits for a script. The file is checked before anything runs
(``script.jsonl:3:1: error: ...``); a request the domain cannot express is rejected when it
arrives, as a client's would be.
"""
from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from cplus.errors import CPlusError, Location, Source
from cplus.robot.serving.goals import GoalBoard, GoalWatcher

__all__ = ["MAX_SCRIPT", "MAX_SCRIPT_CYCLE", "RequestScript", "ScriptEntry", "ScriptError", "json_line",
           "load_script", "parse_script"]

MAX_SCRIPT = 16 << 20
"""The largest script read (bytes)."""
MAX_SCRIPT_CYCLE = 10_000
"""The latest cycle of a script entry: while nothing is to be done, the loop runs the idle
cycles up to the next entry at once (a scripted run is deterministic), so a cycle of 10**18
would mean idle cycles, and log lines, without end."""


class ScriptError(CPlusError):
    """A request script that cannot be read."""


@dataclass(frozen=True)
class ScriptEntry:
    """One line of a script: a request or a cancellation arriving at ``cycle``."""

    cycle: int
    request: str | None
    cancel: int | None
    line: int


class RequestScript:
    """Requests and cancellations at given cycles, fed to a board from the loop's thread."""

    def __init__(self, entries: Iterable[ScriptEntry], name: str = "script") -> None:
        self.entries = sorted(entries, key=lambda e: e.cycle)
        self.name = name
        self.board: GoalBoard | None = None
        self.watcher: GoalWatcher | None = None
        self.ids: list[int] = []          # the goal id of each of its requests, in their order

    def attach(self, board: GoalBoard, watcher: GoalWatcher | None = None) -> None:
        self.board = board
        self.watcher = watcher
        board.add_script(self.due, lambda: bool(self.entries))

    def due(self, cycle: int) -> None:
        """Submit every entry due at ``cycle``, in order."""
        board = self.board
        assert board is not None
        while self.entries and self.entries[0].cycle <= cycle:
            e = self.entries.pop(0)
            if e.request is not None:
                self.ids.append(board.submit(e.request, self.watcher, f"{self.name}:{e.line}").id)
            else:
                assert e.cancel is not None and e.cancel <= len(self.ids)   # checked at load time
                try:
                    board.cancel(self.ids[e.cancel - 1], f"{self.name}:{e.line}")
                except KeyError:
                    pass                  # ended and forgotten meanwhile


def load_script(path: str) -> RequestScript:
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_SCRIPT + 1)
    except OSError as exc:
        raise ScriptError(f"cannot read script {path}: {exc.strerror or exc}") from None
    if len(data) > MAX_SCRIPT:
        raise ScriptError(f"script {path} is larger than {MAX_SCRIPT >> 20} MiB")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScriptError(f"script {path} is not UTF-8 text: {exc.reason}") from None
    return parse_script(text, path)


def json_line(text: str | bytes) -> object:
    """One JSON value of a line; ValueError with a one-line reason (``not JSON: ...``, where
    :class:`json.JSONDecodeError` adds ``pos``) for anything json cannot read, including
    what it gives up on with another exception: an integer beyond Python's digit limit for
    conversions, nesting deeper than its recursion allows."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        raise
    except RecursionError:
        raise ValueError("not JSON: nested too deeply") from None
    except ValueError:
        raise ValueError("not JSON: a number with too many digits") from None


def parse_script(text: str, path: str) -> RequestScript:
    """Check a script and return it. Raises :class:`ScriptError` (located)."""
    source = Source(path, text)
    entries: list[ScriptEntry] = []
    offset = 0
    for number, raw in enumerate(text.splitlines(keepends=True), start=1):
        line = raw.rstrip("\r\n")
        here = offset
        offset += len(raw)
        if not line.strip():
            continue

        def fail(message: str, col: int = 0, here: int = here, line: str = line) -> ScriptError:
            return ScriptError(message, Location(source, here + col, here + max(col + 1, len(line))))
        try:
            obj = json_line(line)
        except json.JSONDecodeError as exc:
            raise fail(f"not JSON: {exc.msg}", exc.pos) from None
        except ValueError as exc:
            raise fail(str(exc)) from None
        if not isinstance(obj, dict):
            raise fail("each line is a JSON object such as {\"cycle\": 1, \"request\": \"deliver(office3,office2)\"}")
        unknown = sorted(set(obj) - {"cycle", "request", "cancel"})
        if unknown:
            raise fail(f"unknown field '{unknown[0]}'; a line has \"cycle\" and one of \"request\" or \"cancel\"")
        cycle = obj.get("cycle")
        if isinstance(cycle, bool) or not isinstance(cycle, int) or not 1 <= cycle <= MAX_SCRIPT_CYCLE:
            raise fail(f"\"cycle\" must be an integer from 1 (the first transition ends at cycle 1) to "
                       f"{MAX_SCRIPT_CYCLE} (a robot with nothing to do runs idle cycles at once until the next "
                       "entry is due)")
        if ("request" in obj) == ("cancel" in obj):
            raise fail("a line has exactly one of \"request\" (text) or \"cancel\" (a goal id)")
        if "request" in obj:
            if not isinstance(obj["request"], str):
                raise fail("\"request\" must be a string such as \"deliver(office3,office2)\"")
            entries.append(ScriptEntry(cycle, obj["request"], None, number))
        else:
            gid = obj["cancel"]
            if isinstance(gid, bool) or not isinstance(gid, int) or gid < 1:
                raise fail("\"cancel\" must be a goal id (an integer >= 1)")
            entries.append(ScriptEntry(cycle, None, gid, number))
    ordered = sorted(entries, key=lambda e: e.cycle)
    requests = 0
    for e in ordered:
        if e.request is not None:
            requests += 1
        elif e.cancel is not None and e.cancel > requests:
            lines = text.splitlines(keepends=True)
            start = sum(len(x) for x in lines[:e.line - 1])
            arrive = "request arrives" if requests == 1 else "requests arrive"
            raise ScriptError(f"cancels goal {e.cancel}, but only {requests} {arrive} by cycle {e.cycle}", Location(source, start, start + len(lines[e.line - 1].rstrip())))
    return RequestScript(entries, Path(path).name)
