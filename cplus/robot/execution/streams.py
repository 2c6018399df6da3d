"""Run a ``cplus.trajectory/1`` on NXT bricks.

The glue between :mod:`trajectory` (what to do, and kinematics to judge what was done) and
:mod:`nxt_link` (doing it):

1. ``load_trajectory`` validates the file (fields, and that its parts agree: times, steps,
   kinematics, setpoints); :func:`motor_limits` recomputes every motor's limits from the
   scene's joint limits and gear ratios (refusing a file whose kinematics or motors differ from
   the scene's), and :func:`streams_from_trajectory` turns each robot's ``setpoints_deg`` into an
   ``nxt_link.SetpointStream`` with those limits; anything unreachable or out of limits is
   refused before a brick is touched;
2. ``--brick NAME=PORT`` opens real devices (``/dev/rfcomm0``) or emulator ptys; without any
   ``--brick`` one emulated brick per robot is started in-process on a pty, and the run goes
   through the same serial path;
3. ``nxt_link.execute_streams`` checks that every motor stands at its first setpoint, uploads,
   starts all bricks together and reads the logs back (or, when a brick fails, stops the others
   and returns what was gathered in ``ExecutionFailed.log``);
4. :func:`~cplus.robot.execution.tracking.tracking_report` (in :mod:`.tracking`) reconstructs the executed end-effector and payload paths by forward
   kinematics (``RobotTrajectory.xy_from_motor_deg``) and measures the tracking error per
   robot (max and RMS, motor degrees and grid units); the payload is compared on a common
   clock, each robot's log shifted by when its brick actually started (measured from the log);
   ``--plot`` draws executed against planned (the paper's Fig. 5).

The command ``cplus execute`` is :mod:`cplus.cli.execute`.
"""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass, replace

import numpy as np

import nxt_link
import trajectory
from nxt_link.wire.clock import MONOTONIC, clock_of_device
from nxt_link.wire.errors import SetpointError

__all__ = ["EmulatorSettings", "check_ports", "execute_trajectory", "motor_limits", "streams_from_trajectory"]

#: Kinematics of the file and of the scene agree within this (grid units, degrees).
_KINEMATICS_TOL = 1e-6


def motor_limits(traj: trajectory.Trajectory, scene: trajectory.Scene | None = None
                 ) -> dict[str, tuple[tuple[int, int], ...]]:
    """Each robot's motor limits (degrees, in ``ports`` order), recomputed, not read.

    From the scene's joint limits and gear ratios when a scene is given (the file's kinematics
    and motors must then be the scene's), else from the file's own kinematics; the encoders
    count from the first sample's joint values. A file may narrow a motor's limits, never
    widen them.

    Raises:
        SetpointError: a robot of the file is not in the scene, or its kinematics or motors
            differ from the scene's.
    """
    out = {}
    for robot in traj.robots:
        arm = robot.arm
        ratios = {m.port: (m.joint, m.deg_per_unit, m.offset_deg) for m in robot.motors}
        if scene is not None:
            try:
                sr = scene.robot(robot.name)
            except KeyError:
                raise SetpointError(f"robot {robot.name!r} of the trajectory is not in the scene "
                                    f"{scene.file}") from None
            _same_kinematics(robot, sr.arm, scene.file)
            wanted = {m.port: (m.joint, m.deg_per_unit, m.offset_deg) for m in sr.motors}
            if wanted != ratios:
                raise SetpointError(
                    f"robot {robot.name}: the trajectory's motors {_motors_text(ratios)} are not "
                    f"the scene's {_motors_text(wanted)} ({scene.file})")
            arm = sr.arm
        limits = []
        for motor in robot.motors:
            if motor.joint == "s":
                lo, hi, zero = arm.s_limits[0], arm.s_limits[1], float(robot.s[0])
            else:
                lo, hi = (math.degrees(t) for t in arm.theta_limits_rad)
                zero = float(robot.theta_deg[0])
            ends = sorted(motor.offset_deg + motor.deg_per_unit * (v - zero) for v in (lo, hi))
            limits.append((max(motor.min_deg, math.ceil(ends[0] - 1e-9)),
                           min(motor.max_deg, math.floor(ends[1] + 1e-9))))
        out[robot.name] = tuple(limits)
    return out


