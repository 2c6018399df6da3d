"""The brick programs and the mailbox protocols they speak.

``nxc/cplus_follow.nxc`` (the setpoint follower, the paper's Algorithm 2) and
``nxc/cplus_legolog.nxc`` (Legolog's act / sense / exogenous-event loop), shipped as package
data, and their protocols: :mod:`~nxt_link.programs.stream_protocol` and
:mod:`~nxt_link.programs.behaviour_protocol`. The protocols are shared: the host side speaks
them to a brick, the emulator's models of the programs answer them. They import only the wire.
"""
from pathlib import Path

from nxt_link.programs import behaviour_protocol, stream_protocol

#: The folder of the ``.nxc`` sources.
NXC_DIR = Path(__file__).resolve().parent / "nxc"

__all__ = ["NXC_DIR", "stream_protocol", "behaviour_protocol"]
