"""Event sources of the online loop that read text: a script file, or standard input.

One event file format serves both (``cplus online --events FILE|-``). Each line holds one or
more events as CCALC prints ground actions (``press``, ``request(office3,office2)``),
separated by blanks, optionally after ``@N`` to say at which cycle they arrive. ``#``
starts a comment::

    # a button press observed at cycle 3, then a request as soon as possible
    @3 press
    request(office3,office2)

An event at cycle ``N`` belongs to the transition that ends at cycle ``N`` (the robot's
action of cycle ``N-1``, or an idle step). So its effects hold when the actions of cycle ``N``
are chosen. The first transition ends at cycle 1. A line without ``@N`` arrives at the first
cycle after it was read. From a file, that is cycle 1 for every such line; from standard
input, it is the cycle after the line was typed.

:func:`parse_events` checks the syntax and :func:`check_events` the names against a model's
observed events. Both raise located errors (``events.txt:3:5: error: ...``), before anything
moves.
"""
from __future__ import annotations

import queue
import re
import threading
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TextIO

from cplus.errors import CPlusError, Location, Source
from cplus.robot.online.loop import EventSource

__all__ = ["EventLine", "EventsError", "LineEvents", "MAX_CYCLE", "MAX_LINE", "ScriptedEvents", "check_events",
           "parse_events", "parse_line"]

_TOKEN = re.compile(r"@\S*|[^\s(]+(\([^()]*(\([^()]*\)[^()]*)*\))?")


class EventsError(CPlusError):
    """An event file or line that cannot be read: bad syntax, or no such event."""


@dataclass(frozen=True)
class EventLine:
    """Events that arrive together: at ``cycle`` (None: as soon as possible)."""

    cycle: int | None
    events: tuple[str, ...]
    locations: tuple[Location, ...]


MAX_CYCLE = 10 ** 9
"""The largest cycle an ``@N`` may name: a run of a billion cycles is beyond any robot, and the
bound keeps a thousand-digit ``@N`` from costing a bignum (or Python's digit limit)."""

MAX_LINE = 65536
"""The longest line standard input may send (characters); a longer one is refused whole, so a
stream without line breaks cannot fill the memory."""


def _cycle(token: str, loc: Location) -> int:
    """The N of ``@N``: ASCII digits only (``str.isdigit`` also accepts ``²`` and ``٣``, which
    ``int`` then rejects or reads as 3), from 1 to :data:`MAX_CYCLE`."""
    digits = token[1:]
    if not digits or len(digits) > len(str(MAX_CYCLE)) or any(c not in "0123456789" for c in digits) \
            or not 1 <= int(digits) <= MAX_CYCLE:
        raise EventsError(f"'{token}': a cycle is written @N with N a whole number from 1 to {MAX_CYCLE} "
                          "(the first transition ends at cycle 1)", loc)
    return int(digits)


def parse_line(text: str, source: Source, offset: int = 0) -> EventLine | None:
    """One line of an event file (None for a blank or comment line)."""
    body = text.split("#", 1)[0]
    cycle: int | None = None
    events: list[str] = []
    locs: list[Location] = []
    pos = 0
    while pos < len(body):
        if body[pos].isspace():
            pos += 1
            continue
        m = _TOKEN.match(body, pos)
        end = m.end() if m else len(body)
        token = body[pos:end]
        loc = Location(source, offset + pos, offset + end)
        if token.startswith("@"):
            if events or cycle is not None:
                raise EventsError("'@N' must come first on its line", loc)
            cycle = _cycle(token, loc)
        else:
            if token.count("(") != token.count(")") or not re.fullmatch(r"[a-z]\w*(\(.+\))?", token):
                raise EventsError(f"'{token}' is not an event (write it as a ground action: press, request(3))", loc)
            events.append(token)
            locs.append(loc)
        pos = end
    if not events:
        if cycle is not None:
            raise EventsError(f"no event after '@{cycle}'", Location(source, offset, offset + len(text)))
        return None
    return EventLine(cycle, tuple(events), tuple(locs))


def parse_events(text: str, path: str) -> list[EventLine]:
    """Every line of an event file, in order. Raises :class:`EventsError`."""
    source = Source(path, text)
    out = []
    offset = 0
    for line in text.splitlines(keepends=True):
        parsed = parse_line(line.rstrip("\r\n"), source, offset)
        if parsed is not None:
            out.append(parsed)
        offset += len(line)
    return out


def check_events(lines: Iterable[EventLine], names: Iterable[str]) -> None:
    """Every event must be one of ``names`` (the model's observed events that come from the
    event input). Raises :class:`EventsError` at the first one that is not."""
    known = set(names)
    for line in lines:
        for text, loc in zip(line.events, line.locations):
            if text not in known:
                listed = ", ".join(sorted(known)) or "none"
                raise EventsError(f"'{text}' is not an event the input may send (those are: {listed})", loc)


