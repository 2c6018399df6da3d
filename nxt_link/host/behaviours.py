"""The PC side of the behaviour protocol: run a robot one Legolog action at a time.

:class:`BehaviourClient` talks to the Legolog brick program (``cplus_legolog.rxe``, see
:mod:`nxt_link.programs.behaviour_protocol` for the messages) through a :class:`~nxt_link.Brick`,
whose direct commands already survive lost, damaged and late frames and link drops:

* :meth:`~BehaviourClient.connect` — make sure the program runs (start it if nothing
  runs), clear a PANIC an earlier PC left behind (ABORT), then HELLO with a fresh
  session id until WELCOME;
* :meth:`~BehaviourClient.act` — ACT -> ACK -> DONE with the sensing values, answering
  each MORE_TIME with a CONT; returns an :class:`ActResult`, raises
  :class:`BehaviourFailed` when the behaviour reports failure (e.g. STUCK);
* :meth:`~BehaviourClient.poll_events` — EXOG -> EVENTS or NONE; each event exactly once;
* :meth:`~BehaviourClient.abort` — ABORT -> ABORTED: every behaviour stops, PANIC ends;
* :meth:`~BehaviourClient.close` — abort an interrupted action, close the brick.

Timing (:class:`BehaviourTiming`; Legolog's numbers were 3.5 s time-outs and 3 s
actions over infrared, Bluetooth answers in about 30 ms): a request whose answer has
not come within ``resend_s`` (1 s) is sent again — the same ACT number, so the brick
never runs an action twice; while a behaviour runs, these copies also fetch a DONE that
was lost. ``max_silent_s`` (10 s) without any answer of this session means the brick is
lost (:class:`BrickLostError`). On the brick: MORE_TIME every ``ACTION_MS`` (3 s) of
running, re-sent every ``RESEND_MS`` (3.5 s) until a CONT, PANIC after ``MAX_SENDS`` (3)
unanswered copies (about 10.5 s without the PC).

Start an emulated delivery robot in-process and drive it (what ``cplus online`` does
without ``--brick``; ``cplus brick --world world.toml`` does the same on a pty for
another process)::

    from nxt_link import Brick, BrickEmulator, EmulatorConfig, PtyBrickServer, SerialTransport
    from nxt_link.host.behaviours import BehaviourClient, Behaviour
    from nxt_link.emulator.world import delivery_world      # a WorldSpec; from a world file (located
    world = delivery_world()                        # errors): cplus.robot.online.world_file.load_world

    emu = BrickEmulator(EmulatorConfig(name="robot", world=world))
    server = PtyBrickServer(emu)
    path = server.start()                           # the Legolog program runs from power-on
    client = BehaviourClient(Brick(SerialTransport(path), name="robot"))
    client.connect()
    result = client.act(Behaviour.FOLLOW)           # ActResult(sensing={'landmark': 1, ...})
    events = client.poll_events()                   # [BrickEvent('button')] after a press
    client.close(); server.stop()

For fast tests the same emulator runs on a virtual clock behind a
:class:`~nxt_link.MemoryTransport` (no pty, no real time)::

    emu = BrickEmulator(EmulatorConfig(world=delivery_world(), link=LinkParams.instant()))
    client = BehaviourClient(Brick(MemoryTransport(emu, VirtualClock())))

The world's touch sensor can be pressed from the PC side with ``emu.world.press()``.
Messages, timeouts and behaviours: ``docs/nxt-link.md`` ("Behaviours").
"""
from __future__ import annotations

import logging
import random
from collections.abc import Callable
from dataclasses import dataclass, field

from nxt_link.host.brick import Brick, running_program
from nxt_link.programs import behaviour_protocol as bp
from nxt_link.programs.behaviour_protocol import AckCode, Behaviour, Status
from nxt_link.wire.clock import Deadline
from nxt_link.wire.errors import (
    EmptyMailboxError,
    IllegalValueError,
    LinkDisconnectedError,
    LinkError,
    LinkTimeoutError,
    NoActiveProgramError,
    TelegramError,
)

__all__ = ["BehaviourClient", "BehaviourTiming", "ActResult", "BrickEvent", "Behaviour",
           "Status", "BehaviourError", "BehaviourFailed", "BehaviourInterrupted", "BehaviourRefused", "BrickLostError",
           "BrickPanicError"]

log = logging.getLogger(__name__)

_ID0 = 0x8000  # ids of EXOG/ABORT/HELLO requests; ACT numbers stay below


