"""NXT telegrams, transports, the brick emulator and trajectory streaming.

Everything between the PC and the LEGO MINDSTORMS NXT bricks (stdlib +
pyserial only; no numpy, no geometry, no plans), one package per concern:
:mod:`nxt_link.wire` (telegrams, framing, transports, clocks), :mod:`nxt_link.host` (driving
bricks), :mod:`nxt_link.emulator` (the emulated brick and its bytecode VM) and
:mod:`nxt_link.programs` (the NXC brick programs and their mailbox protocols):

* :mod:`nxt_link.wire.telegram`, :mod:`nxt_link.wire.framing` — pure codecs of the
  direct commands and the Bluetooth length prefix;
* :class:`Brick` over a transport: :class:`SerialTransport` (``/dev/rfcommN``
  or an emulator pty) or :class:`MemoryTransport` (in-process, virtual clock);
* :mod:`nxt_link.programs.stream_protocol` and :func:`execute_streams` — the setpoint
  streaming protocol over mailboxes (sequence numbers, acknowledgements,
  checksums, a common start time, resumable log read-back);
* ``nxt_link/programs/nxc/cplus_follow.nxc`` — the brick program (the paper's
  Algorithm 2), and :class:`BrickEmulator` — firmware, a model of that program
  and motor physics, served on a pty by ``cplus brick``;
* :mod:`nxt_link.programs.behaviour_protocol` and :class:`BehaviourClient` — Legolog's
  act / sense / exogenous-event protocol with the brick program
  ``nxt_link/programs/nxc/cplus_legolog.nxc`` (a delivery robot), and :class:`WorldSpec` —
  the line track the emulated robot drives on and senses.

Typical use::

    from nxt_link import Brick, SerialTransport, SetpointStream, execute_streams
    bricks = {"r1": Brick(SerialTransport("/dev/rfcomm0"), name="r1")}
    log = execute_streams([SetpointStream("r1", ("A", "B"), 50, rows)], bricks)
    open("exec.json", "w").write(log.dumps())
"""
from nxt_link.emulator import (
    BrickEmulator,
    EmulatorConfig,
    FaultParams,
    LinkParams,
    MemoryTransport,
    PtyBrickServer,
    Stall,
    WorldSpec,
    delivery_world,
)
from nxt_link.host import (
    ActResult,
    Behaviour,
    BehaviourClient,
    BehaviourError,
    BehaviourFailed,
    BehaviourRefused,
    BehaviourTiming,
    Brick,
    BrickEvent,
    BrickLog,
    BrickLostError,
    BrickPanicError,
    ControllerSettings,
    ExecutionLog,
    ExecutionOptions,
    Progress,
    RetryPolicy,
    SessionTiming,
    SetpointStream,
    execute_streams,
)
from nxt_link.wire import (
    LinkError,
    LinkTimeoutError,
    MonotonicClock,
    ProtocolError,
    SimClock,
    SimulationStalled,
    VirtualClock,
)

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
        from nxt_link.wire.serial_transport import SerialTransport

        return SerialTransport
    if name == "EmulatedBricks":
        from nxt_link.emulator.inprocess import EmulatedBricks

        return EmulatedBricks
    raise AttributeError(f"module 'nxt_link' has no attribute {name!r}")
