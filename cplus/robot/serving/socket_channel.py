"""A server's requests as JSON lines on a socket (``cplus serve --listen HOST:PORT``).

It feeds a :class:`~cplus.robot.serving.goals.GoalBoard`, as the script
(:mod:`cplus.robot.serving.script`) and ROS actionlib (:mod:`cplus.robot.serving.ros_bridge`) do.

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

Each line is answered at once and in order (a request with its acknowledgement, before any
news of that goal; a cancellation with its answer, before the goal's ``result`` it causes).
A client that shuts its writing side (``nc -q``, ``socat -t``, ``shutdown(SHUT_WR)``) has its
lines answered and hears its goals until they end; then the server hangs up. A client that
disconnects leaves its goals running (a mail robot does not drop a package because the person
who asked hung up); their results are in the log.

One I/O thread serves every connection (:class:`SocketChannel`), and no client can make the
server or another client wait (:class:`SocketLimits`): at most 64 connections (one more is
told why and closed); a client's answers are queued for it alone, its further lines wait
while 256 KiB of answers are unsent, and it is disconnected when 1 MiB is (it does not read);
an unfinished line is given up after 60 s; a line over 64 KiB, text that is not UTF-8 or not
JSON (numbers beyond Python's digit limit, nesting beyond json's recursion) is an error line.

Locks: a client's ``_lock`` guards its unsent answers and is a leaf (sends are non-blocking,
and the board is never called with it held); the I/O thread calls the board with no lock held.
"""
from __future__ import annotations

import ipaddress
import json
import selectors
import socket
import threading
import time
from dataclasses import dataclass

from cplus.robot.serving.goals import FINAL, Feedback, Goal, GoalBoard, GoalStatus, GoalWatcher
from cplus.robot.serving.script import json_line

__all__ = ["MAX_LINE", "SocketChannel", "SocketLimits", "parse_listen"]

MAX_LINE = 65536
"""The longest line a socket client may send (bytes); a longer one is an error and is dropped."""


