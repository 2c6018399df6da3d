"""Monitoring the payload arms while they move: a stalled joint, a safe stop, a re-plan from
where the arms are.

The arms do not run one C+ step at a time as the delivery robot does. A refined plan becomes
one joint trajectory, and the bricks follow it with their P-controllers
(:func:`nxt_link.execute_streams`). :func:`run_arms` watches that execution:

1. plan from the current state with the refinement loop (:func:`cplus.robot.offline.refine`, in a
   solver prepared by :meth:`OnlineModel.session`, with the clauses that earlier refinements
   learned: a motion that collided once is never proposed again);
2. build the trajectory and stream it to the bricks. At every progress report of the
   streaming protocol, the PC reads each motor's angle (GETOUTPUTSTATE) and compares a
   brick's motors with the setpoints of the tick that fits them best, among the ticks around
   the one the brick has logged (:data:`TRACKING_WINDOW_TICKS` before it,
   :data:`TRACKING_AHEAD_TICKS` after it, since the report and the readings take time on the
   link). A brick drives all its motors on one clock, so a motor that does not fit the tick
   of the others is not following. When its error exceeds :data:`TRACKING_THRESHOLD_DEG`, the
   cause is a stalled motor, a caught cable or a hand in the way;
3. then both bricks are stopped at once (the protocol's STOP, :func:`nxt_link.execute_streams`
   does it when the monitor raises), every motor is braked (power 0, the short-circuit brake:
   a coasting carriage runs on for tens of degrees) and the angles are read once the arms
   stand still (:func:`stop_and_measure`). Forward kinematics gives each end-effector's position, which is
   mapped to the nearest *grid state*: the closest grid points the arms can reach, such that,
   with the payload ends that were held moving with their robots and the step's other effects
   (its cost) counted, the domain's static laws allow the state (a horizon-0 query,
   :meth:`OnlineModel.complete`);
4. the rest is re-planned from that state (1). The bricks go to the new trajectory's start
   (the streaming protocol's homing, a short joint-space move of under half a cell) and run
   it. When no plan exists from there, or the arms cannot reach the new start (a motor
   stalled for good), the run stops safely: every brick's program is stopped and every motor
   coasts (:meth:`ArmsExecutor.abort`).

After a complete trajectory the arms' final angles are mapped the same way: a state that is
not the plan's last is re-planned from too. Each segment (a plan and its execution) is one
record of the ``cplus.online/1`` log. Its ``cycle`` is the C+ step the segment starts at, its
``executed`` holds the actions of the steps it started, its ``failure`` names the fault, and
``raw`` holds the motor angles read.
"""
from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from itertools import product

import nxt_link
from cplus.robot.execution import streams_from_trajectory
from cplus.robot.offline import RefineStatus, RobotTask, TaskError, refine
from cplus.robot.online.estimation import OnlineModel, Plan, Roles, State
from cplus.robot.online.loop import CycleRecord, Observer, OnlineStatus, Replan, RunResult
from cplus.signature import GroundConst
from nxt_link.emulator.inprocess import EmulatedBricks
from nxt_link.emulator.stall import Stall
from nxt_link.wire.clock import MONOTONIC, Clock, SimClock, clock_of_device
from nxt_link.wire.errors import LinkError, NoActiveProgramError, SetpointError, StreamError

__all__ = ["TRACKING_THRESHOLD_DEG", "TRACKING_WINDOW_TICKS", "TRACKING_AHEAD_TICKS", "ArmsExecutor", "TrackingFault", "TrackingMonitor",
           "nearest_grid_state", "run_arms"]

TRACKING_THRESHOLD_DEG = 30
"""A motor this many degrees from every setpoint near the current tick is not following. With
the payload scene's gears that is a third of a grid cell of carriage travel (81.8 motor degrees
per cell) or 6 degrees of arm angle (5 motor degrees per arm degree). An arm that follows stays
within a few degrees (the emulator: 2-3, ``cplus execute``'s report)."""

TRACKING_WINDOW_TICKS = 2
"""How many ticks before the last one the brick logged the motors may still be."""

