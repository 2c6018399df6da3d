"""Request channels of a server: a script of requests by cycle, and JSON lines on a socket.

Both feed a :class:`~cplus.robot.serving.goals.GoalBoard`. The ROS actionlib channel is
:mod:`cplus.robot.serving.ros_bridge` (an optional extra).

**The script** (``--script FILE``) is JSON lines, one per request or cancellation::

    {"cycle": 1, "request": "deliver(office3,office2)"}
    {"cycle": 3, "cancel": 1}

Goal ids are 1, 2, ... in the order requests arrive, so a script cancels its own requests by
their rank. An entry at cycle ``k`` arrives before the actions of cycle ``k`` are chosen and
takes effect at cycle ``k`` (the transition that ended there). Scripted runs are
deterministic: the loop never waits for a script. The file is checked before anything runs
(``script.jsonl:3:1: error: ...``); a request the domain cannot express is rejected when it
arrives, as a client's would be.

**The socket** (``--listen HOST:PORT``, loopback only: it has no authentication) takes one
JSON object per line and answers with JSON lines:

============================================ =================================================
client                                       server
============================================ =================================================
``{"request": "deliver(office3,office2)"}``  ``{"type": "goal", "id": 1, "request": ..., "status": "pending"}``
                                             (or ``"status": "rejected", "reason": ...``), then
                                             for that goal: ``{"type": "status", ...}`` on each
                                             change, ``{"type": "feedback", "id": 1, "cycle": 2,
                                             "executed": [...], "plan": [[...], ...]}`` per
                                             cycle, and ``{"type": "result", "id": 1, "status":
                                             "succeeded", ...}`` at the end
``{"cancel": 1}``                            ``{"type": "cancel", "id": 1, "status": ...}`` (the
                                             goal's owner also gets its status lines)
``{"status": 1}``                            ``{"type": "status", "id": 1, ...}``
anything else                                ``{"type": "error", "message": ...}``
============================================ =================================================

A client that disconnects leaves its goals running (a mail robot does not drop a package
because the person who asked hung up); their results are in the log.
"""
from __future__ import annotations

import ipaddress
import json
import socket
import threading
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from cplus.errors import CPlusError, Location, Source
from cplus.robot.serving.goals import FINAL, Feedback, Goal, GoalBoard, GoalStatus, GoalWatcher

__all__ = ["MAX_LINE", "RequestScript", "ScriptEntry", "ScriptError", "SocketChannel", "load_script",
           "parse_listen", "parse_script"]

MAX_LINE = 65536
"""The longest line a socket client may send (bytes); a longer one is an error and is dropped."""


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
                board.submit(e.request, self.watcher, f"{self.name}:{e.line}")
            else:
                assert e.cancel is not None
                try:
                    board.cancel(e.cancel, f"{self.name}:{e.line}")
                except KeyError:
                    pass                  # checked at load time; another channel's ids came first


