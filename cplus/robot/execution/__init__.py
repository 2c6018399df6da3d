"""Executing a ``cplus.trajectory/1`` on NXT bricks, real or emulated, and judging how closely
they followed it.

* :func:`execute_trajectory` and what it is built from — the motors' limits, one setpoint
  stream per robot, the ports (:mod:`.streams`);
* :func:`tracking_report`, :func:`skew_verdict` — the executed paths rebuilt from the encoder
  logs, and the tracking error (:mod:`.tracking`).

It uses no other part of :mod:`cplus.robot`; the online loop streams the arms through it.
"""
from __future__ import annotations

from cplus.robot.execution.streams import (
    EmulatorSettings,
    check_ports,
    execute_trajectory,
    motor_limits,
    streams_from_trajectory,
)
from cplus.robot.execution.tracking import RobotTracking, TrackingReport, skew_verdict, tracking_report

__all__ = ["EmulatorSettings", "RobotTracking", "TrackingReport", "check_ports", "execute_trajectory",
           "motor_limits", "skew_verdict", "streams_from_trajectory", "tracking_report"]