TRACKING_AHEAD_TICKS = 10
"""How many ticks after it they may already be: the report of the logged tick and the reading of
the angles come one after another over the link (a second of trajectory at most)."""

_CANDIDATES = 6          # nearest grid points tried per robot


class TrackingFault(Exception):
    """A motor left its setpoints: which robot and port, at which tick, how far."""

    def __init__(self, robot: str, port: str, tick: int, error_deg: int) -> None:
        super().__init__(f"robot {robot} motor {port}: {error_deg} degrees from its setpoints at tick {tick} "
                         f"(threshold {TRACKING_THRESHOLD_DEG})")
        self.robot, self.port, self.tick, self.error_deg = robot, port, tick, error_deg


class TrackingMonitor:
    """The ``on_progress`` hook of :func:`nxt_link.execute_streams` that raises
    :class:`TrackingFault`; raising there makes the streaming stop every brick."""

    def __init__(self, streams: Sequence[nxt_link.SetpointStream], bricks: Mapping[str, nxt_link.Brick],
                 threshold_deg: float = TRACKING_THRESHOLD_DEG, window: int = TRACKING_WINDOW_TICKS,
                 ahead: int = TRACKING_AHEAD_TICKS) -> None:
        self.streams = {s.brick: s for s in streams}
        self.bricks = bricks
        self.threshold = threshold_deg
        self.window = window
        self.ahead = ahead
        self.worst: dict[str, int] = {s.brick: 0 for s in streams}
        self.checks = 0

    def __call__(self, p: nxt_link.Progress) -> None:
        if p.phase != "run" or p.brick not in self.streams:
            return
        s = self.streams[p.brick]
        logged = min(p.done, len(s.rows) - 1)
        lo, hi = max(0, logged - self.window), min(len(s.rows), logged + self.ahead + 1)
        angles = read_angles(self.bricks[p.brick], s.ports)
        self.checks += 1
        # the brick drives all its motors on one clock: align on the tick that fits them best
        best_err, best_tick, best_port = None, logged, s.ports[0]
        for k in range(lo, hi):
            errs = [abs(a - r) for a, r in zip(angles, s.rows[k])]
            worst = max(errs)
            if best_err is None or worst < best_err:
                best_err, best_tick, best_port = worst, k, s.ports[errs.index(worst)]
        assert best_err is not None
        self.worst[p.brick] = max(self.worst[p.brick], best_err)
        if best_err > self.threshold:
            raise TrackingFault(p.brick, best_port, best_tick, best_err)


STILL_DEG = 1
"""Two readings of a motor this close, :data:`SETTLE_INTERVAL_S` apart, and it stands still."""
SETTLE_INTERVAL_S = 0.05
SETTLE_LIMIT_S = 2.0
"""How long the arms may take to stand still after the brake (they stop within a tenth of a
second; a motor that is still pushed, by a hand or a falling arm, is read as it is then)."""


def stop_and_measure(bricks: Mapping[str, nxt_link.Brick], ports: Mapping[str, Sequence[str]],
                     clock: Clock) -> dict[str, tuple[int, ...]]:
    """Brake every motor of ``ports`` (brick name -> its ports) at power 0 and return the
    angles once two readings :data:`SETTLE_INTERVAL_S` apart agree (the arms stand still), or
    after :data:`SETTLE_LIMIT_S`: what the state is re-estimated from must be where the arms
    stopped, not where they were passing when the fault was seen."""
    from nxt_link.wire.telegram import OutputMode, RegulationMode, RunState
    for name, brick_ports in ports.items():
        for port in brick_ports:
            bricks[name].set_output_state("ABC".index(port), 0, OutputMode.MOTORON | OutputMode.BRAKE,
                                          RegulationMode.IDLE, 0, RunState.RUNNING, 0)
    angles = {name: read_angles(bricks[name], p) for name, p in ports.items()}
    waited = 0.0
    while waited < SETTLE_LIMIT_S:
        clock.sleep(SETTLE_INTERVAL_S)
        waited += SETTLE_INTERVAL_S
        again = {name: read_angles(bricks[name], p) for name, p in ports.items()}
        still = all(abs(a - b) <= STILL_DEG for name in ports for a, b in zip(angles[name], again[name]))
        angles = again
        if still:
            break
    return angles