def _same_kinematics(robot: trajectory.RobotTrajectory, arm: trajectory.Arm, where: str) -> None:
    mine = robot.arm
    pairs = (("rail_origin", mine.rail_origin, arm.rail_origin),
             ("rail_dir", mine.rail_dir, arm.rail_dir),
             ("arm_length", (mine.length,), (arm.length,)),
             ("s_limits", mine.s_limits, arm.s_limits),
             ("theta_limits_deg", tuple(math.degrees(t) for t in mine.theta_limits_rad),
              tuple(math.degrees(t) for t in arm.theta_limits_rad)))
    for name, a, b in pairs:
        if any(abs(x - y) > _KINEMATICS_TOL * max(1.0, abs(y)) for x, y in zip(a, b)):
            raise SetpointError(f"robot {robot.name}: the trajectory's {name} {_vec(a)} is not the "
                                f"scene's {_vec(b)} ({where})")


def _vec(values: tuple[float, ...]) -> str:
    return f"{values[0]:g}" if len(values) == 1 else "[" + ", ".join(f"{v:g}" for v in values) + "]"


def _motors_text(motors: Mapping[str, tuple[str, float, float]]) -> str:
    return ", ".join(f"{p}:{j}x{r:g}" + (f"{o:+g}" if o else "") for p, (j, r, o) in sorted(motors.items()))


def streams_from_trajectory(traj: trajectory.Trajectory, scene: trajectory.Scene | None = None,
                            *, origin: trajectory.Trajectory | None = None
                            ) -> list[nxt_link.SetpointStream]:
    """One setpoint stream per robot: its ports, the tick, its integer motor degrees.

    The motor limits are :func:`motor_limits` (from the scene when given); the brick program
    enforces them as well.

    A trajectory's setpoints count from its own first sample, where the encoders are zero when
    the brick program starts there. A trajectory that continues from elsewhere (a re-plan from
    where the arms stopped) runs on encoders that count from an earlier start: ``origin`` is
    the trajectory at whose first sample they read zero, and the setpoints and limits are
    recomputed from the samples in that frame (its robots must have the same motors).

    Raises:
        SetpointError: a robot's setpoints cannot be streamed (ports, limits, size), the file
            disagrees with the scene, or ``origin`` has other motors.
    """
    frame = origin or traj
    limits = motor_limits(frame, scene)
    streams = []
    for robot in traj.robots:
        rows_deg = np.asarray(robot.setpoints_deg)
        if origin is not None:
            try:
                base = origin.robot(robot.name)
            except KeyError:
                raise SetpointError(f"robot {robot.name!r} is not in the origin trajectory") from None
            if [(m.port, m.joint, m.deg_per_unit, m.offset_deg) for m in base.motors] != \
                    [(m.port, m.joint, m.deg_per_unit, m.offset_deg) for m in robot.motors]:
                raise SetpointError(f"robot {robot.name}: the origin trajectory has other motors")
            rows_deg = np.column_stack([
                np.rint(m.motor_deg(robot.s if m.joint == "s" else robot.theta_deg))
                for m in base.motors])
        rows = tuple(tuple(int(v) for v in row) for row in rows_deg)
        streams.append(nxt_link.SetpointStream(robot.name, robot.ports, int(traj.tick_ms), rows,
                                               limits[robot.name]))
    return streams


def check_ports(traj: trajectory.Trajectory, ports: Mapping[str, str]) -> None:
    """``ports`` (robot -> device) names every robot of ``traj`` once, each on its own device.

    Raises:
        SetpointError: an unknown robot, a robot without a port, or one port for two robots.
    """
    robots = [r.name for r in traj.robots]
    unknown = sorted(set(ports) - set(robots))
    if unknown:
        raise SetpointError(f"--brick {unknown[0]}: the trajectory has no robot "
                            f"{unknown[0]!r} (robots: {', '.join(robots)})")
    missing = [r for r in robots if r not in ports]
    if missing:
        raise SetpointError(f"no --brick for robot {missing[0]!r}: give one per robot, or "
                            "none to use emulated bricks")
    seen: dict[str, str] = {}
    for name, port in ports.items():
        key = _device_key(port)
        if key in seen:
            raise SetpointError(f"--brick {seen[key]} and --brick {name} are both {port}: each "
                                "robot needs its own brick")
        seen[key] = name


