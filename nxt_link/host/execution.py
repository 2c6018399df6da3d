"""Run setpoint streams on several bricks together and collect what they did.

:func:`execute_streams` is the one call the rest of the project needs:
validate every stream (nothing moves if one is refused), connect, check that
every motor stands near its first setpoint (nothing moves if one does not),
upload each stream to its brick, bring every brick to its initial
configuration, send the start signal to all bricks back to back, report
progress while they run, read the logs back and return an
:class:`~nxt_link.host.execlog.ExecutionLog`.

Nothing gathered is lost: when a brick fails for good (no valid answer for
``SessionTiming.max_silent_s``, a link that cannot be reopened, a refusal),
every other brick is sent STOP at once, the logs of the bricks still reachable
are read back (resuming where a read stopped), and
:class:`~nxt_link.wire.errors.ExecutionFailed` carries the incomplete log: what each
brick recorded, the reason and the time it stopped. Ctrl-C does the same
without the read-back (:class:`~nxt_link.wire.errors.ExecutionInterrupted`).

Bricks are driven one after another within each phase from a single thread:
each phase is short except the run itself, during which the bricks work on
their own (everything was uploaded first), so polling them in turn costs
nothing and keeps the code deterministic under a virtual clock.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from nxt_link.host.brick import Brick, LinkEvent
from nxt_link.host.execlog import BrickLog, ExecutionLog, LogEvent, Stopped
from nxt_link.host.session import PORT_NUMBERS, BrickSession, ControllerSettings, SessionTiming
from nxt_link.programs import stream_protocol as sp
from nxt_link.wire.clock import Deadline
from nxt_link.wire.errors import (
    ExecutionFailed,
    ExecutionInterrupted,
    LinkDisconnectedError,
    LinkError,
    LinkTimeoutError,
    SetpointError,
    StreamError,
)

__all__ = ["SetpointStream", "ExecutionOptions", "Progress", "execute_streams",
           "validate_streams"]

log = logging.getLogger(__name__)

INT16 = (-32768, 32767)


@dataclass(frozen=True, slots=True)
class SetpointStream:
    """The motor setpoints of one brick: one row per tick, one integer degree per port.

    Attributes:
        brick: brick (robot) name, the key of the ``bricks`` mapping.
        ports: port letters ("A", "B", "C"), the order of each row's values.
        tick_ms: duration of one row (10..10000 ms, the brick's loop is 10 ms).
        rows: absolute motor angles in degrees relative to the motor position
            when the brick program started; row 0 is the initial configuration.
        limits_deg: optional (min, max) per port; the brick program enforces
            them too. Default: the int16 range.

    Raises:
        SetpointError: malformed or out-of-range stream (checked on creation).
    """

    brick: str
    ports: tuple[str, ...]
    tick_ms: int
    rows: tuple[tuple[int, ...], ...]
    limits_deg: tuple[tuple[int, int], ...] | None = None

    def __post_init__(self) -> None:
        who = f"stream {self.brick!r}"
        if not self.brick:
            raise SetpointError("stream without a brick name")
        if (not self.ports or len(self.ports) > sp.MAX_PORTS
                or any(p not in PORT_NUMBERS for p in self.ports)
                or len(set(self.ports)) != len(self.ports)):
            raise SetpointError(f"{who}: ports must be 1-3 distinct letters among A, B, C, "
                                f"got {list(self.ports)}")
        if not isinstance(self.tick_ms, int) or not sp.CONTROL_MS <= self.tick_ms <= 10000:
            raise SetpointError(f"{who}: tick_ms must be an integer in "
                                f"{sp.CONTROL_MS}..10000, got {self.tick_ms!r}")
        if not self.rows:
            raise SetpointError(f"{who}: no setpoints")
        if len(self.rows) * len(self.ports) > sp.MAX_VALUES:
            raise SetpointError(
                f"{who}: {len(self.rows)} ticks x {len(self.ports)} ports exceed the brick "
                f"program's {sp.MAX_VALUES} values (use a longer tick)")
        limits = self.limits_deg or tuple(INT16 for _ in self.ports)
        if len(limits) != len(self.ports):
            raise SetpointError(f"{who}: {len(limits)} limits for {len(self.ports)} ports")
        for (lo, hi), port in zip(limits, self.ports):
            if not (INT16[0] <= lo <= hi <= INT16[1]):
                raise SetpointError(f"{who}: port {port} limits [{lo}, {hi}] are not a range "
                                    f"within {list(INT16)}")
        for k, row in enumerate(self.rows):
            if len(row) != len(self.ports):
                raise SetpointError(f"{who}: tick {k} has {len(row)} values for "
                                    f"{len(self.ports)} ports")
            for v, port, (lo, hi) in zip(row, self.ports, limits):
                if not isinstance(v, int) or isinstance(v, bool):
                    raise SetpointError(f"{who}: tick {k} port {port}: {v!r} is not an "
                                        "integer degree")
                if not lo <= v <= hi:
                    raise SetpointError(f"{who}: tick {k} port {port}: {v} deg is outside "
                                        f"the limits [{lo}, {hi}]")

    @property
    def limits(self) -> tuple[tuple[int, int], ...]:
        return self.limits_deg or tuple(INT16 for _ in self.ports)

    @property
    def duration_s(self) -> float:
        return len(self.rows) * self.tick_ms / 1000.0


@dataclass(frozen=True, slots=True)
class ExecutionOptions:
    """Knobs of :func:`execute_streams`.

    Attributes:
        controller: the brick P-controller settings.
        timing: streaming protocol timeouts.
        max_speed_deg_s: refuse a stream whose consecutive rows need a motor
            faster than this (the 9842 motor does about 1000 deg/s unloaded).
        start_program: start ``cplus_follow.rxe`` on a brick where nothing runs.
        replace_program: stop another running program first (else an error).
        run_margin_s: give up when a brick is not done this long after the
            trajectory should have ended.
        start_delay_s: the common start time is this far after the first GO
            is sent, leaving room to resend a lost GO without skewing the start.
        max_start_offset_deg: refuse, before anything moves, a stream whose
            first setpoint is farther than this from where its motor stands
            (homing would swing the arm there unplanned); None: no check.
        time_scale: the bricks' clocks run this many times faster than ours
            (emulated bricks with a time scale; 1 for real bricks).
    """

    controller: ControllerSettings = field(default_factory=ControllerSettings)
    timing: SessionTiming = field(default_factory=SessionTiming)
    max_speed_deg_s: float = 1000.0
    start_program: bool = True
    replace_program: bool = False
    run_margin_s: float = 10.0
    start_delay_s: float = 1.0
    max_start_offset_deg: int | None = 10
    time_scale: float = 1.0

    def __post_init__(self) -> None:
        if not self.time_scale > 0:
            raise ValueError("time_scale must be > 0")
        if self.max_start_offset_deg is not None and self.max_start_offset_deg < 0:
            raise ValueError("max_start_offset_deg must be >= 0")


@dataclass(frozen=True, slots=True)
class Progress:
    """A progress report: ``phase`` of ``brick`` is ``done`` of ``total``.

    Phases: "connect", "upload", "homing", "start", "run", "log", "done".
    """

    brick: str
    phase: str
    done: int
    total: int


def validate_streams(streams: Sequence[SetpointStream], brick_names: Sequence[str],
                     max_speed_deg_s: float) -> None:
    """Refuse, before anything moves, what cannot be executed.

    Raises:
        SetpointError: no stream, duplicate brick, a stream without a brick,
            or a step between rows faster than the motor can go.
    """
    if not streams:
        raise SetpointError("no setpoint stream to execute")
    seen: set[str] = set()
    for s in streams:
        if s.brick in seen:
            raise SetpointError(f"two streams for brick {s.brick!r}")
        seen.add(s.brick)
        if s.brick not in brick_names:
            raise SetpointError(f"stream {s.brick!r} has no brick (bricks: "
                                f"{', '.join(sorted(brick_names)) or 'none'})")
        max_step = max_speed_deg_s * s.tick_ms / 1000.0
        for k in range(1, len(s.rows)):
            for j, port in enumerate(s.ports):
                step = abs(s.rows[k][j] - s.rows[k - 1][j])
                if step > max_step:
                    raise SetpointError(
                        f"stream {s.brick!r} port {port}: {step} deg between ticks {k - 1} and "
                        f"{k} needs {step * 1000.0 / s.tick_ms:.0f} deg/s, more than the "
                        f"{max_speed_deg_s:g} deg/s a motor can do")
    ticks = {len(s.rows) * s.tick_ms for s in streams}
    if len(ticks) > 1:
        raise SetpointError("streams of different durations: "
                            + ", ".join(f"{s.brick}={s.duration_s:g}s" for s in streams))


def execute_streams(streams: Sequence[SetpointStream], bricks: Mapping[str, Brick], *,
                    options: ExecutionOptions | None = None,
                    on_progress: Callable[[Progress], None] | None = None,
                    session_ids: Mapping[str, int] | None = None,
                    on_snapshot: Callable[[Callable[[str], ExecutionLog]], None] | None = None
                    ) -> ExecutionLog:
    """Execute ``streams`` on ``bricks`` together and return what they did.

    Args:
        streams: one :class:`SetpointStream` per brick, all of the same duration.
        bricks: connected :class:`~nxt_link.host.brick.Brick` objects by name; they
            must share one clock (real bricks: the monotonic clock).
        options: controller, timeouts, limits.
        on_progress: receives a :class:`Progress` at every step of every phase; an
            exception it raises stops every brick at once (STOP, acknowledged) and is
            raised to the caller.
        session_ids: fixed session ids per brick (tests); random by default.
        on_snapshot: receives, before anything moves, ``snapshot(reason)``: the log gathered
            so far, marked stopped now for ``reason``. It is for a shutdown watchdog that
            must write the log from another thread while this one is stuck on a link (a
            reconnect); best effort, since it reads what this thread may still be writing.

    Returns:
        The complete :class:`~nxt_link.host.execlog.ExecutionLog`: per brick the
        verified reference rows, the measured rows, when it started and the events.

    Raises:
        SetpointError: a stream was refused before anything moved (also a first
            setpoint far from where its motor stands).
        ExecutionFailed: a brick refused something, lacks the program, failed to
            reach its initial configuration, or its link failed beyond recovery;
            the other bricks were stopped at once and ``.log`` holds what every
            brick recorded (incomplete, with the reason and the time). It is also
            an instance of the cause's class (``StreamError``, ``LinkTimeoutError``,
            ...), which is its ``__cause__``.
        ExecutionInterrupted: Ctrl-C; the bricks were told to stop.

    Example (in-memory emulator, virtual clock)::

        clock = VirtualClock()
        emu = BrickEmulator(EmulatorConfig(name="r1", link=LinkParams.instant()))
        brick = Brick(MemoryTransport(emu, clock), name="r1")
        stream = SetpointStream("r1", ("A",), 50, tuple((k,) for k in range(40)))
        log = execute_streams([stream], {"r1": brick})
    """
    opts = options or ExecutionOptions()
    validate_streams(streams, list(bricks), opts.max_speed_deg_s)
    execution = _Execution(streams, bricks, opts, on_progress, session_ids or {})
    if on_snapshot is not None:
        on_snapshot(execution.snapshot)
    return execution.run()


class _Execution:
    """One call of :func:`execute_streams`: the sessions, their events, and what failed."""

    def __init__(self, streams: Sequence[SetpointStream], bricks: Mapping[str, Brick],
                 opts: ExecutionOptions, on_progress: Callable[[Progress], None] | None,
                 session_ids: Mapping[str, int]) -> None:
        self.streams = list(streams)
        self.bricks = bricks
        self.opts = opts
        self.on_progress = on_progress
        self.clock = bricks[streams[0].brick].clock
        self.t0 = self.clock.now()
        self.events: dict[str, list[LogEvent]] = {s.brick: [] for s in streams}
        self.current: str | None = None  # the brick being talked to
        self.opened: list[str] = []
        self.sessions = {
            s.brick: BrickSession(bricks[s.brick], s.ports, s.tick_ms, s.rows, s.limits,
                                  opts.controller, opts.timing, on_event=self._note(s.brick),
                                  session_id=session_ids.get(s.brick),
                                  time_scale=opts.time_scale)
            for s in streams}

    def _note(self, brick: str) -> Callable[[str, str], None]:
        def record(event: str, detail: str) -> None:
            self.events[brick].append(LogEvent(round(self.clock.now() - self.t0, 4), event,
                                               detail))
        return record

    def _link_event(self, ev: LinkEvent) -> None:
        if ev.brick in self.events:
            self.events[ev.brick].append(LogEvent(round(ev.t_s - self.t0, 4), ev.event,
                                                  ev.detail))

    def _report(self, brick: str, phase: str, done: int, total: int) -> None:
        if self.on_progress is not None:
            self.on_progress(Progress(brick, phase, done, total))

    # -- the phases -------------------------------------------------------------------

    def run(self) -> ExecutionLog:
        for s in self.streams:
            b = self.bricks[s.brick]
            b.on_event = _chain(b.on_event, self._link_event)
        try:
            self._connect()
            self._check_start()
            for s in self.streams:
                self.current = s.brick
                self.sessions[s.brick].upload(
                    lambda done, total, name=s.brick: self._report(name, "upload", done, total))  # type: ignore[misc]
            for s in self.streams:
                self.current = s.brick
                self.sessions[s.brick].prepare()
            for s in self.streams:
                self.current = s.brick
                self._report(s.brick, "homing", 0, 1)
                self.sessions[s.brick].wait_ready()
                self._report(s.brick, "homing", 1, 1)
            self._start()
            self._wait_done()
            for s in self.streams:
                self.current = s.brick
                self.sessions[s.brick].read_log(
                    lambda done, total, name=s.brick: self._report(name, "log", done, total))  # type: ignore[misc]
        except SetpointError:
            raise  # refused before anything moved
        except KeyboardInterrupt as exc:   # Ctrl-C, or a SIGTERM raised as one (its text says which)
            stopped = self._stopped(str(exc) or "interrupted")
            self._stop_all(failed=None, confirm_s=1.0, shared=True)
            raise ExecutionInterrupted(self._log(stopped)) from None
        except LinkError as exc:
            stopped = self._stopped(str(exc))
            self._abort(exc)
            raise ExecutionFailed.of(exc, self._log(stopped), stopped.brick) from exc
        except Exception:
            # the caller's on_progress gave up (a motor off its setpoints): every brick stops
            # at once, before the caller looks at the arms; the exception is the caller's
            self._stop_all(failed=None, confirm_s=self.opts.timing.max_silent_s)
            raise
        finally:
            for s in self.streams:
                self.bricks[s.brick].on_event = _unchain(self.bricks[s.brick].on_event)
        for s in self.streams:
            self._report(s.brick, "done", 1, 1)
        return self._log(None)

    def _connect(self) -> None:
        for s in self.streams:
            self.current = s.brick
            self._report(s.brick, "connect", 0, 1)
            self.sessions[s.brick].open(start_program=self.opts.start_program,
                                        replace_program=self.opts.replace_program)
            self.opened.append(s.brick)
            self._report(s.brick, "connect", 1, 1)

    def _check_start(self) -> None:
        """Refuse, before anything moves, a first setpoint far from where the motor is."""
        limit = self.opts.max_start_offset_deg
        if limit is None:
            return
        for s in self.streams:
            self.current = s.brick
            angles = self.sessions[s.brick].motor_angles()
            for port, angle, first in zip(s.ports, angles, s.rows[0]):
                if abs(first - angle) > limit:
                    raise SetpointError(
                        f"brick {s.brick} motor {port} stands at {angle} deg, the trajectory "
                        f"starts at {first} deg ({abs(first - angle)} deg away, more than "
                        f"{limit}): move the arm to the start configuration and restart "
                        f"{sp.PROGRAM_NAME} there (its encoders count from where it started)")

    def _start(self) -> None:
        """GO to every brick back to back, then look after all of them in turn."""
        start_at = self.clock.now() + self.opts.start_delay_s
        for s in self.streams:
            self.current = s.brick
            self.sessions[s.brick].post_go(start_at)
        pending = [s.brick for s in self.streams]
        while pending:
            for name in list(pending):
                self.current = name
                if self.sessions[name].poll_go() is not None:
                    pending.remove(name)
                    self._report(name, "start", 1, 1)

    def _wait_done(self) -> None:
        duration = max(s.duration_s for s in self.streams) / self.opts.time_scale
        start = self.clock.now()
        pending = {s.brick for s in self.streams}
        while pending:
            for s in self.streams:
                if s.brick not in pending:
                    continue
                self.current = s.brick
                ack = self.sessions[s.brick].poll_progress()
                self._report(s.brick, "run", min(ack.logged, len(s.rows)), len(s.rows))
                if ack.state == sp.State.DONE:
                    pending.discard(s.brick)
            if not pending:
                return
            self.current = None
            if self.clock.now() - start > duration + self.opts.run_margin_s:
                raise StreamError(f"brick(s) {', '.join(sorted(pending))} not done "
                                  f"{self.opts.run_margin_s:g} s after the trajectory should "
                                  "have ended")
            self.clock.sleep(self.opts.timing.query_interval_s)

    # -- failure ----------------------------------------------------------------------------

    def _stopped(self, reason: str) -> Stopped:
        return Stopped(round(self.clock.now() - self.t0, 4), reason, self.current)

    def snapshot(self, reason: str) -> ExecutionLog:
        """The log so far, stopped now for ``reason`` (from another thread: see
        :func:`execute_streams`' ``on_snapshot``)."""
        return self._log(self._stopped(reason))

    def _stop_all(self, failed: str | None, confirm_s: float, *, shared: bool = False) -> None:
        """STOP to every opened brick but ``failed`` at once, then make sure they got it:
        each within ``confirm_s``, or (``shared``) all of them within ``confirm_s`` together,
        each brick in turn getting an equal share of what is left (a brick that answers
        leaves its share to the next), so that Ctrl-C ends within its limit however many
        bricks are silent."""
        others = [n for n in self.opened if n != failed]
        for name in others:
            try:
                self.sessions[name].post_stop()
            except LinkError:
                pass  # stop() below tries again
        deadline = Deadline(self.clock, confirm_s)
        for k, name in enumerate(others):
            share = confirm_s if not shared else (deadline.remaining() or 0.0) / (len(others) - k)
            self.sessions[name].stop(share)

    def _abort(self, exc: LinkError) -> None:
        """Stop every brick (the others first), then read back what they logged."""
        failed = self.current
        lost = isinstance(exc, (LinkTimeoutError, LinkDisconnectedError))
        self._stop_all(failed, self.opts.timing.max_silent_s)
        if failed is not None and failed in self.opened \
                and not isinstance(exc, LinkDisconnectedError):  # its port cannot be reopened
            # one short try at a brick that went silent (its link may come back); a brick that
            # refused something still answers and is stopped like the others
            self.sessions[failed].stop(2 * self.opts.timing.ack_timeout_s if lost
                                       else self.opts.timing.max_silent_s)
        for s in self.streams:
            sess = self.sessions[s.brick]
            if not sess.go_sent or (s.brick == failed and lost):
                continue  # never started, or gone
            self.current = s.brick
            try:
                sess.read_log(lambda done, total, name=s.brick: self._report(  # type: ignore[misc]
                    name, "log", done, total), rows=sess.logged)
            except LinkError as err:
                self.events[s.brick].append(LogEvent(round(self.clock.now() - self.t0, 4),
                                                     "log read failed", str(err)))

    # -- the log ------------------------------------------------------------------------------

    def _log(self, stopped: Stopped | None) -> ExecutionLog:
        x = self.opts.time_scale
        logs = []
        windows = []
        for s in self.streams:
            sess = self.sessions[s.brick]
            got = sess.log_rows
            if stopped is None:
                measured: tuple[tuple[int, ...] | None, ...] = tuple(got[r] for r in range(len(s.rows)))
            else:
                n = min(len(s.rows), max([sess.logged, *(r + 1 for r in got)]))
                measured = tuple(got.get(r) for r in range(n))
            window = None
            if sess.start_window is not None:
                lo, hi = sess.start_window
                window = (round(lo - self.t0, 4), round(hi - self.t0, 4))
                windows.append(sess.start_window)
            logs.append(BrickLog(s.brick, s.ports, s.tick_ms, s.rows, measured,
                                 tuple(self.events[s.brick]), window, sess.phase))
        bound = (max(hi for _, hi in windows) - min(lo for lo, _ in windows)) * x \
            if len(windows) > 1 else 0.0
        return ExecutionLog(tuple(logs), round(bound, 4), stopped, x)


class _Chained:
    def __init__(self, first: Callable[[LinkEvent], None] | None,
                 second: Callable[[LinkEvent], None]) -> None:
        self.first, self.second = first, second

    def __call__(self, ev: LinkEvent) -> None:
        if self.first is not None:
            self.first(ev)
        self.second(ev)


def _chain(first: Callable[[LinkEvent], None] | None,
           second: Callable[[LinkEvent], None]) -> _Chained:
    return _Chained(first, second)


def _unchain(hook: Callable[[LinkEvent], None] | None) -> Callable[[LinkEvent], None] | None:
    return hook.first if isinstance(hook, _Chained) else hook