def read_angles(brick: nxt_link.Brick, ports: Sequence[str]) -> tuple[int, ...]:
    """Each motor's angle (its rotation count, as the brick program logs it)."""
    return tuple(int(brick.get_output_state("ABC".index(port)).rotation_count) for port in ports)


def nearest_grid_state(task: RobotTask, model: OnlineModel, before: State, after: State,
                       positions: Mapping[str, tuple[float, float]]) -> tuple[State, dict[str, tuple[int, int]]] | None:
    """The state nearest to where the arms are, between the plan's states ``before`` and
    ``after`` of the interrupted step.

    Each robot's end-effector goes to one of its nearest reachable grid points. A payload
    end held at ``before`` moves with its robot; an end not held stays. Every other fluent
    takes its value from ``after``: the step's other effects (its cost) count. Fluents the
    static laws determine (``on/2``) follow. Candidates are tried by the total distance from
    the measured positions; the first one the domain allows is the answer (None: none of the
    nearest ones is a state).
    """
    scene = task.scene
    grid = scene.grid  # type: ignore[attr-defined]
    sd = {gc for gc in model.state_gcs if gc.decl.kind == "sdFluent"}
    per_robot: list[list[tuple[float, tuple[int, int]]]] = []
    names = list(task.robots)
    for name in names:
        x, y = positions[name]
        near = []
        for gx in range(max(grid.x_min, math.floor(x) - 2), min(grid.x_max, math.ceil(x) + 2) + 1):
            for gy in range(max(grid.y_min, math.floor(y) - 2), min(grid.y_max, math.ceil(y) + 2) + 1):
                if scene.reachable(name, gx, gy):  # type: ignore[attr-defined]
                    near.append((math.hypot(gx - x, gy - y), (gx, gy)))
        per_robot.append(sorted(near)[:_CANDIDATES])
    held = {end: next((r for r in names if before[task.holds[(r, end)]] == "true"), None) for end in task.ends}
    combos = sorted(product(*per_robot), key=lambda c: sum(d for d, _ in c))
    for combo in combos:
        points = {name: p for name, (_, p) in zip(names, combo)}
        values: dict[GroundConst, object] = {gc: v for gc, v in after.items() if gc not in sd}
        for name, (gx, gy) in points.items():
            xg, yg = task.robots[name]
            values[xg], values[yg] = gx, gy
        for end, (xg, yg) in task.ends.items():
            holder = held[end]
            if holder is not None:
                values[xg], values[yg] = points[holder]
            else:
                values[xg], values[yg] = before[xg], before[yg]
        est = model.complete(values)
        if est.states:
            return est.states[0], points
    return None


