"""The online loop's executor for NXT bricks that run the Legolog behaviour program.

Each of the robot's actions is a behaviour of a brick (the binding file says which, with
which arguments). :class:`NxtExecutor` sends it with :class:`nxt_link.host.behaviours.BehaviourClient`
(ACT -> ACK -> DONE, answering MORE_TIME), maps the sensing values of the DONE to the sensed
fluents of that brick, then polls every brick for events (EXOG) and reads the sensor ports
that the binding names (GETINPUTVALUES, the scaled value as the brick program configured the
port). Actions of one step on one brick run one after another; bricks run in parallel.

Without ports, each brick is emulated in-process on a pseudo-terminal: a
:class:`nxt_link.BrickEmulator` running the behaviour program in the world its binding names
(``world = "world.toml"``), served by :class:`nxt_link.PtyBrickServer`, so the run goes
through the same serial path as a real brick (:class:`nxt_link.emulator.inprocess.EmulatedBricks`).
They run on simulated time unless a ``time_scale`` asks for the wall clock: the executor's
``clock`` is then the bricks' :class:`nxt_link.SimClock`, the thread that opens the executor
takes part in it until it closes it, and the loop should measure its cycles on that clock.

A behaviour that reports failure (stuck, line lost) is the step's ``failure``. A brick that
stops answering is :class:`~cplus.robot.online.loop.RobotLost`.

A step cut short (:attr:`~cplus.robot.online.loop.Step.stop`, ``cplus serve --preempt stop``)
stops each action the binding allows to stop (``stop = "halted"`` in its ``[actions]``
table): the brick is told to ABORT within a poll (every behaviour stops, the motors go to
power 0 and coast), the action counts as executed together with its stop event (``halted``),
and the domain says where that leaves the robot (between two offices, for the mail robot on
its line). The actions after it are not sent; an action without ``stop`` finishes.
:attr:`NxtExecutor.stopped_at` keeps when the last ABORT was acknowledged (the bricks'
clock).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass, field

import nxt_link
from cplus.robot.online.binding import BindingError, RobotBinding
from cplus.robot.online.estimation import Act, OnlineModel
from cplus.robot.online.loop import Executor, Outcome, RobotLost, Step
from nxt_link.emulator.inprocess import EmulatedBricks
from nxt_link.host.behaviours import (
    BehaviourClient,
    BehaviourError,
    BehaviourFailed,
    BehaviourInterrupted,
    BehaviourTiming,
)
from nxt_link.wire.clock import MONOTONIC, Clock, SimClock, clock_of_device, join_threads, start_thread
from nxt_link.wire.errors import LinkError
from nxt_link.wire.serial_transport import SerialTransport

__all__ = ["NxtExecutor", "load_world"]


def load_world(binding: RobotBinding, brick: str):
    """The emulated world of a brick, from the world file its binding names.

    Raises:
        BindingError: no world file is named, or it cannot be read (located at ``world =``).
    """
    spec = binding.bricks[brick]
    if spec.world is None:
        raise BindingError(f"brick '{brick}' has no world to be emulated in: give world = \"world.toml\" in "
                           f"[bricks.{brick}], or its port with --brick {brick}=PORT", spec.location)
    if not spec.world.is_file():
        raise BindingError(f"no world file {spec.world}", spec.world_location)
    from cplus.robot.online.world_file import load_world as load_world_file  # the schema cplus.world/1
    return load_world_file(spec.world)


@dataclass
class _Brick:
    name: str
    client: BehaviourClient
    brick: nxt_link.Brick
    last_readings: dict[str, int] = field(default_factory=dict)


class NxtExecutor(Executor):
    """The robot's actions as behaviours of NXT bricks (real, or emulated in their worlds).

    Args:
        model: the loop's model (for the sensed fluents' values).
        binding: the robot's binding file.
        ports: brick name -> device (``/dev/rfcomm0``, a ``cplus brick`` pty); None: emulate
            every brick in its world.
        latency: emulated bricks answer with Bluetooth timing (False: at once).
        time_scale: None (default): emulated bricks and their worlds run on simulated time
            (then ``clock`` is theirs); a number: on the wall clock, this much faster than
            real time.
        seed: emulated bricks: the seed of their link model, worlds and session ids.
        compiled: emulated bricks run the compiled Legolog program (nbc) on the bytecode
            interpreter instead of its Python model.
        worlds: brick name -> ``nxt_link.emulator.world.WorldSpec``, instead of the binding's world
            files (tests, benchmarks).
        transports: brick name -> an open transport (e.g. a ``MemoryTransport`` on a virtual
            clock), instead of ports or emulation.
        timing: the behaviour client's timeouts.
        policy: the link's timeouts and retries (how long a lost link is reopened).
        on_link_event: receives ``(brick, event, detail)`` from the behaviour clients
            (re-sends, more time, panic): a log line for the curious.
        clock: what a step's duration is measured on (the transports' virtual clock in tests;
            the emulated bricks' simulated clock when they run on one).
    """

    def __init__(self, model: OnlineModel, binding: RobotBinding, ports: Mapping[str, str] | None = None, *,
                 latency: bool = True, time_scale: float | None = None, worlds: Mapping[str, object] | None = None,
                 transports: Mapping[str, object] | None = None, timing: BehaviourTiming | None = None,
                 policy: nxt_link.RetryPolicy | None = None,
                 on_link_event: Callable[[str, str, str], None] | None = None, clock: Clock = MONOTONIC,
                 seed: int = 0, compiled: bool = True) -> None:
        self.model = model
        self.clock = clock
        self.emulated: EmulatedBricks | None = None
        self.binding = binding
        self.ports = dict(ports or {})
        self.latency = latency
        self.time_scale = time_scale
        self.worlds = dict(worlds or {})
        self.transports = dict(transports or {})
        self.timing = timing
        self.policy = policy
        self.on_link_event = on_link_event
        self.bricks: dict[str, _Brick] = {}
        self.servers: dict[str, object] = {}
        self.stopped_at: float | None = None      # when the last action stopped part-way was (bricks' clock)
        self._stack = ExitStack()
        names = list(binding.bricks)
        if self.transports:
            self.description = "NXT bricks " + ", ".join(names)
        elif self.ports:
            self.description = "NXT bricks " + ", ".join(f"{n}={self.ports[n]}" for n in names)
            # ports of bricks emulated in this process on simulated time are used on their clock
            self.clock = clock_of_device(next(iter(self.ports.values()))) or clock
        else:
            for name in names:                      # refuse a missing world before anything starts
                if name not in self.worlds:
                    self.worlds[name] = load_world(binding, name)
            self.emulated = EmulatedBricks(time_scale, seed=seed, compiled=compiled)
            self.clock = self.emulated.clock
            self.description = "emulated NXT bricks " + ", ".join(
                f"{n} (world {getattr(self.worlds[n], 'name', '?')})" for n in names)

    # ------------------------------------------------------------------ connection
    def open(self) -> None:
        sessions: dict[str, int] = {}
        if self.emulated is not None:
            self._stack.enter_context(self.emulated)   # the calling thread takes part in its clock
            sessions = self.emulated.session_ids(self.binding.bricks) or {}
        elif isinstance(self.clock, SimClock) and self.ports:
            self._stack.enter_context(self.clock.participant("pc"))
        try:
            for name in self.binding.bricks:
                transport = self._transport(name)
                brick = nxt_link.Brick(transport, name=name, policy=self.policy)
                self._stack.callback(brick.close)
                client = BehaviourClient(brick, timing=self.timing, on_event=self._link_event(name),
                                         session_id=sessions.get(name))
                client.connect()
                self.bricks[name] = _Brick(name, client, brick)
        except (LinkError, OSError) as exc:
            raise RobotLost(f"brick {name}: {exc}") from None

    def _link_event(self, name: str) -> Callable[[str, str], None] | None:
        report = self.on_link_event
        if report is None:
            return None
        return lambda event, detail: report(name, event, detail)

    def _transport(self, name: str):
        if name in self.transports:
            return self.transports[name]
        if self.ports:
            t = SerialTransport(self.ports[name], clock=self.clock if isinstance(self.clock, SimClock) else MONOTONIC)
            self._stack.callback(t.close)
            return t
        assert self.emulated is not None
        t = self.emulated.add(nxt_link.EmulatorConfig(
            name=name, world=self.worlds[name],  # type: ignore[arg-type]
            link=nxt_link.LinkParams() if self.latency else nxt_link.LinkParams.instant()))
        self.servers[name] = self.emulated.servers[name]
        return t

    def abort(self) -> None:
        for b in self.bricks.values():
            try:
                b.client.abort()
            except LinkError:
                pass

    def close(self) -> None:
        for b in self.bricks.values():
            try:
                b.client.close()
            except LinkError:
                pass
        self.bricks.clear()
        self._stack.close()

    # ------------------------------------------------------------------ steps
    def sense(self) -> Outcome:
        out = Outcome()
        self._read_ports(out, initial=True)
        return out

    def execute(self, step: Step) -> Outcome:
        t0 = self.clock.now()
        out = Outcome()
        by_brick: dict[str, list[Act]] = {}
        for act in step.acts:
            by_brick.setdefault(self.binding.actions[act.gc].brick, []).append(act)
        out.ran = []
        if len(by_brick) <= 1:
            for name, acts in by_brick.items():
                self._run(name, acts, out, step)
        else:
            # one thread per brick (participants of a simulated clock); their outcomes are
            # merged in the bricks' order, whatever order they finished in
            errors: dict[str, BaseException] = {}
            parts = {name: Outcome() for name in by_brick}

            for part in parts.values():
                part.ran = []

            def work(name: str, acts: list[Act]) -> None:
                try:
                    self._run(name, acts, parts[name], step)
                except BaseException as exc:  # noqa: BLE001 - re-raised in the caller's thread
                    errors[name] = exc
            threads = [start_thread(self.clock, f"act-{name}", work, item) for name, item in
                       zip(by_brick, by_brick.items())]
            join_threads(self.clock, threads)
            for part in parts.values():
                _merge(out, part)
            if errors:
                raise errors[next(n for n in by_brick if n in errors)]
        self._poll_events(out)
        self._read_ports(out)
        out.seconds = self.clock.now() - t0
        if out.ran is not None and len(out.ran) == len(step.acts):
            out.ran = None                       # all of them
        elif out.ran is not None:
            out.ran = [a for a in step.acts if a in out.ran]      # in the step's order
        return out

    def poll(self) -> Outcome:
        out = Outcome()
        self._poll_events(out)
        self._read_ports(out)
        return out

    def _run(self, name: str, acts: list[Act], out: Outcome, step: Step) -> None:
        b = self.bricks[name]
        stop = step.stop
        for act in acts:
            bound = self.binding.actions[act.gc]
            if stop is not None and stop.is_set():
                return                          # cut short: the rest is not sent
            cut = stop.is_set if stop is not None and bound.stop is not None else None
            try:
                result = b.client.act(bound.behaviour, bound.call_args(act), interrupt=cut)
            except BehaviourInterrupted as exc:
                assert bound.stop is not None and out.ran is not None
                self.stopped_at = exc.stopped_at
                out.ran.append(act)
                out.events.append(bound.stop)
                out.notes.append(f"{act.text} stopped part-way on brick {name} (motors at power 0): "
                                 f"{bound.stop.text}")
                return
            except BehaviourFailed as exc:      # it ran, and failed
                assert out.ran is not None
                out.ran.append(act)
                self._sensing(name, exc.result.sensing, out)
                out.failure = f"{act.text} on brick {name}: {exc.result.status_name} ({exc})"
                return
            except BehaviourError as exc:       # refused: not started
                out.failure = f"{act.text} on brick {name}: {exc}"
                return
            except LinkError as exc:
                raise RobotLost(f"brick {name}: {exc}") from None
            assert out.ran is not None
            out.ran.append(act)
            self._sensing(name, result.sensing, out)

    def _sensing(self, name: str, sensing: Mapping[str, int], out: Outcome) -> None:
        for key, reading in sensing.items():
            out.raw[f"{name}.{key}"] = reading
        for gc, s in self.binding.sensed.items():
            if s.brick == name and s.value is not None and s.value in sensing:
                value = s.map(sensing[s.value])
                if value is not None:
                    out.sensed[gc] = value

    def _poll_events(self, out: Outcome) -> None:
        for name, b in self.bricks.items():
            try:
                events = b.client.poll_events()
            except LinkError as exc:
                raise RobotLost(f"brick {name}: {exc}") from None
            for e in events:
                gc = self.binding.brick_event(name, e.name, e.args)
                if gc is None:
                    shown = e.name + (f"({','.join(map(str, e.args))})" if e.args else "")
                    out.notes.append(f"ignored event {shown} from brick {name}: no binding")
                elif gc not in out.events:
                    out.events.append(gc)

    def _read_ports(self, out: Outcome, initial: bool = False) -> None:
        sensed = self.binding.sensed
        for name, b in self.bricks.items():
            ports = sorted({s.port for s in sensed.values() if s.brick == name and s.port}
                           | {e.port for e in self.binding.events.values()
                              if e.source == "sensor" and e.brick == name and e.port})
            for port in ports:
                try:
                    reply = b.brick.get_input_values(int(port[1]) - 1)
                except LinkError as exc:
                    raise RobotLost(f"brick {name}: {exc}") from None
                reading = int(reply.scaled_value)
                out.raw[f"{name}.{port}"] = reading
                for gc, s in sensed.items():
                    if s.brick == name and s.port == port:
                        value = s.map(reading)
                        if value is not None:
                            out.sensed[gc] = value
                before = b.last_readings.get(port)
                for gc, e in self.binding.events.items():
                    if e.source == "sensor" and e.brick == name and e.port == port and not initial \
                            and e.crossed(before, reading) and gc not in out.events:
                        out.events.append(gc)
                b.last_readings[port] = reading


def _merge(into: Outcome, part: Outcome) -> None:
    if into.ran is not None:
        into.ran.extend(part.ran or [])
    into.sensed.update(part.sensed)
    into.raw.update(part.raw)
    into.notes.extend(part.notes)
    if part.failure and not into.failure:
        into.failure = part.failure
    for gc in part.events:
        if gc not in into.events:
            into.events.append(gc)
