"""The emulated brick: firmware, motors, sensors, the world it drives in, the programs it runs.

:class:`BrickEmulator` answers telegrams as the firmware does, runs the brick programs (their
compiled ``.rxe`` in the bytecode interpreter :mod:`nxt_link.emulator.vm`, or the Python models
:mod:`~nxt_link.emulator.follower_program` and :mod:`~nxt_link.emulator.legolog_program`),
moves modelled motors in a :class:`WorldSpec`, and is served on a pty (:class:`PtyBrickServer`),
in process (:class:`MemoryTransport`) or many at once (:class:`EmulatedBricks`). It imports the
wire and the programs, never the host side.
"""
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, FaultParams, LinkParams
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.pty_server import PtyBrickServer
from nxt_link.emulator.stall import Stall
from nxt_link.emulator.world import WorldSpec, delivery_world

__all__ = ["BrickEmulator", "EmulatorConfig", "FaultParams", "LinkParams", "MemoryTransport",
           "PtyBrickServer", "Stall", "WorldSpec", "delivery_world", "EmulatedBricks"]


def __getattr__(name: str) -> object:
    if name == "EmulatedBricks":
        from nxt_link.emulator.inprocess import EmulatedBricks

        return EmulatedBricks
    raise AttributeError(f"module 'nxt_link.emulator' has no attribute {name!r}")