def _device_key(port: str) -> str:
    return os.path.realpath(port)


@dataclass(frozen=True, slots=True)
class EmulatorSettings:
    """How to emulate the bricks when no port is given.

    Attributes:
        latency: the Bluetooth timing model (False: instant answers).
        time_scale: None (default): the bricks and the link's timeouts run on simulated
            time (:class:`nxt_link.SimClock`), so the run depends neither on the machine's
            load nor on its speed, and the same seed gives the same log byte for byte; a
            number: the wall clock, that many times faster than real time (1: real time).
        seed: the random seed of the link model, the faults and the session ids (each
            brick its own, from this one).
        faults: faults every emulated brick injects (each with its own seed).
        compiled: run the compiled brick program on the bytecode interpreter (when nbc is
            installed) instead of its Python model.
    """

    latency: bool = True
    time_scale: float | None = None
    seed: int = 0
    faults: nxt_link.FaultParams | None = None
    compiled: bool = True


def execute_trajectory(traj: trajectory.Trajectory, ports: Mapping[str, str] | None = None, *,
                       options: nxt_link.ExecutionOptions | None = None,
                       emulator: EmulatorSettings | None = None,
                       on_progress: Callable[[nxt_link.Progress], None] | None = None,
                       on_bricks: Callable[[Mapping[str, str]], None] | None = None,
                       scene: trajectory.Scene | None = None,
                       on_connected: Callable[[Mapping[str, nxt_link.Brick]], None] | None = None,
                       on_snapshot: Callable[[Callable[[str], nxt_link.ExecutionLog]], None] | None = None,
                       ) -> nxt_link.ExecutionLog:
    """Execute ``traj`` on bricks at ``ports`` (robot name -> device), or on emulated bricks.

    With emulated bricks the options' ``time_scale`` is the emulator's (1 on simulated
    time, where the bricks' clock is the PC's). ``on_connected`` receives the bricks once
    they are opened, before anything moves; ``on_snapshot`` the function that gives the log
    gathered so far (:func:`nxt_link.execute_streams`), for a shutdown watchdog.

    Raises:
        SetpointError: the trajectory cannot be executed (nothing moved).
        ExecutionFailed: a brick failed; ``.log`` holds what was gathered.
        LinkError: a port cannot be opened.
        SimulationStalled: the emulation's simulated clock could not move (a bug).
    """
    streams = streams_from_trajectory(traj, scene)
    robots = [r.name for r in traj.robots]
    if ports:
        check_ports(traj, ports)
    emu = emulator or EmulatorSettings()
    opts = options or nxt_link.ExecutionOptions()
    with ExitStack() as stack:
        bricks = {}
        session_ids = None
        if not ports:
            from nxt_link.emulator.inprocess import EmulatedBricks
            emulated = stack.enter_context(EmulatedBricks(emu.time_scale, seed=emu.seed, compiled=emu.compiled))
            opts = replace(opts, time_scale=emu.time_scale or 1.0)
            for name in robots:
                transport = emulated.add(nxt_link.EmulatorConfig(
                    name=name, link=nxt_link.LinkParams() if emu.latency else nxt_link.LinkParams.instant(),
                    faults=emu.faults or nxt_link.FaultParams()))
                bricks[name] = nxt_link.Brick(transport, name=name)
            session_ids = emulated.session_ids(robots)
            shown = {name: s.path for name, s in emulated.servers.items()}
        else:
            shown = dict(ports)
        if on_bricks is not None:
            on_bricks(shown)
        if ports:
            # a port served by a brick emulated in this process on simulated time (tests) is
            # used on that brick's clock
            clock = clock_of_device(next(iter(ports.values())))
            if clock is not None:
                stack.enter_context(clock.participant("pc"))
                opts = replace(opts, time_scale=1.0)
            for name in robots:
                transport = nxt_link.SerialTransport(ports[name], clock=clock or MONOTONIC)  # type: ignore[operator]
                stack.callback(transport.close)
                bricks[name] = nxt_link.Brick(transport, name=name)
        if on_connected is not None:      # e.g. a shutdown watchdog that must reach the bricks
            on_connected(bricks)
        return nxt_link.execute_streams(streams, bricks, options=opts, on_progress=on_progress,
                                        session_ids=session_ids, on_snapshot=on_snapshot)
