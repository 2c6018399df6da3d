"""The one exception tree of `nxt_link`.

Everything the package raises on purpose derives from :class:`LinkError`, so a
caller (the CLI) can turn any of them into a one-line message with ``str(err)``.

* :class:`ProtocolError` — the brick answered with a non-zero status byte; one
  subclass per firmware status (see ``docs/nxt-link.md`` and the protocol doc,
  §1.5), looked up with :func:`error_for_status`.
* :class:`LinkTimeoutError` — nothing (or nothing usable) arrived before a
  deadline; also a :class:`TimeoutError`.
* :class:`LinkDisconnectedError` — the device went away (EIO, hang-up); also a
  :class:`ConnectionError`.
* :class:`PortOpenError` — the port could not be opened at all.
* :class:`TelegramError` — bytes that do not decode as the telegram they claim
  to be (truncated, wrong length, bad opcode); also a :class:`ValueError`.
* :class:`StreamError` — the streaming protocol above the mailboxes failed
  (brick refused a configuration, program not installed, ...).
* :class:`ExecutionFailed` — an execution stopped before its end; carries the
  incomplete execution log (what every brick recorded) and the cause.
  :class:`ExecutionInterrupted` is its counterpart for Ctrl-C (a
  :class:`KeyboardInterrupt`).
* :class:`SetpointError` — a setpoint stream was refused before anything moved
  (out of limits, too fast, too long); also a :class:`ValueError`.
* :class:`ExecLogError` — an execution-log file does not validate.
* ``nxt_link.emulator.vm.errors`` adds :class:`~nxt_link.emulator.vm.errors.RxeError` (a program
  file the brick refuses; also a :class:`ValueError`) and
  :class:`~nxt_link.emulator.vm.errors.VMError` (a program the brick aborts; also a
  :class:`RuntimeError`).
"""
from __future__ import annotations

__all__ = [
    "LinkError",
    "ProtocolError",
    "PendingCommunicationError",
    "EmptyMailboxError",
    "RequestFailedError",
    "UnknownCommandError",
    "BadPacketError",
    "IllegalValueError",
    "BusError",
    "BufferFullError",
    "InvalidChannelError",
    "ChannelNotReadyError",
    "NoActiveProgramError",
    "InvalidSizeError",
    "InvalidQueueError",
    "InvalidFieldError",
    "InvalidPortError",
    "OutOfMemoryError",
    "BadArgumentsError",
    "UnknownStatusError",
    "LinkTimeoutError",
    "LinkDisconnectedError",
    "PortOpenError",
    "TelegramError",
    "StreamError",
    "ExecutionFailed",
    "ExecutionInterrupted",
    "SetpointError",
    "ExecLogError",
    "error_for_status",
    "STATUS_ERRORS",
]


class LinkError(Exception):
    """Base class of every error raised by `nxt_link`."""


class ProtocolError(LinkError):
    """The brick replied with a non-zero status byte.

    Attributes:
        status: the status byte as sent on the wire (0..255).
        opcode: the opcode of the command that failed, or ``None``.
    """

    status: int = -1
    meaning: str = "protocol error"

    def __init__(self, opcode: int | None = None, detail: str | None = None) -> None:
        self.opcode = opcode
        where = f" (opcode 0x{opcode:02X})" if opcode is not None else ""
        text = f"brick status 0x{self.status & 0xFF:02X}: {self.meaning}{where}"
        if detail:
            text = f"{text}: {detail}"
        super().__init__(text)


class PendingCommunicationError(ProtocolError):
    status, meaning = 0x20, "a communication transaction is still pending"


class EmptyMailboxError(ProtocolError):
    status, meaning = 0x40, "the mailbox queue is empty"


class RequestFailedError(ProtocolError):
    status, meaning = 0xBD, "request failed (e.g. file not found)"


class UnknownCommandError(ProtocolError):
    status, meaning = 0xBE, "unknown command opcode"


class BadPacketError(ProtocolError):
    status, meaning = 0xBF, "malformed packet"


class IllegalValueError(ProtocolError):
    status, meaning = 0xC0, "data contains out-of-range values"


class BusError(ProtocolError):
    status, meaning = 0xDD, "communication bus error"


class BufferFullError(ProtocolError):
    status, meaning = 0xDE, "communication buffer full"


class InvalidChannelError(ProtocolError):
    status, meaning = 0xDF, "channel/connection is not valid"


