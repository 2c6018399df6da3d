"""Executors of the online loop that need no hardware: a simulated robot.

:class:`SimulatedExecutor` is a world that does what the model predicts, except where told
otherwise. Each action takes a configurable (simulated or real) time; a step cut short
(:attr:`~cplus.robot.online.loop.Step.stop`, ``--preempt stop``) ends at once with none of its
actions done: the simulated robot stays where it was. The sensed fluents
report their values in the simulated world. Faults can be scheduled by cycle: an event that
happens, observed or not (a button press, a missed landmark); a sensor that reads a wrong
value; an action that fails; a robot that stops answering. The loop's tests use it, and so
does a server whose requests need no robot. The NXT executor is
:mod:`cplus.robot.online.nxt_executor`.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping

from cplus.robot.online.estimation import OnlineModel, Roles, State, json_value
from cplus.robot.online.loop import Executor, Outcome, RobotLost, Step
from cplus.signature import GroundConst
from nxt_link.wire.clock import MONOTONIC, Clock, MonotonicClock

__all__ = ["SimulatedExecutor"]


class SimulatedExecutor(Executor):
    """A simulated robot for :class:`~cplus.robot.online.loop.OnlineLoop`.

    Args:
        model: the loop's model (the simulated world uses its domain and roles).
        sensed: the fluents the robot senses (their text), each mapped to the names of the
            actions after which it is read (None: after every step that does something).
        durations: seconds per action name; ``default_s`` for the others. A step lasts as
            long as its longest action.
        events: by cycle, events that happen during that cycle's step (their text). Observed
            ones are reported as the robot's; inferred ones only change the world.
        readings: by cycle, sensor readings that override the world's (``{"atLandmark": 4}``):
            a sensor that lies, or a world the model does not describe.
        failures: by cycle, the reason the step's actions fail (nothing changes).
        lost_at: the cycle at which the robot stops answering (:class:`RobotLost`).
        clock: the clock actions take their time on (a ``VirtualClock`` in tests).
    """

    def __init__(self, model: OnlineModel, *, sensed: Mapping[str, Iterable[str] | None] | Iterable[str] = (),
                 durations: Mapping[str, float] | None = None, default_s: float = 0.0,
                 events: Mapping[int, Iterable[str]] | None = None,
                 readings: Mapping[int, Mapping[str, object]] | None = None,
                 failures: Mapping[int, str] | None = None, lost_at: int | None = None,
                 clock: Clock = MONOTONIC, name: str = "robot") -> None:
        self.model = model
        self.name = name
        self.clock = clock
        self.durations = dict(durations or {})
        self.default_s = default_s
        table = sensed if isinstance(sensed, Mapping) else {f: None for f in sensed}
        self.sensed: dict[GroundConst, frozenset[str] | None] = {
            self._gc(f): (None if after is None else frozenset(after)) for f, after in table.items()}
        self.events = {c: [self._gc(e) for e in es] for c, es in (events or {}).items()}
        self.readings = {c: {self._gc(f): _internal(v) for f, v in r.items()} for c, r in (readings or {}).items()}
        self.failures = dict(failures or {})
        self.lost_at = lost_at
        roles = model.roles
        # the world fixes every event: what the schedule says happens, happens; nothing else
        self.world = OnlineModel(model.domain, model.query.label, Roles(roles.agent, roles.events))
        self.log: list[tuple[int, list[str], State]] = []
        timing = f"{default_s:g} s per action" + (", some timed by name" if self.durations else "")
        self.description = f"simulated robot ({', '.join(f.text for f in self.sensed) or 'no sensors'}; {timing})"

    @classmethod
    def from_binding(cls, model: OnlineModel, binding, **kw) -> SimulatedExecutor:
        """A simulated robot that senses what a binding file says its bricks sense: a sensing
        value after each action of its brick, a sensor port after every step."""
        sensed: dict[str, list[str] | None] = {}
        for gc, s in binding.sensed.items():
            sensed[gc.text] = None if s.port is not None else \
                [a.decl.name for a, ab in binding.actions.items() if ab.brick == s.brick]
        return cls(model, sensed=sensed, **kw)

    def _gc(self, text: str) -> GroundConst:
        gc = self.model.by_text.get("".join(text.split()))
        if gc is None:
            raise ValueError(f"{text!r} is not a ground constant of {self.model.domain.path}")
        return gc

    def execute(self, step: Step) -> Outcome:
        if self.lost_at is not None and step.cycle >= self.lost_at:
            raise RobotLost(f"{self.name}: no answer at cycle {step.cycle} (simulated)")
        seconds = max((self.durations.get(a.name, self.default_s) for a in step.acts), default=self.default_s)
        if not self._sleep(seconds, step):
            shown = ", ".join(a.text for a in step.acts)
            return Outcome(ran=[], notes=[f"stopped before {shown} was done (the simulated robot stays where it "
                                          "was)"], seconds=seconds)
        if step.cycle in self.failures:
            return Outcome(failure=self.failures[step.cycle], seconds=seconds)
        happen = self.events.get(step.cycle, [])
        if step.predicted is not None and not happen:
            new = step.predicted
        else:
            est = self.world.estimate(step.state, step.acts, happen)
            if not est.states:
                what = ", ".join(gc.text for gc in happen) or "nothing"
                return Outcome(failure=f"the simulated world cannot do this with {what} happening "
                                       f"({'; '.join(est.unexplained)})", seconds=seconds)
            new = est.states[0]
        self.log.append((step.cycle, [a.text for a in step.acts], new))
        names = {a.name for a in step.acts}
        sensed = {gc: new[gc] for gc, after in self.sensed.items()
                  if (after is None and step.acts) or (after is not None and after & names)}
        for gc, v in self.readings.get(step.cycle, {}).items():
            sensed[gc] = v
        observed = [gc for gc in happen if gc in self.model.roles.observed]
        raw = {f"{self.name}.{gc.text}": json_value(gc, v) for gc, v in sensed.items()}
        return Outcome(sensed, observed, raw, seconds=seconds)


    _SLICE_S = 0.01

    def _sleep(self, seconds: float, step: Step) -> bool:
        """The step's time, in slices so that a cut (``step.stop``) is heard within one; False
        when it was cut short."""
        stop = step.stop
        if stop is None or not step.acts:
            self.clock.sleep(seconds)
            return True
        if not _real(self.clock):            # simulated time: one sleep (its times stay exact)
            if stop.is_set():
                return False
            self.clock.sleep(seconds)
            return True
        left = seconds
        while left > 0:
            if stop.is_set():
                return False
            self.clock.sleep(min(self._SLICE_S, left))
            left -= self._SLICE_S
        return True                       # its time is over: done


def _real(clock: Clock) -> bool:
    """Whether ``clock`` is the wall clock (a server's clock says so with ``real``)."""
    return isinstance(clock, MonotonicClock) or bool(getattr(clock, "real", False))


def _internal(value: object) -> object:
    """A Python value as the planner writes it (``True`` is ``"true"``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return value
