"""Run setpoint streams on several bricks together and collect what they did.

:func:`execute_streams` is the one call the rest of the project needs:
validate every stream (nothing moves if one is refused), upload each stream to
its brick, bring every brick to its initial configuration, send the start
signal to all bricks back to back, report progress while they run, read the
logs back and return an :class:`~nxt_link.execlog.ExecutionLog`.

Bricks are driven one after another within each phase from a single thread:
each phase is short except the run itself, during which the bricks work on
their own (everything was uploaded first), so polling them in turn costs
nothing and keeps the code deterministic under a virtual clock.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from nxt_link import stream_protocol as sp
from nxt_link.brick import Brick, LinkEvent
from nxt_link.errors import SetpointError, StreamError
from nxt_link.execlog import BrickLog, ExecutionLog, LogEvent
from nxt_link.session import PORT_NUMBERS, BrickSession, ControllerSettings, SessionTiming

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
    """

    controller: ControllerSettings = field(default_factory=ControllerSettings)
    timing: SessionTiming = field(default_factory=SessionTiming)
    max_speed_deg_s: float = 1000.0
    start_program: bool = True
    replace_program: bool = False
    run_margin_s: float = 10.0
    start_delay_s: float = 1.0


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
                    session_ids: Mapping[str, int] | None = None) -> ExecutionLog:
    """Execute ``streams`` on ``bricks`` together and return what they did.

    Args:
        streams: one :class:`SetpointStream` per brick, all of the same duration.
        bricks: connected :class:`~nxt_link.brick.Brick` objects by name; they
            must share one clock (real bricks: the monotonic clock).
        options: controller, timeouts, limits.
        on_progress: receives a :class:`Progress` at every step of every phase.
        session_ids: fixed session ids per brick (tests); random by default.

    Returns:
        The :class:`~nxt_link.execlog.ExecutionLog`: per brick the verified
        reference rows, the measured rows and the events.

    Raises:
        SetpointError: a stream was refused before anything moved.
        StreamError: a brick refused something, lacks the program, or failed
            to reach its initial configuration (the bricks are stopped).
        LinkError: the link failed beyond recovery (the bricks are stopped
            where the link still works).

    Example (in-memory emulator, virtual clock)::

        clock = VirtualClock()
        emu = BrickEmulator(EmulatorConfig(name="r1", link=LinkParams.instant()))
        brick = Brick(MemoryTransport(emu, clock), name="r1")
        stream = SetpointStream("r1", ("A",), 50, tuple((k,) for k in range(40)))
        log = execute_streams([stream], {"r1": brick})
    """
    opts = options or ExecutionOptions()
    validate_streams(streams, list(bricks), opts.max_speed_deg_s)
    clock = bricks[streams[0].brick].clock
    t0 = clock.now()
    events: dict[str, list[LogEvent]] = {s.brick: [] for s in streams}

    def note(brick: str) -> Callable[[str, str], None]:
        def record(event: str, detail: str) -> None:
            events[brick].append(LogEvent(round(clock.now() - t0, 4), event, detail))
        return record

    def link_event(ev: LinkEvent) -> None:
        if ev.brick in events:
            events[ev.brick].append(LogEvent(round(ev.t_s - t0, 4), ev.event, ev.detail))

    def report(brick: str, phase: str, done: int, total: int) -> None:
        if on_progress is not None:
            on_progress(Progress(brick, phase, done, total))

    sessions: dict[str, BrickSession] = {}
    for s in streams:
        b = bricks[s.brick]
        b.on_event = _chain(b.on_event, link_event)
        sessions[s.brick] = BrickSession(
            b, s.ports, s.tick_ms, s.rows, s.limits, opts.controller, opts.timing,
            on_event=note(s.brick),
            session_id=(session_ids or {}).get(s.brick))
    started = False
    try:
        for s in streams:
            report(s.brick, "connect", 0, 1)
            sessions[s.brick].open(start_program=opts.start_program,
                                   replace_program=opts.replace_program)
            report(s.brick, "connect", 1, 1)
        for s in streams:
            sessions[s.brick].upload(
                lambda done, total, name=s.brick: report(name, "upload", done, total))  # type: ignore[misc]
        for s in streams:
            sessions[s.brick].prepare()
        for s in streams:
            report(s.brick, "homing", 0, 1)
            sessions[s.brick].wait_ready()
            report(s.brick, "homing", 1, 1)
        # the start signal: one common start time, GO to every brick back to back
        start_at = clock.now() + opts.start_delay_s
        for s in streams:
            sessions[s.brick].post_go(start_at)
        started = True
        latest = [sessions[s.brick].confirm_go() for s in streams]
        skew_bound = max(latest) - start_at
        for s in streams:
            report(s.brick, "start", 1, 1)
        _wait_done(streams, sessions, clock, opts, report)
        logs = []
        for s in streams:
            measured = sessions[s.brick].read_log(
                lambda done, total, name=s.brick: report(name, "log", done, total))  # type: ignore[misc]
            logs.append((s, measured))
    except BaseException:
        if started:
            for sess in sessions.values():
                try:
                    sess.stop()
                except Exception:  # the link may be the reason we are here
                    log.debug("could not stop %s", sess.name, exc_info=True)
        raise
    finally:
        for s in streams:
            bricks[s.brick].on_event = _unchain(bricks[s.brick].on_event)
    for s in streams:
        report(s.brick, "done", 1, 1)
    return ExecutionLog(
        tuple(BrickLog(s.brick, s.ports, s.tick_ms, s.rows, measured, tuple(events[s.brick]))
              for s, measured in logs),
        round(skew_bound, 4))


def _wait_done(streams: Sequence[SetpointStream], sessions: Mapping[str, BrickSession],
               clock, opts: ExecutionOptions,
               report: Callable[[str, str, int, int], None]) -> None:
    duration = max(s.duration_s for s in streams)
    start = clock.now()
    pending = {s.brick for s in streams}
    while pending:
        for s in streams:
            if s.brick not in pending:
                continue
            ack = sessions[s.brick].poll_progress()
            report(s.brick, "run", min(ack.logged, len(s.rows)), len(s.rows))
            if ack.state == sp.State.DONE:
                pending.discard(s.brick)
        if not pending:
            return
        if clock.now() - start > duration + opts.run_margin_s:
            raise StreamError(f"brick(s) {', '.join(sorted(pending))} not done "
                              f"{opts.run_margin_s:g} s after the trajectory should have ended")
        clock.sleep(opts.timing.query_interval_s)


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