class BehaviourError(LinkError):
    """An action did not do what was asked (the link itself works)."""


class BehaviourFailed(BehaviourError):
    """The behaviour ran and reported failure; ``result`` has its status and sensing values."""

    def __init__(self, message: str, result: ActResult) -> None:
        super().__init__(message)
        self.result = result


class BehaviourInterrupted(BehaviourError):
    """The caller stopped the behaviour part-way (``act(interrupt=...)``): the brick was told
    to ABORT (every behaviour stops, the motors coast) at ``abort_sent_at`` and acknowledged
    it at ``stopped_at`` (the brick's clock): the motors stopped in between."""

    def __init__(self, message: str, stopped_at: float, abort_sent_at: float | None = None) -> None:
        super().__init__(message)
        self.stopped_at = stopped_at
        self.abort_sent_at = stopped_at if abort_sent_at is None else abort_sent_at


class BehaviourRefused(BehaviourError):
    """The brick did not start the action (unknown behaviour, bad arguments, busy)."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code


class BrickLostError(LinkError):
    """No usable answer from the brick program: silent too long, link gone for good, or
    the program stopped. Whether the action in progress ran is unknown."""


class BrickPanicError(BrickLostError):
    """The brick is in PANIC (the PC did not acknowledge it in time); it has stopped its
    motors and accepts only :meth:`BehaviourClient.abort`."""


@dataclass(frozen=True, slots=True)
class BehaviourTiming:
    """The PC side's timeouts (seconds, on the brick's clock).

    Attributes:
        resend_s: a request (ACT, HELLO, EXOG, ABORT) with no answer this long is sent
            again (an ACT with its own number: never executed twice).
        poll_s: pause between reads of an empty response mailbox.
        max_silent_s: no answer of this session at all for this long: the brick is lost.
        program_start_timeout_s: STARTPROGRAM until the program answers.
    """

    resend_s: float = 1.0
    poll_s: float = 0.01
    max_silent_s: float = 10.0
    program_start_timeout_s: float = 5.0

    def __post_init__(self) -> None:
        if min(self.resend_s, self.poll_s, self.max_silent_s, self.program_start_timeout_s) <= 0:
            raise ValueError("behaviour timing values must be > 0")


@dataclass(frozen=True, slots=True)
class ActResult:
    """The end of one action.

    Attributes:
        behaviour: its number.
        status: a :class:`Status` value (OK unless raised inside BehaviourFailed).
        sensing: named values: ``light`` (%), ``touch`` (0/1), ``tray`` (degrees),
            and for FOLLOW ``landmark`` (number reached, 0 if none) and ``distance`` (mm).
        seconds: the behaviour's duration as the brick measured it.
        more_time: how many times the brick asked for more time.
        seq: the ACT number.
    """

    behaviour: int
    status: int
    sensing: dict[str, int]
    seconds: float
    more_time: int = 0
    seq: int = 0

    @property
    def status_name(self) -> str:
        return _name(Status, self.status)


@dataclass(frozen=True, slots=True)
class BrickEvent:
    """An exogenous event the brick detected: ``name`` (e.g. ``button``), ``args``, and
    the brick's running ``number`` of it."""

    name: str
    args: tuple[int, ...] = ()
    number: int = field(default=0, compare=False)


def _name(enum_type: type, value: int) -> str:
    try:
        return str(enum_type(value).name.lower())
    except ValueError:
        return f"{enum_type.__name__.lower()} {value}"


