"""NXT telegrams, transports, the brick emulator and trajectory streaming.

Everything between the PC and the LEGO MINDSTORMS NXT bricks (stdlib +
pyserial only; no numpy, no geometry, no plans):

* :mod:`nxt_link.telegram`, :mod:`nxt_link.framing` — pure codecs of the
  direct commands and the Bluetooth length prefix;
* :class:`Brick` over a transport: :class:`SerialTransport` (``/dev/rfcommN``
  or an emulator pty) or :class:`MemoryTransport` (in-process, virtual clock);
* :mod:`nxt_link.stream_protocol` and :func:`execute_streams` — the setpoint
  streaming protocol over mailboxes (sequence numbers, acknowledgements,
  checksums, a common start time, resumable log read-back);
* ``nxt_link/nxc/cplus_follow.nxc`` — the brick program (the paper's
  Algorithm 2), and :class:`BrickEmulator` — firmware, a model of that program
  and motor physics, served on a pty by ``cplus brick``;
* :mod:`nxt_link.behaviour_protocol` and :class:`BehaviourClient` — Legolog's
  act / sense / exogenous-event protocol with the brick program
  ``nxt_link/nxc/cplus_legolog.nxc`` (a delivery robot), and :class:`WorldSpec` —
  the line track the emulated robot drives on and senses.

Typical use::

    from nxt_link import Brick, SerialTransport, SetpointStream, execute_streams
    bricks = {"r1": Brick(SerialTransport("/dev/rfcomm0"), name="r1")}
    log = execute_streams([SetpointStream("r1", ("A", "B"), 50, rows)], bricks)
    open("exec.json", "w").write(log.dumps())
"""
from nxt_link.behaviours import (
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
from nxt_link.brick import Brick, RetryPolicy
from nxt_link.clock import MonotonicClock, SimClock, SimulationStalled, VirtualClock
from nxt_link.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.errors import LinkError, LinkTimeoutError, ProtocolError
from nxt_link.execlog import BrickLog, ExecutionLog
from nxt_link.execution import ExecutionOptions, Progress, SetpointStream, execute_streams
from nxt_link.memory_transport import MemoryTransport
from nxt_link.pty_server import PtyBrickServer
from nxt_link.session import ControllerSettings, SessionTiming
from nxt_link.stall import Stall
from nxt_link.world import WorldSpec, delivery_world

__all__ = [
    "SetpointStream",
    "execute_streams",
    "ExecutionLog",
    "BrickLog",
    "ExecutionOptions",
    "ControllerSettings",
    "SessionTiming",
    "Progress",
    "Brick",
    "RetryPolicy",
    "SerialTransport",
    "MemoryTransport",
    "BrickEmulator",
    "EmulatorConfig",
    "LinkParams",
    "FaultParams",
    "PtyBrickServer",
    "VirtualClock",
    "MonotonicClock",
    "SimClock",
    "SimulationStalled",
    "EmulatedBricks",
    "LinkError",
    "LinkTimeoutError",
    "ProtocolError",
    "BehaviourClient",
    "BehaviourTiming",
    "Behaviour",
    "ActResult",
    "BrickEvent",
    "BehaviourError",
    "BehaviourFailed",
    "BehaviourRefused",
    "BrickLostError",
    "BrickPanicError",
    "WorldSpec",
    "delivery_world",
    "Stall",
]


def __getattr__(name: str) -> object:
    # pyserial is imported only when the serial transport is actually used
    if name == "SerialTransport":
        from nxt_link.serial_transport import SerialTransport

        return SerialTransport
    if name == "EmulatedBricks":
        from nxt_link.inprocess import EmulatedBricks

        return EmulatedBricks
    raise AttributeError(f"module 'nxt_link' has no attribute {name!r}")
