"""The transport contract between :class:`nxt_link.host.brick.Brick` and a link.

A transport moves whole telegrams: ``send`` adds the Bluetooth length prefix,
``recv`` returns the next complete telegram with the prefix removed. Two
implementations share this contract so that ``Brick`` never knows which one it
has (architecture: "hardware behind a transport protocol with a software twin"):

* :class:`nxt_link.wire.serial_transport.SerialTransport` — pyserial on a real
  ``/dev/rfcommN`` or on the emulator's pseudo-terminal;
* :class:`nxt_link.emulator.memory_transport.MemoryTransport` — straight into an
  in-process :class:`nxt_link.emulator.emulator.BrickEmulator`, on a virtual clock.
"""
from __future__ import annotations

from typing import Protocol

from nxt_link.wire.clock import Clock, Deadline

__all__ = ["Transport"]


class Transport(Protocol):
    """What a link to one brick must offer.

    Attributes:
        name: where it goes, for messages ("/dev/rfcomm0", "memory:r1").
        clock: the clock its deadlines are measured on.
    """

    name: str
    clock: Clock

    def send(self, telegram: bytes) -> None:
        """Frame and send one telegram.

        Raises:
            LinkDisconnectedError: the link is gone.
            LinkTimeoutError: the bytes could not be written in time.
        """
        ...

    def recv(self, deadline: Deadline) -> bytes:
        """Return the next complete telegram received.

        Raises:
            LinkTimeoutError: none arrived before ``deadline``.
            LinkDisconnectedError: the link is gone.
        """
        ...

    def discard_input(self, quiet_s: float) -> int:
        """Drop everything received until the line has been quiet for ``quiet_s``.

        Used after a timeout or a damaged frame so that late or broken bytes are
        not taken for the next reply. Returns the number of bytes dropped.
        """
        ...

    def reconnect(self, deadline: Deadline) -> None:
        """Close and reopen the link, retrying until ``deadline``.

        Raises:
            LinkDisconnectedError: still unreachable at the deadline.
        """
        ...

    def close(self) -> None:
        """Release the link; further use raises LinkDisconnectedError."""
        ...
