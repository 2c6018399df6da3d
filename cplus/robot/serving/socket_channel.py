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

A connection's own bookkeeping (:class:`~cplus.robot.serving.socket_client._Client`) is in
:mod:`cplus.robot.serving.socket_client`; this module keeps the listening socket and the I/O
thread.
"""
from __future__ import annotations

import ipaddress
import json
import selectors
import socket
import threading
import time

from cplus.robot.serving.goals import GoalBoard
from cplus.robot.serving.socket_client import MAX_LINE, SocketLimits, _Client

__all__ = ["MAX_LINE", "SocketChannel", "SocketLimits", "parse_listen"]


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


_ACCEPT, _WAKE = object(), object()



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

