"""The online loop (Legolog's act, sense, decide again) over a C+ domain, and what it runs on.

* the loop and its interfaces — :class:`OnlineLoop`, :class:`Executor`, :class:`EventSource`,
  :class:`Observer`, the ``cplus.online/1`` log (:mod:`.loop`);
* the planning side — :class:`OnlineModel`: plans, estimates and roles (:mod:`.estimation`);
* executors — simulated (:mod:`.executors`), NXT bricks through the behaviour protocol
  (:mod:`.nxt_executor`, bound by a ``robot.toml``: :mod:`.binding`), the payload arms under
  monitoring (:mod:`.payload_monitor`);
* events from outside — a script or standard input (:mod:`.events`);
* the emulated world of a run — ``world.toml`` (:mod:`.world_file`). It reads
  ``cplus.world/1``, which :mod:`nxt_link.emulator.world` runs, but stays here: its errors are the
  language's located errors (:mod:`cplus.errors`) and its key paths come from
  :mod:`trajectory.toml_locations`, neither of which ``nxt_link`` may import.

Serving (:mod:`cplus.robot.serving`) builds on this package; this package never uses serving.
"""
from __future__ import annotations

from cplus.robot.online.binding import BindingError, RobotBinding, binding_beside, load_binding, parse_binding
from cplus.robot.online.estimation import (
    Act,
    Estimate,
    EstimateStatus,
    OnlineModel,
    Plan,
    Roles,
    State,
    json_value,
    user_actions,
)
from cplus.robot.online.events import EventsError, LineEvents, ScriptedEvents, check_events, parse_events
from cplus.robot.online.executors import SimulatedExecutor
from cplus.robot.online.loop import (
    ONLINE_FORMAT,
    CycleRecord,
    EventSource,
    Executor,
    JsonLinesLog,
    Observer,
    OnlineLoop,
    OnlineStatus,
    Outcome,
    Replan,
    RobotLost,
    RunResult,
    Step,
)
from cplus.robot.online.nxt_executor import NxtExecutor
from cplus.robot.online.payload_monitor import ArmsExecutor, run_arms
from cplus.robot.online.world_file import WorldFileError, load_world, parse_world

__all__ = ["ONLINE_FORMAT", "Act", "ArmsExecutor", "BindingError", "CycleRecord", "Estimate", "EstimateStatus", "EventSource",
           "EventsError", "Executor", "JsonLinesLog", "LineEvents", "NxtExecutor", "Observer", "OnlineLoop",
           "OnlineModel", "OnlineStatus", "Outcome", "Plan", "Replan", "RobotBinding", "RobotLost", "Roles",
           "RunResult", "ScriptedEvents", "SimulatedExecutor", "State", "Step", "WorldFileError", "binding_beside",
           "check_events", "json_value", "load_binding", "load_world", "parse_binding", "parse_events",
           "parse_world", "run_arms", "user_actions"]