class ChannelNotReadyError(ProtocolError):
    status, meaning = 0xE0, "channel/connection busy or not configured"


class NoActiveProgramError(ProtocolError):
    status, meaning = 0xEC, "no program is running on the brick"


class InvalidSizeError(ProtocolError):
    status, meaning = 0xED, "illegal size"


class InvalidQueueError(ProtocolError):
    status, meaning = 0xEE, "illegal mailbox queue number"


class InvalidFieldError(ProtocolError):
    status, meaning = 0xEF, "invalid structure field"


class InvalidPortError(ProtocolError):
    status, meaning = 0xF0, "bad input or output port"


class OutOfMemoryError(ProtocolError):
    status, meaning = 0xFB, "out of memory"


class BadArgumentsError(ProtocolError):
    status, meaning = 0xFF, "invalid arguments"


class UnknownStatusError(ProtocolError):
    """A status byte the firmware documentation does not list."""

    meaning = "unknown status code"

    def __init__(self, status: int, opcode: int | None = None) -> None:
        self.status = status
        super().__init__(opcode)


STATUS_ERRORS: dict[int, type[ProtocolError]] = {
    cls.status: cls
    for cls in (
        PendingCommunicationError,
        EmptyMailboxError,
        RequestFailedError,
        UnknownCommandError,
        BadPacketError,
        IllegalValueError,
        BusError,
        BufferFullError,
        InvalidChannelError,
        ChannelNotReadyError,
        NoActiveProgramError,
        InvalidSizeError,
        InvalidQueueError,
        InvalidFieldError,
        InvalidPortError,
        OutOfMemoryError,
        BadArgumentsError,
    )
}


def error_for_status(status: int, opcode: int | None = None) -> ProtocolError:
    """Return (not raise) the exception for a non-zero status byte.

    >>> str(error_for_status(0xEC, 0x09))
    'brick status 0xEC: no program is running on the brick (opcode 0x09)'
    """
    cls = STATUS_ERRORS.get(status)
    if cls is None:
        return UnknownStatusError(status, opcode)
    return cls(opcode)


class LinkTimeoutError(LinkError, TimeoutError):
    """No (usable) answer arrived before the deadline."""


class LinkDisconnectedError(LinkError, ConnectionError):
    """The serial device went away (hang-up, EIO, closed by the peer)."""


class PortOpenError(LinkError):
    """The port could not be opened (missing device, permissions, not a tty)."""


class TelegramError(LinkError, ValueError):
    """Bytes that are not a well-formed telegram of the expected kind."""


class StreamError(LinkError):
    """The setpoint streaming protocol failed (refused, program missing, ...)."""


class ExecutionFailed(LinkError):
    """An execution stopped before its end (the message is the cause's).

    Raised through :meth:`of`, it is also an instance of its cause's class, so code that
    catches ``StreamError`` or ``LinkTimeoutError`` around an execution still does.

    Attributes:
        log: the incomplete :class:`~nxt_link.host.execlog.ExecutionLog`: what every
            brick recorded, the reason and the time it stopped.
        brick: the brick that failed, or None.
    """

    _kinds: dict[type, type] = {}

    def __init__(self, message: str, log: object, brick: str | None = None) -> None:
        Exception.__init__(self, message)
        self.log = log
        self.brick = brick

    @classmethod
    def of(cls, cause: LinkError, log: object, brick: str | None = None) -> ExecutionFailed:
        """The failure caused by ``cause``: an ExecutionFailed that is also a ``type(cause)``."""
        kind = cls._kinds.get(type(cause))
        if kind is None:
            kind = cls if isinstance(cause, cls) else type(cls.__name__, (cls, type(cause)),
                                                           {"__module__": __name__})
            cls._kinds[type(cause)] = kind
        failure: ExecutionFailed = kind.__new__(kind)  # type: ignore[call-overload]
        failure.__dict__.update(getattr(cause, "__dict__", {}))  # opcode, status, ...
        ExecutionFailed.__init__(failure, str(cause), log, brick)
        return failure


class ExecutionInterrupted(KeyboardInterrupt):
    """Ctrl-C during an execution: the bricks were told to stop; ``log`` holds what was
    gathered until then (incomplete)."""

    def __init__(self, log: object) -> None:
        super().__init__("interrupted")
        self.log = log


class SetpointError(LinkError, ValueError):
    """A setpoint stream was refused before anything moved."""


class ExecLogError(LinkError, ValueError):
    """An execution log does not validate against ``cplus.execlog/1``."""
