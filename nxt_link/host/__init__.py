"""The host side: the PC driving bricks over the wire.

:class:`Brick` (direct commands with retries over a transport), the setpoint streaming session
and :func:`execute_streams` (many bricks, a common start, the log read back into an
:class:`ExecutionLog`), and :class:`BehaviourClient` (Legolog's behaviours). It imports the wire
and the programs' protocols, never the emulator.
"""
from nxt_link.host.behaviours import (
    ActResult,
    Behaviour,
    BehaviourClient,
    BehaviourError,
    BehaviourFailed,
    BehaviourRefused,
    BehaviourTiming,
    BrickEvent,
    BrickLostError,
    BrickPanicError,
)
from nxt_link.host.brick import Brick, RetryPolicy
from nxt_link.host.execlog import BrickLog, ExecutionLog
from nxt_link.host.execution import ExecutionOptions, Progress, SetpointStream, execute_streams
from nxt_link.host.session import ControllerSettings, SessionTiming

__all__ = ["ActResult", "Behaviour", "BehaviourClient", "BehaviourError", "BehaviourFailed",
           "BehaviourRefused", "BehaviourTiming", "BrickEvent", "BrickLostError", "BrickPanicError",
           "Brick", "RetryPolicy", "BrickLog", "ExecutionLog", "ExecutionOptions", "Progress",
           "SetpointStream", "execute_streams", "ControllerSettings", "SessionTiming"]