class BehaviourClient:
    """One session with the Legolog brick program on one brick.

    Args:
        brick: the connected brick (its clock is used for every wait).
        timing: the PC side's timeouts.
        on_event: receives (event, detail) for a log: link ok, more time, re-sends,
            damaged answers, events lost, panic, abort.
        session_id: 1..65535; random by default.
        program: the program file to expect (and start) on the brick.
    """

    def __init__(self, brick: Brick, *, timing: BehaviourTiming | None = None,
                 on_event: Callable[[str, str], None] | None = None,
                 session_id: int | None = None, program: str = bp.PROGRAM_NAME) -> None:
        self.brick = brick
        self.name = brick.name
        self.timing = timing or BehaviourTiming()
        self.clock = brick.clock
        self.program = program
        self._on_event = on_event
        self.session = session_id or random.SystemRandom().randrange(1, 0x10000)
        self.connected = False
        self._act = 0  # last ACT number used
        self._in_progress: int | None = None  # an ACT whose end we did not see
        self._next_id = _ID0
        self._aborts = 0
        self._events_have = 0  # every event up to this number was received
        self._events_lost = 0
        self.retransmissions = 0
        self.damaged_responses = 0
        self.more_time_answered = 0
        self.brick_state = bp.State.IDLE

    # -- plumbing ---------------------------------------------------------------------------

    def _event(self, event: str, detail: str = "") -> None:
        log.info("%s: %s %s", self.name, event, detail)
        if self._on_event is not None:
            self._on_event(event, detail)

    def _new_id(self) -> int:
        self._next_id = _ID0 + ((self._next_id - _ID0 + 1) % 0x7FFF)
        return self._next_id

    def _lost(self, what: str) -> BrickLostError:
        return BrickLostError(f"brick {self.name}: {what}")

    def _post(self, req: bp.Request) -> None:
        """Write one request. HELLO asks for the write's reply, so a missing program is seen
        at once; the others do not wait for it (a round trip less; a lost write is covered
        by the re-send timer, a stopped program by the next read)."""
        try:
            self.brick.message_write(bp.CMD_INBOX, bp.encode_request(req),
                                     reply=isinstance(req, bp.Hello))
        except NoActiveProgramError:
            raise self._lost(f"the program {self.program} is not running") from None
        except LinkTimeoutError as exc:
            self._event("write timeout", str(exc))  # the re-send timer covers it
        except LinkDisconnectedError as exc:
            raise self._lost(f"link lost: {exc}") from None

    def _poll(self, *, panic_ok: bool = False) -> bp.Response | None:
        """One response of interest, or None (empty, damaged, stale, unreadable).

        A current PANIC raises BrickPanicError unless ``panic_ok`` (then it is returned).
        """
        try:
            raw = self.brick.message_read(bp.RESPONSE_MAILBOX, 0, True)
        except EmptyMailboxError:
            return None
        except LinkTimeoutError as exc:
            self._event("read timeout", str(exc))
            return None
        except NoActiveProgramError:
            raise self._lost(f"the program {self.program} is no longer running") from None
        except LinkDisconnectedError as exc:
            raise self._lost(f"link lost: {exc}") from None
        try:
            resp = bp.decode_response(raw)
        except TelegramError as exc:
            self.damaged_responses += 1
            self._event("damaged response", str(exc))
            return None
        if isinstance(resp, bp.Panic):
            if resp.aborts < self._aborts:
                return None  # queued before our last ABORT
            self.brick_state = bp.State.PANIC
            if panic_ok:
                return resp
            self._event("panic", f"ACT {resp.seq} ({_name(Behaviour, resp.behaviour)}) was "
                                 "running")
            raise BrickPanicError(
                f"brick {self.name} is in PANIC: it stopped during ACT {resp.seq} "
                f"({_name(Behaviour, resp.behaviour)}) because its requests for more time "
                "were not acknowledged; abort() clears it")
        if isinstance(resp, bp.Aborted):
            return resp  # matched by id: may come from another session's ABORT
        if resp.session != self.session:
            return None
        self.brick_state = bp.State(resp.state) if resp.state in (0, 1, 2) else self.brick_state
        return resp

    def _exchange(self, make: Callable[[int], bp.Request],
                  accept: Callable[[bp.Response, set[int]], bool], *,
                  panic_ok: bool = False) -> bp.Response:
        """Send an unsequenced request until an accepted answer to any copy arrives."""
        ids: set[int] = set()
        heard = self.clock.now()
        while True:
            rid = self._new_id()
            ids.add(rid)
            self._post(make(rid))
            deadline = Deadline(self.clock, self.timing.resend_s)
            while not deadline.expired():
                # the program answers within its loop: read after it had the time to
                self.clock.sleep(self.timing.poll_s)
                resp = self._poll(panic_ok=panic_ok)
                if resp is None:
                    continue
                heard = self.clock.now()
                if accept(resp, ids):
                    return resp
            if self.clock.now() - heard > self.timing.max_silent_s:
                raise self._lost(f"no answer from {self.program} for "
                                 f"{self.timing.max_silent_s:g} s")
            self.retransmissions += 1

    # -- session ------------------------------------------------------------------------------

    def _running_program(self) -> str | None:
        return running_program(self.brick.get_current_program_name, self.program)

    def ensure_program(self, replace: bool = False) -> None:
        """Make sure the behaviour program runs; start it when nothing (or, with
        ``replace``, another program) runs."""
        running = self._running_program()
        if running == self.program:
            return
        if running is not None:
            if not replace:
                raise BehaviourError(f"brick {self.name} is running {running!r}, not "
                                     f"{self.program!r}; stop it on the brick first")
            self.brick.stop_program()
            self.clock.sleep(1.0)  # as nxt-python's MotorControl helper does
        try:
            self.brick.start_program(self.program)
        except IllegalValueError:
            raise BehaviourError(
                f"brick {self.name} has no {self.program}: compile nxt_link/programs/nxc/"
                f"{self.program.removesuffix('.rxe')}.nxc with nbc and download it") from None
        self._event("program started", self.program)
        deadline = Deadline(self.clock, self.timing.program_start_timeout_s)
        while self._running_program() != self.program:
            if deadline.expired():
                raise self._lost(f"{self.program} did not start within "
                                 f"{self.timing.program_start_timeout_s:g} s")
            self.clock.sleep(0.1)

    def connect(self, *, start_program: bool = True, replace_program: bool = False) -> bp.Welcome:
        """Check the program runs (start it), clear a PANIC, open a session. Returns WELCOME.

        Raises:
            BrickLostError: no answer; BehaviourError: another program, no program file,
            or a program speaking another protocol version.
        """
        if start_program:
            self.ensure_program(replace_program)
        for _ in range(3):
            try:
                w = self._exchange(
                    lambda rid: bp.Hello(self.session, rid),
                    lambda r, ids: isinstance(r, bp.Welcome) and r.seq in ids)
            except BrickPanicError:
                self._event("clearing panic", "left by an earlier session")
                self.abort()
                continue
            assert isinstance(w, bp.Welcome)
            if w.code == AckCode.BAD_VERSION:
                raise BehaviourError(f"brick {self.name}: its program speaks behaviour protocol "
                                     f"version {w.version}, this client {bp.PROTOCOL_VERSION}")
            self._aborts = w.aborts
            self._act = w.last_act
            self._events_have = 0
            self.connected = True
            self._event("link ok", f"session {self.session}, {self.program} protocol "
                                   f"v{w.version}")
            return w
        raise self._lost("stays in PANIC after ABORT")

    # -- actions --------------------------------------------------------------------------------

    def act(self, behaviour: int, args: tuple[int, ...] = (), *,
            on_more_time: Callable[[float], None] | None = None,
            interrupt: Callable[[], bool] | None = None) -> ActResult:
        """Execute one behaviour; return when it is done, with its sensing values.

        Args:
            behaviour: a :class:`Behaviour` number.
            args: its integer arguments (int16 each, at most 8).
            on_more_time: called with the seconds elapsed each time the brick asks for
                more time (progress for the caller).
            interrupt: asked at every poll (every ``poll_s``) while the behaviour runs; once
                it says True the brick is told to ABORT and :class:`BehaviourInterrupted`
                is raised (a preempted goal's motion stops within a poll and a round trip).

        Raises:
            BehaviourFailed: the behaviour ended with a failure status (``.result``).
            BehaviourRefused: not started (unknown behaviour, bad arguments, another
                action still running: abort() first).
            BrickLostError, BrickPanicError: no answer / the brick panicked; whether the
                action ran is unknown; abort() (and connect() again) to go on.
        """
        if not self.connected:
            raise BehaviourError(f"brick {self.name}: connect() first")
        seq = self._act + 1
        req = bp.Act(self.session, seq, int(behaviour), tuple(int(a) for a in args))
        bp.encode_request(req)  # TelegramError now for arguments that do not fit
        self._act = seq
        self._in_progress = seq
        more = 0
        self._post(req)
        sent = heard = self.clock.now()
        self.clock.sleep(self.timing.poll_s)  # the program takes the ACT within its loop
        while True:
            resp = None if interrupt is not None and interrupt() else self._poll()
            if interrupt is not None and interrupt():   # asked before the poll, or during its round trip
                sent = self.clock.now()
                self.abort()
                raise BehaviourInterrupted(f"brick {self.name}: ACT {seq} ({_name(Behaviour, behaviour)}) stopped "
                                           "part-way on request", self.clock.now(), sent)
            now = self.clock.now()
            if resp is None:
                if now - heard > self.timing.max_silent_s:
                    raise self._lost(f"no answer to ACT {seq} ({_name(Behaviour, behaviour)}) "
                                     f"for {self.timing.max_silent_s:g} s")
                if now - sent >= self.timing.resend_s:
                    self.retransmissions += 1
                    self._post(req)  # a copy: the brick answers, never runs it again
                    sent = now
                self.clock.sleep(self.timing.poll_s)
                continue
            if resp.seq != seq or isinstance(resp, bp.Welcome | bp.Events | bp.NoEvents
                                              | bp.Aborted):
                continue
            heard = now
            if isinstance(resp, bp.Ack):
                if resp.code in (AckCode.OK, AckCode.DUPLICATE):
                    continue
                self._in_progress = None
                raise BehaviourRefused(
                    f"brick {self.name} refused ACT {seq} ({_name(Behaviour, behaviour)} "
                    f"{list(args)}): {_name(AckCode, resp.code).replace('_', ' ')}", resp.code)
            if isinstance(resp, bp.MoreTime):
                self._post(bp.Cont(self.session, seq, resp.part))
                self.more_time_answered += 1
                more = max(more, resp.part)
                self._event("more time", f"ACT {seq} part {resp.part} after "
                                         f"{resp.elapsed_ms / 1000:.1f} s")
                if on_more_time is not None:
                    on_more_time(resp.elapsed_ms / 1000.0)
                continue
            if isinstance(resp, bp.Done):
                self._in_progress = None
                result = ActResult(resp.behaviour, resp.status,
                                   {_name(bp.Sense, k): v for k, v in resp.values},
                                   resp.elapsed_ms / 1000.0, more, seq)
                if resp.status != Status.OK:
                    raise BehaviourFailed(
                        f"brick {self.name}: {_name(Behaviour, resp.behaviour)} failed: "
                        f"{result.status_name} after {result.seconds:.1f} s "
                        f"({_sensing_text(result.sensing)})", result)
                return result

    # -- events -----------------------------------------------------------------------------------

    def poll_events(self) -> list[BrickEvent]:
        """EXOG: the events the brick detected since the last poll (each exactly once).

        Raises:
            BrickLostError, BrickPanicError: as for :meth:`act`.
        """
        if not self.connected:
            raise BehaviourError(f"brick {self.name}: connect() first")
        out: list[BrickEvent] = []
        while True:
            resp = self._exchange(
                lambda rid: bp.Exog(self.session, rid, self._events_have),
                lambda r, ids: isinstance(r, bp.Events | bp.NoEvents) and r.seq in ids)
            assert isinstance(resp, bp.Events | bp.NoEvents)
            if resp.lost > self._events_lost:
                self._event("events lost", f"the brick dropped {resp.lost - self._events_lost} "
                                           "event(s): its queue was full")
                self._events_lost = resp.lost
            if isinstance(resp, bp.NoEvents):
                return out
            for i, (code, args) in enumerate(resp.events):
                number = resp.first + i
                if number > self._events_have:
                    out.append(BrickEvent(_name(bp.Event, code), tuple(args), number))
                    self._events_have = number
            if len(resp.events) < bp.MAX_EVENTS_PER_MESSAGE:
                # acknowledged by the next poll, whoever makes it
                return out

    @property
    def events_lost(self) -> int:
        """Events the brick could not keep (its queue of EVENT_SLOTS was full)."""
        return self._events_lost

    # -- abort and close ------------------------------------------------------------------------------

    def abort(self) -> None:
        """ABORT: every behaviour stops, the motors coast, PANIC ends (any session).

        Raises:
            BrickLostError: no answer.
        """
        # PANIC messages sent before our ABORT arrived may still be queued: skip them
        resp = self._exchange(lambda rid: bp.Abort(self.session, rid),
                              lambda r, ids: isinstance(r, bp.Aborted) and r.seq in ids,
                              panic_ok=True)
        assert isinstance(resp, bp.Aborted)
        self._aborts = resp.aborts
        if resp.session == self.session:
            self._act = max(self._act, resp.last_act)
        self._in_progress = None
        self.brick_state = bp.State.IDLE
        self._event("aborted", f"abort {resp.aborts}")

    def close(self) -> None:
        """Abort an action we did not see the end of, then close the brick's link."""
        try:
            if self._in_progress is not None and self.connected:
                self.abort()
        except LinkError as exc:
            self._event("abort failed", str(exc))
        finally:
            self.connected = False
            self.brick.close()


def _sensing_text(sensing: dict[str, int]) -> str:
    return ", ".join(f"{k} {v}" for k, v in sensing.items())