def parse_listen(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``[::1]:PORT`` for IPv6) on the loopback interface; ValueError otherwise."""
    host, sep, port = text.rpartition(":")
    if not sep or not (port.isascii() and port.isdigit()) or len(port) > 5 or not 0 <= int(port) <= 65535:
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
                         "authentication, so it listens on loopback addresses only (127.0.0.0/8 or ::1)")
    return host, int(port)


@dataclass(frozen=True)
class SocketLimits:
    """What the socket takes from its clients at most.

    Attributes:
        clients: connections at once; one more is answered with an error line and closed.
        out_bytes: a client's answers not yet sent; a client that lets more pile up (it does
            not read) is disconnected, and its goals go on.
        pause_bytes: while this much is unsent to a client (or unread from it), its further
            lines wait in the kernel (the client's writes block, nobody else's).
        line_timeout: seconds an unfinished line (no newline) may stay unfinished; then the
            client is told and disconnected (so that half-sent lines cannot hold every
            connection).
        lines_per_round: lines handled for one client before the others' turn.
    """

    clients: int = 64
    out_bytes: int = 1 << 20
    pause_bytes: int = 256 << 10
    line_timeout: float = 60.0
    lines_per_round: int = 64


_ACCEPT, _WAKE = object(), object()


class _Client(GoalWatcher):
    """One connection: the bytes read and not yet handled, the answers not yet sent.

    Only the channel's I/O thread reads, parses, answers the client's lines and changes the
    selector; the board's dispatcher adds the news of the client's goals. ``_lock`` guards
    ``out``, the socket's writing side and the bookkeeping of acknowledgements; nothing else
    is taken while it is held (sends are non-blocking), and it is never held while the board
    is called.

    The I/O thread answers every line itself, at once and in order (a request with its
    acknowledgement, built from the goal as the board made it: :meth:`GoalBoard.request`, so
    that the dispatcher has nothing for this client before the answer is out, and the I/O
    thread does not wait for the client's lock, which would hand Python's GIL to the loop's
    re-plan first). News of the goal that the dispatcher has before that acknowledgement is
    sent waits in ``_early``, so the client hears a goal's lines in order, after the answer to
    the line that asked for it."""

    def __init__(self, channel: SocketChannel, sock: socket.socket, peer: str) -> None:
        self.channel = channel
        self.sock = sock
        self.peer = peer
        self._lock = threading.Lock()
        self.out = bytearray()            # answers not yet sent (under _lock)
        self.closed = False               # under _lock
        self.overflow = False             # it stopped reading: to be disconnected
        self.inbuf = bytearray()          # read, not yet handled (I/O thread)
        self.pos = 0                      # where the unhandled part of inbuf starts
        self.discarding = False           # inside a line too long, until its newline
        self.partial_since: float | None = None
        self.eof = False                  # it shut its writing side: closed once its goals have ended
        self.hangup = False               # to be closed once its last lines are sent (told why)
        self.dead = False                 # the connection failed: hang up
        self.mask = 0                     # what the selector watches for it
        self._acked: set[int] = set()     # goals in flight whose acknowledgement is out (under _lock)
        self._open: set[int] = set()      # its own goals not final yet (under _lock)
        self._early: dict[int, list[dict]] = {}   # news before the acknowledgement (under _lock)

    # ------------------------------------------------------------- from any thread
    def _send(self, obj: dict, now: bool = True) -> bool:
        """Send ``obj`` as a JSON line (the lock held): at once when the socket takes it, else
        kept for the I/O thread; never blocks. Too much kept (:attr:`SocketLimits.out_bytes`)
        marks the client for disconnection. True when the I/O thread must look. ``now``
        False: only keep it (the I/O thread sends a round's answers at once, with one system
        call, during which Python's GIL may go to the loop's re-plan)."""
        if self.closed or self.overflow:
            return False
        data = (json.dumps(obj, separators=(",", ":")) + "\n").encode()
        wake = False
        if not self.out and now:
            try:
                sent = self.sock.send(data)
            except BlockingIOError:
                sent = 0
            except OSError:               # the client went away: the I/O thread hangs up
                sent, wake, self.dead = len(data), True, True
            data = data[sent:]
        if data:
            if len(self.out) + len(data) > self.channel.limits.out_bytes:
                self.overflow = True
            else:
                self.out += data
            # the dispatcher wakes the I/O thread to send the rest; the I/O thread itself sends
            # at the end of its round (a wake is a system call: the GIL would go to the loop)
            wake = now or self.overflow
        return wake

    def answer(self, obj: dict) -> None:
        """The I/O thread's answer to a line: kept, and sent with the round's others."""
        with self._lock:
            self._send(obj, now=False)

    def acknowledge(self, ack: dict, final: bool) -> None:
        """The I/O thread's answer to a request, then the goal's news that came before it."""
        if not final:
            with self._lock:
                self._open.add(ack["id"])
        self._answer_first({"type": "goal", **ack}, ack["id"], not final)

    def goals_open(self) -> bool:
        """Whether a goal this client asked for has not ended yet (its lines are still to come)."""
        with self._lock:
            return bool(self._open)

    def _answer_first(self, answer: dict, gid: int, in_flight: bool) -> None:
        """Send ``answer``, then the news of goal ``gid`` held back until it was out; from now
        on that goal's news goes out as it comes, while it is ``in_flight`` (not final)."""
        with self._lock:
            wake = self._send(answer, now=False)
            if in_flight:
                self._acked.add(gid)
            for obj in self._early.pop(gid, []):
                wake = self._send(obj, now=False) or wake
                if obj["type"] == "result":
                    self._acked.discard(gid)
                    self._open.discard(gid)
        if wake:
            self.channel._wake()

    def _hold(self, gid: int) -> bool:
        """Keep the news of this client's goal ``gid`` back (in ``_early``) until the answer
        to the line being handled is out: a cancellation's ``result`` (a pending goal is
        recalled at once, by the board's dispatcher) must not overtake the ``cancel`` answer.
        True when the goal is this client's and in flight."""
        with self._lock:
            if gid in self._acked:
                self._acked.discard(gid)
                return True
        return False

    def _news(self, goal: Goal, obj: dict, final: bool) -> None:
        wake = False
        with self._lock:
            if goal.id in self._acked:
                wake = self._send(obj)
                if final:
                    self._acked.discard(goal.id)
                    self._open.discard(goal.id)
                    wake = wake or self.eof      # a half-closed client is closed once its goals end
            else:
                self._early.setdefault(goal.id, []).append(obj)
        if wake:
            self.channel._wake()

    def status(self, goal: Goal, status: GoalStatus) -> None:
        final = status in FINAL
        self._news(goal, {"type": "result" if final else "status", **goal.to_json(), "status": status.value}, final)

    def feedback(self, goal: Goal, feedback: Feedback) -> None:
        self._news(goal, {"type": "feedback", "id": goal.id, **feedback.to_json()}, False)

    # ------------------------------------------------------------- the I/O thread
    def write(self) -> None:
        """Send what the socket takes of the answers kept."""
        with self._lock:
            if self.closed or not self.out:
                return
            try:
                sent = self.sock.send(self.out)
            except BlockingIOError:
                return
            except OSError:
                self.out.clear()
                self.dead = True          # gone; closed by the I/O thread
                return
            del self.out[:sent]

    def close(self) -> None:
        with self._lock:
            self.closed = True
            self.out.clear()
            try:
                self.sock.close()
            except OSError:
                pass

    def next_line(self) -> bytes | None:
        """The next complete line read (without its newline), or None. A line longer than
        :data:`MAX_LINE` is answered with an error and skipped up to its newline."""
        buf = self.inbuf
        while True:
            nl = buf.find(b"\n", self.pos)
            if self.discarding:
                if nl < 0:
                    del buf[:]
                    self.pos = 0
                    return None
                self.pos, self.discarding = nl + 1, False
                continue
            if nl < 0:
                if len(buf) - self.pos > MAX_LINE:
                    del buf[:]
                    self.pos, self.discarding = 0, True
                    self.answer({"type": "error", "message": f"line longer than {MAX_LINE} bytes, dropped"})
                elif self.pos:
                    del buf[:self.pos]
                    self.pos = 0
                return None
            start, self.pos = self.pos, nl + 1
            if nl - start > MAX_LINE:
                self.answer({"type": "error", "message": f"line longer than {MAX_LINE} bytes, dropped"})
                continue
            return bytes(buf[start:nl])

    def unhandled(self) -> int:
        return len(self.inbuf) - self.pos

    def busy(self) -> bool:
        """Too much of its answers not sent yet: its next lines wait (in the kernel, and then in
        its own writes), so that a client that does not read costs a bounded amount."""
        return len(self.out) >= self.channel.limits.pause_bytes

    def handle(self, raw: bytes, board: GoalBoard) -> None:
        """Answer one line (parsed here, in the I/O thread, outside every lock)."""
        try:
            text = raw.decode("utf-8").strip()
        except UnicodeDecodeError:
            self.answer({"type": "error", "message": "not UTF-8 text"})
            return
        if not text:
            return
        try:
            msg = json_line(text)
        except json.JSONDecodeError as exc:
            self.answer({"type": "error", "message": f"not JSON: {exc.msg} at column {exc.pos + 1}"})
            return
        except ValueError as exc:
            self.answer({"type": "error", "message": str(exc)})
            return
        if not isinstance(msg, dict) or len(msg) != 1 or next(iter(msg)) not in ("request", "cancel", "status"):
            self.answer({"type": "error", "message": "send one of {\"request\": TEXT}, {\"cancel\": ID}, "
                                                    "{\"status\": ID}"})
            return
        (key, value), = msg.items()
        if key == "request":
            if not isinstance(value, str):
                self.answer({"type": "error", "message": "\"request\" must be a string such as "
                                                        "\"deliver(office3,office2)\""})
                return
            _, ack = board.request(value, self, self.peer, client=self)
            self.acknowledge(ack, ack["status"] != GoalStatus.PENDING.value)
            return
        if isinstance(value, bool) or not isinstance(value, int):
            self.answer({"type": "error", "message": f"\"{key}\" takes a goal id (an integer)"})
            return
        held = False
        if key == "cancel":
            held = self._hold(value)
            try:
                board.cancel(value, self.peer)
            except KeyError:
                pass
        now = board.describe(value)
        answer = {"type": "error", "message": _unknown(board, value)} if now is None else {"type": key, **now}
        if held:
            self._answer_first(answer, value, True)
        else:
            self.answer(answer)