@dataclass
class ArmsExecutor:
    """The arms' bricks, opened once for the whole run (real ones, or emulated on ptys, with
    stalls), so that every motor keeps its angle from one trajectory to the next.

    Emulated bricks run on simulated time (``time_scale`` None, the default; ``clock`` is
    then theirs, and the thread that opens the executor takes part in it until it closes it)
    or on the wall clock, ``time_scale`` times faster than real time."""

    robots: Sequence[str]
    ports: Mapping[str, str] | None = None
    stalls: Mapping[str, Sequence[Stall]] = field(default_factory=dict)
    time_scale: float | None = None
    latency: bool = True
    transports: Mapping[str, object] | None = None
    policy: nxt_link.RetryPolicy | None = None
    seed: int = 0
    compiled: bool = True
    bricks: dict[str, nxt_link.Brick] = field(default_factory=dict)
    description: str = ""
    clock: Clock = MONOTONIC
    emulated: EmulatedBricks | None = None
    _stack: ExitStack = field(default_factory=ExitStack)

    def __post_init__(self) -> None:
        if not self.transports and not self.ports:
            self.emulated = EmulatedBricks(self.time_scale, seed=self.seed, compiled=self.compiled)
            self.clock = self.emulated.clock
        elif self.ports:   # ports of bricks emulated in this process on simulated time: their clock
            self.clock = clock_of_device(next(iter(self.ports.values()))) or MONOTONIC
        if self.transports:
            self.description = "NXT bricks " + ", ".join(self.robots)
        elif self.ports:
            self.description = "NXT bricks " + ", ".join(f"{r}={self.ports[r]}" for r in self.robots)
        else:
            stalls = "; ".join(f"{r} stalls {', '.join(map(str, s))}" for r, s in self.stalls.items() if s)
            self.description = "emulated NXT bricks " + ", ".join(self.robots) + (f" ({stalls})" if stalls else "")

    def open(self) -> None:
        from nxt_link.wire.serial_transport import SerialTransport
        if self.emulated is not None:
            self._stack.enter_context(self.emulated)   # the calling thread takes part in its clock
        elif isinstance(self.clock, SimClock) and self.ports:
            self._stack.enter_context(self.clock.participant("pc"))
        for name in self.robots:
            if self.transports:
                transport = self.transports[name]
            elif self.ports:
                transport = SerialTransport(self.ports[name], clock=self.clock)
                self._stack.callback(transport.close)
            else:
                assert self.emulated is not None
                transport = self.emulated.add(nxt_link.EmulatorConfig(
                    name=name, link=nxt_link.LinkParams() if self.latency else nxt_link.LinkParams.instant(),
                    stalls=tuple(self.stalls.get(name, ()))))
            self.bricks[name] = nxt_link.Brick(transport, name=name, policy=self.policy)  # type: ignore[arg-type]

    def session_ids(self) -> dict[str, int] | None:
        """Fresh session ids for one trajectory: from the seed on simulated time (None: random)."""
        return self.emulated.session_ids(self.robots) if self.emulated is not None else None

    def options(self, options: nxt_link.ExecutionOptions | None) -> nxt_link.ExecutionOptions | None:
        """``options`` with the emulated bricks' time scale (1 on simulated time)."""
        if self.emulated is None and not isinstance(self.clock, SimClock):
            return options
        from dataclasses import replace
        return replace(options or nxt_link.ExecutionOptions(), time_scale=self.time_scale or 1.0)

    def abort(self) -> None:
        """Stop every brick for good: its program stops, every motor coasts (best effort:
        a brick that does not answer is skipped)."""
        for brick in self.bricks.values():
            try:
                try:
                    brick.stop_program()
                except NoActiveProgramError:
                    pass
                for port in range(3):
                    brick.set_output_state(port, 0, 0, 0, 0, 0, 0)
            except LinkError:
                continue

    def close(self) -> None:
        self._stack.close()


class _Run:
    """What observers see as the run (``model`` and ``executor``, as an OnlineLoop has)."""

    def __init__(self, model: OnlineModel, executor: ArmsExecutor) -> None:
        self.model = model
        self.executor = executor