def load_script(path: str) -> RequestScript:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ScriptError(f"cannot read script {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ScriptError(f"script {path} is not UTF-8 text: {exc.reason}") from None
    return parse_script(text, path)


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
            obj = json.loads(line)
        except json.JSONDecodeError as exc:
            raise fail(f"not JSON: {exc.msg}", exc.pos) from None
        if not isinstance(obj, dict):
            raise fail("each line is a JSON object such as {\"cycle\": 1, \"request\": \"deliver(office3,office2)\"}")
        unknown = sorted(set(obj) - {"cycle", "request", "cancel"})
        if unknown:
            raise fail(f"unknown field '{unknown[0]}'; a line has \"cycle\" and one of \"request\" or \"cancel\"")
        cycle = obj.get("cycle")
        if isinstance(cycle, bool) or not isinstance(cycle, int) or cycle < 1:
            raise fail("\"cycle\" must be an integer >= 1 (the first transition ends at cycle 1)")
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
            raise ScriptError(f"cancels goal {e.cancel}, but only {requests} request{'s' if requests != 1 else ''} "
                              f"arrive by cycle {e.cycle}", Location(source, start, start + len(lines[e.line - 1].rstrip())))
    return RequestScript(entries, Path(path).name)


# ---------------------------------------------------------------------------------------- socket
def parse_listen(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``[::1]:PORT`` for IPv6) on the loopback interface; ValueError otherwise."""
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"expected HOST:PORT (such as 127.0.0.1:7070), got {text!r}")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    if host == "localhost":
        host = "127.0.0.1"
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = False
    if not loopback:
        raise ValueError(f"{host or 'an empty host'} is not a loopback address: the socket has no "
                         "authentication, so it listens on 127.0.0.1 or ::1 only")
    return host, int(port)


class _Client(GoalWatcher):
    """One connection: reads request lines, writes the answers of its goals."""

    def __init__(self, channel: SocketChannel, conn: socket.socket, peer: str) -> None:
        self.channel = channel
        self.conn = conn
        self.peer = peer
        self._write_lock = threading.Lock()
        self.closed = False
        self._told: set[int] = set()

    def send(self, obj: dict) -> None:
        data = (json.dumps(obj, separators=(",", ":")) + "\n").encode()
        with self._write_lock:
            if self.closed:
                return
            try:
                self.conn.sendall(data)
            except OSError:
                self.closed = True            # the client went away; its goals go on

    def status(self, goal: Goal, status: GoalStatus) -> None:
        kind = "goal" if goal.id not in self._told else ("result" if status in FINAL else "status")
        self._told.add(goal.id)
        self.send({"type": kind, **goal.to_json(), "status": status.value})

    def feedback(self, goal: Goal, feedback: Feedback) -> None:
        self.send({"type": "feedback", "id": goal.id, **feedback.to_json()})

    def serve(self) -> None:
        board = self.channel.board
        rfile = self.conn.makefile("rb")
        try:
            while True:
                raw = rfile.readline(MAX_LINE + 1)
                if not raw:
                    break
                if len(raw) > MAX_LINE and not raw.endswith(b"\n"):
                    self.send({"type": "error", "message": f"line longer than {MAX_LINE} bytes, dropped"})
                    while raw and not raw.endswith(b"\n"):
                        raw = rfile.readline(MAX_LINE + 1)
                    continue
                self.handle(raw, board)
        except OSError:
            pass
        finally:
            with self._write_lock:
                self.closed = True
            try:
                rfile.close()
                self.conn.close()
            except OSError:
                pass
            self.channel._gone(self)

    def handle(self, raw: bytes, board: GoalBoard) -> None:
        try:
            text = raw.decode("utf-8").strip()
        except UnicodeDecodeError:
            self.send({"type": "error", "message": "not UTF-8 text"})
            return
        if not text:
            return
        try:
            msg = json.loads(text)
        except json.JSONDecodeError as exc:
            self.send({"type": "error", "message": f"not JSON: {exc.msg} at column {exc.pos + 1}"})
            return
        if not isinstance(msg, dict) or len(msg) != 1 or next(iter(msg)) not in ("request", "cancel", "status"):
            self.send({"type": "error", "message": "send one of {\"request\": TEXT}, {\"cancel\": ID}, "
                                                   "{\"status\": ID}"})
            return
        (key, value), = msg.items()
        if key == "request":
            if not isinstance(value, str):
                self.send({"type": "error", "message": "\"request\" must be a string such as "
                                                       "\"deliver(office3,office2)\""})
                return
            board.submit(value, self, self.peer)
            return
        if isinstance(value, bool) or not isinstance(value, int):
            self.send({"type": "error", "message": f"\"{key}\" takes a goal id (an integer)"})
            return
        goal = board.get(value)
        if goal is None:
            self.send({"type": "error", "message": f"no goal {value}"})
            return
        if key == "cancel":
            goal = board.cancel(value, self.peer)
            self.send({"type": "cancel", **goal.to_json()})
        else:
            self.send({"type": "status", **goal.to_json()})


class SocketChannel:
    """Requests as JSON lines over TCP on the loopback interface (one thread per client)."""

    def __init__(self, board: GoalBoard, host: str = "127.0.0.1", port: int = 0) -> None:
        self.board = board
        self.host = host
        self.port = port
        self._server: socket.socket | None = None
        self._clients: set[_Client] = set()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    @property
    def address(self) -> tuple[str, int]:
        """Where it listens (the port is known once started, also when 0 was asked for)."""
        assert self._server is not None
        host, port = self._server.getsockname()[:2]
        return host, port

    def start(self) -> tuple[str, int]:
        """Bind and listen; raises OSError when the address is taken."""
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        self._server = socket.create_server((self.host, self.port), family=family)
        self._server.settimeout(0.2)          # accept() wakes up to see the channel closed
        self.board.open_channel()
        self._thread = threading.Thread(target=self._accept, name="cplus-serve-socket", daemon=True)
        self._thread.start()
        return self.address

    def _accept(self) -> None:
        server = self._server
        assert server is not None
        while self._server is not None:
            try:
                conn, addr = server.accept()
            except TimeoutError:
                continue
            except OSError:
                return                        # closed
            conn.settimeout(None)
            client = _Client(self, conn, f"{addr[0]}:{addr[1]}")
            with self._lock:
                self._clients.add(client)
            threading.Thread(target=client.serve, name=f"cplus-serve-{addr[1]}", daemon=True).start()

    def _gone(self, client: _Client) -> None:
        with self._lock:
            self._clients.discard(client)

    def close(self) -> None:
        """Stop listening and hang up on every client."""
        if self._server is None:
            return
        try:
            self._server.close()
        finally:
            self._server = None
            self.board.close_channel()
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            try:
                c.conn.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
