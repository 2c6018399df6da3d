"""Serving goals while the robot runs (ROSoClingo's reactive goals): requests and cancellations
from clients become events of the domain, and one standing planner keeps the robot's plan for
the goals that are open.

* :class:`Server` — the online loop with a goal board, a standing model and channels
  (:mod:`.reactive`);
* :class:`GoalBoard` — each goal's life, from pending to a final status (:mod:`.goals`);
* :class:`StandingModel` — one solver for the run, goals as assumptions (:mod:`.standing`);
* the requests a domain accepts — ``requests.toml`` (:mod:`.vocabulary`);
* the log — ``cplus.online/1`` with goal records, durable and continued (:mod:`.serve_log`);
* channels — a script (:mod:`.script`), a JSON-lines socket (:mod:`.socket_channel`), ROS actionlib
  (:mod:`.ros_bridge`, imported only when asked for: ROS is optional).

This package builds on :mod:`cplus.robot.online`, never the other way round.
"""
from __future__ import annotations

from cplus.robot.serving.goals import Goal, GoalBoard, GoalStatus, GoalWatcher
from cplus.robot.serving.reactive import Server, ServerSettings, serve_roles
from cplus.robot.serving.script import RequestScript, ScriptEntry, ScriptError, load_script, parse_script
from cplus.robot.serving.serve_log import SERVE_LOG, LogHistory, LogRefused, ServeLog, open_log
from cplus.robot.serving.socket_channel import SocketChannel, parse_listen
from cplus.robot.serving.standing import DEFAULT_BUDGET, GoalLiteral, StandingModel
from cplus.robot.serving.vocabulary import (
    Rejected,
    RequestsError,
    RequestVocabulary,
    load_requests,
    parse_requests,
    requests_beside,
)

__all__ = ["DEFAULT_BUDGET", "SERVE_LOG", "Goal", "GoalBoard", "GoalLiteral", "GoalStatus", "GoalWatcher",
           "LogHistory", "LogRefused", "Rejected",
           "RequestScript", "RequestVocabulary", "RequestsError", "ScriptEntry", "ScriptError", "ServeLog", "Server", "ServerSettings",
           "SocketChannel", "StandingModel", "load_requests", "load_script", "open_log", "parse_listen", "parse_requests",
           "parse_script", "requests_beside", "serve_roles"]