def run_arms(task: RobotTask, label: str, executor: ArmsExecutor, *, observers: Iterable[Observer] = (),
             threshold_deg: float = TRACKING_THRESHOLD_DEG, max_faults: int = 3, max_iterations: int = 100,
             max_horizon: int | None = None, points_per_step: int = 10, step_time: float = 1.0,
             options: nxt_link.ExecutionOptions | None = None, clock: Clock | None = None) -> RunResult:
    """Plan, execute while monitoring the tracking error, and re-plan from the nearest grid
    state after a fault, until the goal holds (or no plan, too many faults, a lost brick).

    Times are measured on ``clock`` (default: the executor's, simulated time for emulated
    bricks).

    Returns a :class:`RunResult` whose records are the segments; its status is
    ``goal_reached``, ``no_plan`` (stopped safely: no collision-free plan from where the arms
    are), ``contradicted`` (more than ``max_faults`` faults, no grid state near the arms, or
    the bricks could not reach a new plan's start) or ``robot_lost``.
    """
    import trajectory
    observers = list(observers)
    clock = clock or executor.clock
    options = executor.options(options)
    model = OnlineModel(task.domain, label, Roles.of(task.domain), max_horizon=max_horizon)
    records: list[CycleRecord] = []
    t_start = clock.now()
    run = _Run(model, executor)

    def now() -> float:
        return clock.now() - t_start

    def end(status: OnlineStatus, message: str, state: State | None) -> RunResult:
        if status is not OnlineStatus.GOAL_REACHED:
            executor.abort()
        result = RunResult(status, message, records, state, seconds=now())
        for obs in observers:
            obs.on_end(result)
        return result

    def record(r: CycleRecord) -> None:
        records.append(r)
        for obs in observers:
            obs.on_cycle(r)

    for obs in observers:
        obs.on_start(run)  # type: ignore[arg-type]
    est = model.initial_state()
    if not est.unique:
        opened = ", ".join(gc.text for gc in est.open) or "; ".join(est.unexplained)
        return end(OnlineStatus.AMBIGUOUS, f"the goal's start is not one state ({opened})", None)
    state: State = est.state  # type: ignore[assignment]
    try:
        executor.open()
    except (LinkError, OSError) as exc:
        executor.close()
        return end(OnlineStatus.ROBOT_LOST, str(exc), state)
    learned: list = []
    reason: Replan | None = Replan("start")
    cycle, faults = 0, 0
    carry = 0.0                                   # reading and mapping the angles, before a re-plan
    sensed: dict[GroundConst, object] = {}
    raw: dict[str, object] = {}
    origin: trajectory.Trajectory | None = None  # where the encoders count from: the first start
    try:
        while True:
            t0 = time.perf_counter()
            session = model.session(state)
            refined = refine(task, label, max_iterations, session=session, known=learned)
            rec = CycleRecord(cycle, now(), state, replanned=reason, sensed=sensed, raw=raw, decision_s=carry)
            if refined.status is not RefineStatus.FOUND or refined.history is None:
                rec.decision_s += time.perf_counter() - t0
                record(rec)
                return end(OnlineStatus.NO_PLAN, f"stopped safely at cycle {cycle}: {refined.reason or 'no plan'}",
                           state)
            learned = refined.nogoods
            plan = model.plan_of(refined.history)
            rec.plan = plan
            rec.decision_s += time.perf_counter() - t0
            if plan.length == 0:
                record(rec)
                return end(OnlineStatus.GOAL_REACHED, f"goal '{label}' reached at cycle {cycle}", state)
            try:
                # a re-plan keeps each arm on the IK branch it is on (the joints go on from where
                # they are; the other branch is another configuration of the arm)
                scene = task.scene if origin is None else _on_branches(task.scene, origin)
                traj = trajectory.build_trajectory(scene, refined.states,  # type: ignore[arg-type]
                                                   points_per_step=points_per_step, step_time_s=step_time,
                                                   source={"domain": task.domain.path})  # type: ignore[attr-defined]
            except trajectory.TrajectoryError as exc:
                raise TaskError.from_trajectory(exc) from None
            origin = origin or traj
            streams = streams_from_trajectory(traj, origin=origin)
            monitor = TrackingMonitor(streams, executor.bricks, threshold_deg)
            rec.executed = [a for step in plan.steps for a in step]
            for obs in observers:
                obs.on_act(rec)
            t_act = clock.now()
            fault: TrackingFault | None = None
            try:
                nxt_link.execute_streams(streams, executor.bricks, options=_homing_allowed(options, task.scene)
                                         if cycle else options, on_progress=monitor,
                                         session_ids=executor.session_ids())
            except TrackingFault as exc:
                fault = exc
            except (StreamError, SetpointError) as exc:
                if isinstance(exc, SetpointError):
                    rec.executed = []             # refused before anything moved: nothing ran
                rec.failure = str(exc)
                rec.act_s = clock.now() - t_act
                record(rec)
                return end(OnlineStatus.CONTRADICTED, f"the arms could not run the plan of cycle {cycle}: {exc}", state)
            except LinkError as exc:
                rec.failure = str(exc)
                rec.act_s = clock.now() - t_act
                record(rec)
                return end(OnlineStatus.ROBOT_LOST, str(exc), state)
            t1 = time.perf_counter()
            if fault is not None:
                angles = stop_and_measure(executor.bricks, {r.name: r.ports for r in traj.robots}, clock)
            else:
                angles = {r.name: read_angles(executor.bricks[r.name], r.ports) for r in traj.robots}
            rec.act_s = clock.now() - t_act
            rec.raw = {f"{name}.{port}": a for r in traj.robots for name in [r.name]
                       for port, a in zip(r.ports, angles[name])}
            positions = {r.name: tuple(float(v) for v in origin.robot(r.name).xy_from_motor_deg(angles[r.name]))
                         for r in traj.robots}
            step = plan.length - 1 if fault is None else min(fault.tick // points_per_step, plan.length - 1)
            done = plan.length if fault is None else step + 1
            rec.executed = [a for s in plan.steps[:done] for a in s]
            if fault is not None:
                rec.failure = str(fault)
            record(rec)
            mapped = nearest_grid_state(task, model, plan.states[step], plan.states[step + 1],
                                        positions)  # type: ignore[arg-type]
            if mapped is None:
                where = ", ".join(f"{n} at ({x:.2f}, {y:.2f})" for n, (x, y) in positions.items())
                return end(OnlineStatus.CONTRADICTED, f"no state of the domain near where the arms are ({where})", state)
            new, _points = mapped
            expected = plan.states[step + 1]
            cycle += done
            if fault is None and new == expected:
                final = CycleRecord(cycle, now(), new, sensed=_positions(task, new), raw=dict(rec.raw))
                final.decision_s = time.perf_counter() - t1
                final.plan = Plan([], [new], refined.history, 0.0)
                record(final)
                return end(OnlineStatus.GOAL_REACHED, f"goal '{label}' reached at cycle {cycle}", new)
            faults += fault is not None
            if faults > max_faults:
                return end(OnlineStatus.CONTRADICTED, f"the arms failed to follow {faults} times; last: {fault}", new)
            reason = Replan("fault" if fault is not None else "diverged", expected.diff(new))
            state, sensed, raw = new, _positions(task, new), dict(rec.raw)
            carry = time.perf_counter() - t1
    except (LinkError, OSError) as exc:
        return end(OnlineStatus.ROBOT_LOST, str(exc), state)
    except KeyboardInterrupt as exc:       # its text says which signal, when one was raised as it
        end(OnlineStatus.STOPPED, str(exc) or "interrupted", state)
        raise
    finally:
        executor.close()


def _positions(task: RobotTask, state: State) -> dict[GroundConst, object]:
    return {gc: state[gc] for pair in task.robots.values() for gc in pair}


def _on_branches(scene, origin):
    """``scene`` with each robot's preferred IK branch the one it follows in ``origin``."""
    from dataclasses import replace
    return replace(scene, robots=tuple(replace(r, branch=origin.robot(r.name).branch.branch)
                                       for r in scene.robots))


def _homing_allowed(options: nxt_link.ExecutionOptions | None, scene) -> nxt_link.ExecutionOptions:
    """A re-plan starts at the grid state nearest to where the arms stopped: the brick's homing
    makes that short move on purpose, so the start check of :func:`nxt_link.execute_streams`
    allows up to one cell of each joint (the hand moves less than a cell diagonal; the joints,
    through the inverse kinematics, about as much) through its gear ratio, and no more: a start
    on another IK branch, a whole configuration away, is still refused."""
    from dataclasses import replace
    opts = options or nxt_link.ExecutionOptions()
    cell = max(abs(m.deg_per_unit) * (1.0 if m.joint == "s" else math.degrees(1.0 / r.arm.length))
               for r in scene.robots for m in r.motors)
    return replace(opts, max_start_offset_deg=(opts.max_start_offset_deg or 0) + math.ceil(cell))