class ScriptedEvents(EventSource):
    """Events at fixed cycles (a script): deterministic, and idle steps never wait for them."""

    def __init__(self, lines: Iterable[EventLine]) -> None:
        # in order of the cycle they are due at (a line without @N at once), file order within
        # a cycle: each poll takes a prefix, so a script of n lines costs O(n log n) in all
        # (taking the due lines out of a list by equality made 4,000 lines take 40 s)
        numbered = sorted(enumerate(lines), key=lambda item: (item[1].cycle or 0, item[0]))
        self._order = [e for _, e in numbered]
        self._next = 0

    @property
    def pending(self) -> list[EventLine]:
        """The lines not delivered yet, in the order they are due."""
        return self._order[self._next:]

    def poll(self, cycle: int) -> list[str]:
        start = end = self._next
        while end < len(self._order) and (self._order[end].cycle or 0) <= cycle:
            end += 1
        self._next = end
        return [text for e in self._order[start:end] for text in e.events]

    def waiting(self, cycle: int) -> bool:
        return self._next < len(self._order)

    def wait(self, timeout: float) -> None:
        return None

    def finished(self) -> bool:
        return self._next >= len(self._order)


class LineEvents(EventSource):
    """Events typed on a stream (standard input), read by a background thread.

    A line that cannot be read, or names no event of ``names``, is reported by :meth:`notes`
    with its line number (the loop's record and the progress line show it) and otherwise
    ignored: a typo at the keyboard never stops a robot, and never stops the reader either,
    so every later line still counts. A line longer than :data:`MAX_LINE` characters, or not
    UTF-8, is refused the same way; the reader keeps at most one such line in memory.
    """

    def __init__(self, stream: TextIO, names: Iterable[str], name: str = "<stdin>") -> None:
        self.stream = stream
        self.names = set(names)
        self.name = name
        self._queue: queue.Queue[EventLine | None] = queue.Queue()
        self._held: list[EventLine] = []
        self._eof = False
        self._rejected: queue.Queue[str] = queue.Queue()
        self._thread = threading.Thread(target=self._read, name="cplus-events", daemon=True)
        self._thread.start()

    def _lines(self):
        """``(number, text or None, why)`` for each line: bytes are decoded here, line by line,
        so that one line that is not UTF-8 costs that line only (a text stream's decoder would
        end the iteration), and lines are read with a bound."""
        raw = getattr(self.stream, "buffer", None)
        read = raw.readline if raw is not None else self.stream.readline
        number = 0
        while True:
            chunk = read(MAX_LINE + 1)
            if not chunk:
                return
            number += 1
            too_long = len(chunk) > MAX_LINE and not chunk.endswith(b"\n" if raw is not None else "\n")
            while too_long:                      # skip the rest of the line, a bounded piece at a time
                more = read(MAX_LINE + 1)
                if not more or more.endswith(b"\n" if raw is not None else "\n"):
                    break
            if too_long:
                yield number, None, f"longer than {MAX_LINE} characters"
                continue
            if isinstance(chunk, bytes):
                try:
                    chunk = chunk.decode("utf-8")
                except UnicodeDecodeError:
                    yield number, None, "not UTF-8 text"
                    continue
            yield number, chunk.rstrip("\r\n"), ""

    def _read(self) -> None:
        try:
            for number, text, why in self._lines():
                if text is None:
                    self._rejected.put(f"ignored {self.name} line {number}: {why}")
                    continue
                try:
                    parsed = parse_line(text, Source(f"{self.name}:{number}", text))
                    if parsed is not None:
                        check_events([parsed], self.names)
                        self._queue.put(parsed)
                except EventsError as exc:
                    self._rejected.put(f"ignored {self.name} line {number}: {exc.message}")
                except Exception as exc:  # noqa: BLE001 - a reader that dies loses every later line
                    self._rejected.put(f"ignored {self.name} line {number}: {exc}")
        except (OSError, ValueError) as exc:     # the stream itself failed (closed under us)
            self._rejected.put(f"stopped reading {self.name}: {exc}")
        finally:
            self._queue.put(None)

    def _drain(self) -> None:
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                return
            if item is None:
                self._eof = True
            else:
                self._held.append(item)

    def poll(self, cycle: int) -> list[str]:
        self._drain()
        due: list[EventLine] = []
        later: list[EventLine] = []
        for e in self._held:                     # one pass: linear in the lines held
            (due if e.cycle is None or e.cycle <= cycle else later).append(e)
        self._held = later
        return [text for e in due for text in e.events]

    def wait(self, timeout: float) -> None:
        try:
            item = self._queue.get(timeout=timeout)
        except queue.Empty:
            return
        if item is None:
            self._eof = True
        else:
            self._held.append(item)

    def finished(self) -> bool:
        self._drain()
        return self._eof and not self._held

    def notes(self) -> list[str]:
        out = []
        while not self._rejected.empty():
            out.append(self._rejected.get_nowait())
        return out
