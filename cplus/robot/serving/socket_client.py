"""One client of the socket channel: the bytes read from it and not yet handled, its lines
answered in order, the news of its goals, and the answers not yet sent to it.

Apart from the channel (:mod:`cplus.robot.serving.socket_channel`, which gives
:data:`MAX_LINE` and :class:`SocketLimits` too) because a connection's bookkeeping and its
locking rules read best on their own; what a client uses of its channel is
:class:`_Channel`, so the two modules do not import each other.
"""
from __future__ import annotations

import json
import socket
import threading
from dataclasses import dataclass
from typing import Protocol

from cplus.robot.serving.goals import FINAL, Feedback, Goal, GoalBoard, GoalStatus, GoalWatcher
from cplus.robot.serving.script import json_line

MAX_LINE = 65536
"""The longest line a socket client may send (bytes); a longer one is an error and is dropped."""

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


class _Channel(Protocol):
    """What a client uses of its :class:`~cplus.robot.serving.socket_channel.SocketChannel`."""

    limits: SocketLimits

    def _wake(self) -> None: ...


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

    def __init__(self, channel: _Channel, sock: socket.socket, peer: str) -> None:
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