def _unknown(board: GoalBoard, goal_id: int) -> str:
    if 0 < goal_id < board.first_id:
        return (f"goal {goal_id} belongs to an earlier run of the server (this run's goals start at "
                f"{board.first_id}; the log has its result)")
    if board.forgotten(goal_id):
        return (f"goal {goal_id} ended long ago and is forgotten (the server remembers the last "
                f"{board.limits.kept_final} final goals; the log has its result)")
    return f"no goal {goal_id}"


class SocketChannel:
    """Requests as JSON lines over TCP on the loopback interface.

    One I/O thread serves every connection (a selector, non-blocking sockets), so a client
    costs no thread and none can make another wait: a client's lines are handled a few at a
    time in turn with the others', its answers are queued for it alone
    (:class:`SocketLimits`), and the board is only ever called with no lock of the channel's
    held. ``TCP_NODELAY`` is set on every connection: answers are small lines that must not
    wait for Nagle's algorithm (it held every second one 40 ms)."""

    def __init__(self, board: GoalBoard, host: str = "127.0.0.1", port: int = 0,
                 limits: SocketLimits | None = None) -> None:
        self.board = board
        self.host = host
        self.port = port
        self.limits = limits or SocketLimits()
        self._server: socket.socket | None = None
        self._clients: set[_Client] = set()
        self._refusing: dict[socket.socket, float] = {}     # refused, told why, draining until EOF
        self._thread: threading.Thread | None = None
        self._closing = threading.Event()
        self._sel: selectors.BaseSelector | None = None
        self._waker: socket.socket | None = None
        self._wakee: socket.socket | None = None
        self._accept_again = 0.0          # out of file descriptors: when to try accept() again
        self.refused = 0

    @property
    def address(self) -> tuple[str, int]:
        """Where it listens (the port is known once started, also when 0 was asked for)."""
        assert self._server is not None
        host, port = self._server.getsockname()[:2]
        return host, port

    def start(self) -> tuple[str, int]:
        """Bind and listen; raises OSError when the address is taken."""
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        self._server = socket.create_server((self.host, self.port), family=family, backlog=128)
        self._server.setblocking(False)
        self._wakee, self._waker = socket.socketpair()
        self._wakee.setblocking(False)
        self._waker.setblocking(False)
        self._sel = selectors.DefaultSelector()
        self._sel.register(self._server, selectors.EVENT_READ, _ACCEPT)
        self._sel.register(self._wakee, selectors.EVENT_READ, _WAKE)
        self.board.open_channel()
        self._thread = threading.Thread(target=self._serve, name="cplus-serve-socket", daemon=True)
        self._thread.start()
        return self.address

    def _wake(self) -> None:
        """Make the I/O thread look again (from any thread; never blocks)."""
        waker = self._waker
        if waker is not None:
            try:
                waker.send(b"x")
            except OSError:               # full (a wake is pending anyway) or closed
                pass

    # ------------------------------------------------------------------ the I/O thread
    def _serve(self) -> None:
        sel = self._sel
        assert sel is not None
        more = False
        try:
            while not self._closing.is_set():
                for key, mask in sel.select(0 if more else 0.5):
                    what = key.data
                    if what is _ACCEPT:
                        self._accept()
                    elif what is _WAKE:
                        self._drain_wakes()
                    elif isinstance(what, _Client):
                        if mask & selectors.EVENT_WRITE:
                            what.write()
                        if mask & selectors.EVENT_READ:
                            self._read(what)
                    else:
                        self._refuse_read(key.fileobj)  # type: ignore[arg-type]
                more = self._work()
        finally:
            self._shutdown()

    def _drain_wakes(self) -> None:
        assert self._wakee is not None
        try:
            while self._wakee.recv(4096):
                pass
        except OSError:
            pass

    def _accept(self) -> None:
        server = self._server
        assert server is not None and self._sel is not None
        while True:
            try:
                conn, addr = server.accept()
            except BlockingIOError:
                return
            except OSError:               # out of file descriptors, or a connection reset meanwhile
                self._sel.unregister(server)
                self._accept_again = time.monotonic() + 0.5
                return
            conn.setblocking(False)
            if len(self._clients) >= self.limits.clients:
                self._refuse(conn)
                continue
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            client = _Client(self, conn, f"{addr[0]}:{addr[1]}")
            self._clients.add(client)
            client.mask = selectors.EVENT_READ
            self._sel.register(conn, client.mask, client)

    def _refuse(self, conn: socket.socket) -> None:
        """Tell a connection beyond the limit why, then hang up once it has sent what it had
        (closing at once with its request unread would reset the connection, and the reason
        would be lost)."""
        self.refused += 1
        message = {"type": "error", "message": f"too many connections ({self.limits.clients} at most): try again "
                                               "when another client has hung up"}
        try:
            conn.send((json.dumps(message) + "\n").encode())
            conn.shutdown(socket.SHUT_WR)
        except OSError:
            conn.close()
            return
        if len(self._refusing) >= 4 * self.limits.clients:
            conn.close()
            return
        assert self._sel is not None
        self._refusing[conn] = time.monotonic() + 5.0
        self._sel.register(conn, selectors.EVENT_READ, "refused")

    def _refuse_read(self, conn: socket.socket) -> None:
        try:
            if conn.recv(65536):
                return
        except BlockingIOError:
            return
        except OSError:
            pass
        self._forget_refused(conn)

    def _forget_refused(self, conn: socket.socket) -> None:
        assert self._sel is not None
        self._refusing.pop(conn, None)
        self._sel.unregister(conn)
        conn.close()

    def _read(self, client: _Client) -> None:
        try:
            data = client.sock.recv(65536)
        except BlockingIOError:
            return
        except OSError:
            client.dead = True
            return
        if data:
            client.inbuf += data
        else:
            # the client shut its writing side (nc -q, socat -t, shutdown(SHUT_WR)) or hung up:
            # its lines are answered and its goals' news sent until they end; a client that hung
            # up altogether is seen when a send to it fails
            client.eof = True             # a last line without its newline still counts
            if client.unhandled() and not client.discarding:
                client.inbuf += b"\n"

    def _work(self) -> bool:
        """Handle the lines read, a few per client in turn, and bring each client's watch in
        the selector up to date; True when lines are left for the next round."""
        sel = self._sel
        assert sel is not None
        limits = self.limits
        now = time.monotonic()
        more = False
        for client in list(self._clients):
            handled = 0
            while handled < limits.lines_per_round and not client.busy() and not client.overflow:
                line = client.next_line()
                if line is None:
                    break
                client.handle(line, self.board)
                handled += 1
            if handled:
                client.write()            # the round's answers, in one system call
            if handled == limits.lines_per_round and not client.busy():
                more = True
            if client.unhandled() and not client.discarding and client.inbuf.find(b"\n", client.pos) < 0:
                if client.partial_since is None:
                    client.partial_since = now
                elif now - client.partial_since > limits.line_timeout:
                    client.answer({"type": "error", "message": f"a line left without its newline for "
                                                              f"{limits.line_timeout:g} s: disconnected"})
                    client.eof, client.hangup, client.inbuf, client.pos = True, True, bytearray(), 0
            else:
                client.partial_since = None
            if client.overflow or client.dead or (client.eof and not client.out and not client.unhandled()
                                                  and (client.hangup or not client.goals_open())):
                self._drop(client)
                continue
            want = 0
            if not client.eof and not client.busy() and client.unhandled() < limits.pause_bytes:
                want |= selectors.EVENT_READ
            if client.out:
                want |= selectors.EVENT_WRITE
            if want != client.mask:
                if not want:
                    sel.unregister(client.sock)
                elif not client.mask:
                    sel.register(client.sock, want, client)
                else:
                    sel.modify(client.sock, want, client)
                client.mask = want
        for conn, until in list(self._refusing.items()):
            if now > until:
                self._forget_refused(conn)
        if self._accept_again and now >= self._accept_again and self._server is not None:
            self._accept_again = 0.0
            sel.register(self._server, selectors.EVENT_READ, _ACCEPT)
        return more

    def _drop(self, client: _Client) -> None:
        """Hang up on a client (it went away, or stopped reading); its goals go on."""
        assert self._sel is not None
        if client.overflow:
            try:                          # the reason, if the socket still takes it
                client.sock.send(b'{"type":"error","message":"answers not read (more than '
                                 + str(self.limits.out_bytes).encode() + b' bytes waiting): disconnected; your '
                                 b'goals go on"}\n')
            except OSError:
                pass
        if client.mask:
            self._sel.unregister(client.sock)
            client.mask = 0
        self._clients.discard(client)
        client.close()

    def _shutdown(self) -> None:
        """Stop listening, send what is queued for the clients (half a second at most), hang up."""
        sel = self._sel
        assert sel is not None
        if self._server is not None:
            self._server.close()
        deadline = time.monotonic() + 0.5
        while time.monotonic() < deadline and any(c.out and not c.closed for c in self._clients):
            pending = [c for c in self._clients if c.out and not c.closed]
            for c in pending:
                c.write()
            if any(c.out for c in pending):
                time.sleep(0.01)
        for c in list(self._clients):
            c.close()
        self._clients.clear()
        for conn in list(self._refusing):
            conn.close()
        self._refusing.clear()
        sel.close()
        for s in (self._waker, self._wakee):
            if s is not None:
                s.close()
        self._waker = None

    def close(self, timeout: float = 2.0) -> None:
        """Stop listening and hang up on every client (after sending them what is queued)."""
        if self._closing.is_set() or self._thread is None:
            return
        self._closing.set()
        self._wake()
        self._thread.join(timeout)
        self.board.close_channel()
