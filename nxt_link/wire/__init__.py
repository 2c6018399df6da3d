"""The wire: what travels between the PC and a brick, and how.

The direct-command telegrams (:mod:`~nxt_link.wire.telegram`), the Bluetooth length prefix
(:mod:`~nxt_link.wire.framing`), the :class:`Transport` interface and the serial transport
(``/dev/rfcommN`` or an emulator pty), the link errors and the clocks every side keeps time
with. The wire imports no other part of :mod:`nxt_link`.
"""
from nxt_link.wire.clock import Clock, Deadline, MonotonicClock, SimClock, SimulationStalled, VirtualClock
from nxt_link.wire.errors import LinkError, LinkTimeoutError, ProtocolError, TelegramError
from nxt_link.wire.framing import FrameDecoder, frame
from nxt_link.wire.transport import Transport

__all__ = ["Clock", "Deadline", "MonotonicClock", "SimClock", "SimulationStalled", "VirtualClock",
           "LinkError", "LinkTimeoutError", "ProtocolError", "TelegramError",
           "FrameDecoder", "frame", "Transport", "SerialTransport"]


def __getattr__(name: str) -> object:
    # pyserial is imported only when the serial transport is actually used
    if name == "SerialTransport":
        from nxt_link.wire.serial_transport import SerialTransport

        return SerialTransport
    raise AttributeError(f"module 'nxt_link.wire' has no attribute {name!r}")
