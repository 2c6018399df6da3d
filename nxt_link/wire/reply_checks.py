"""Is this reply the firmware's answer to that command?  The plausibility checks on a parsed reply.

The replies carry no checksum, so a damaged reply can parse cleanly; these functions say
which status bytes the firmware can send to a command as it was sent, and refuse a reply
that does not fit (protocol doc §1.5, §2).  Apart from the layouts in :mod:`nxt_link.wire.codec`
because they judge what a reply means, not how it is laid out; :mod:`nxt_link.wire.telegram`
gives them with the rest.
"""
from __future__ import annotations

from nxt_link.wire.codec import encode_reply
from nxt_link.wire.errors import TelegramError
from nxt_link.wire.messages import (
    MAILBOX_COUNT,
    MAX_MESSAGE_PAYLOAD,
    Command,
    GetCurrentProgramName,
    GetInputValues,
    GetOutputState,
    InputValuesReply,
    MessageRead,
    MessageReadReply,
    MessageWrite,
    OutputPort,
    OutputStateReply,
    ProgramNameReply,
    RegulationMode,
    Reply,
    ResetMotorPosition,
    SetInputMode,
    SetOutputState,
    StartProgram,
    StopProgram,
)

_OK = 0x00
_EMPTY_MAILBOX = 0x40
_FILE_FAILED = 0xBD
_ILLEGAL_VALUE = 0xC0
_NO_PROGRAM = 0xEC
_INVALID_QUEUE = 0xEE
_OUTPUTS, _INPUTS = 3, 4


def plausible_statuses(cmd: Command) -> frozenset[int]:
    """The status bytes the firmware can answer to ``cmd`` exactly as it was sent.

    From the firmware's checks (protocol doc §1.5, §2): a port out of range gets ``C0``, a
    queue out of range ``EE``, a mailbox command without a running program ``EC``, a read
    of an empty queue ``40``, STARTPROGRAM of a missing file ``C0`` (``BD`` on some
    firmware versions). Any other status to that command can only come from damage on the
    way (the replies carry no checksum), so the client treats it like a lost reply.

    >>> sorted(plausible_statuses(MessageRead(11)))
    [0, 64, 236]
    >>> sorted(plausible_statuses(GetOutputState(7)))
    [192]
    """
    if isinstance(cmd, StartProgram):
        return frozenset((_OK, _ILLEGAL_VALUE, _FILE_FAILED))
    if isinstance(cmd, (StopProgram, GetCurrentProgramName)):
        return frozenset((_OK, _NO_PROGRAM))
    if isinstance(cmd, (GetOutputState, ResetMotorPosition)):
        return frozenset((_OK,) if cmd.port < _OUTPUTS else (_ILLEGAL_VALUE,))
    if isinstance(cmd, SetOutputState):
        return frozenset((_OK,) if cmd.port < _OUTPUTS or cmd.port == OutputPort.ALL
                         else (_ILLEGAL_VALUE,))
    if isinstance(cmd, (GetInputValues, SetInputMode)):
        return frozenset((_OK,) if cmd.port < _INPUTS else (_ILLEGAL_VALUE,))
    if isinstance(cmd, MessageWrite):
        if len(cmd.message) > MAX_MESSAGE_PAYLOAD:
            return frozenset((_ILLEGAL_VALUE,))
        if cmd.inbox >= MAILBOX_COUNT:
            return frozenset((_INVALID_QUEUE,))
        return frozenset((_OK, _NO_PROGRAM))
    if isinstance(cmd, MessageRead):
        if cmd.remote_inbox >= MAILBOX_COUNT:
            return frozenset((_NO_PROGRAM, _INVALID_QUEUE))  # the program is checked first
        return frozenset((_OK, _EMPTY_MAILBOX, _NO_PROGRAM))
    return frozenset((_OK,))


def check_reply(cmd: Command, reply: Reply) -> None:
    """Refuse a well-formed reply of ``cmd``'s opcode that cannot be the answer to ``cmd``.

    A reply is untrusted when its status is not one the firmware can give to this very
    command (:func:`plausible_statuses`), when an error reply carries a payload (the
    firmware zero-fills it), or when a field the firmware echoes differs from the request
    (the port of GETOUTPUTSTATE/GETINPUTVALUES, MESSAGEREAD's local inbox), or when a
    field holds a value the firmware never sends (a mailbox message without its NUL, a
    program name that is not printable ASCII, an output mode outside the firmware's).

    Raises:
        TelegramError: the reply was damaged on the way (or answers another request).

    >>> from nxt_link.wire.telegram import GetBatteryLevel, parse_reply
    >>> check_reply(GetBatteryLevel(), parse_reply(bytes.fromhex("02 0b 72 00 00")))
    Traceback (most recent call last):
    ...
    nxt_link.wire.errors.TelegramError: GET_BATTERY_LEVEL reply with status 0x72, which this command cannot get
    """
    name = cmd.opcode.name
    if reply.status not in plausible_statuses(cmd):
        raise TelegramError(f"{name} reply with status 0x{reply.status:02X}, which this "
                            "command cannot get")
    if reply.status:
        body = encode_reply(reply)[3:]
        if isinstance(reply, MessageReadReply):
            body = body[1:]  # the local inbox is echoed on error too
        if any(body):
            raise TelegramError(f"{name} error reply 0x{reply.status:02X} with a payload")
        if isinstance(reply, MessageReadReply) and isinstance(cmd, MessageRead) \
                and reply.local_inbox != cmd.local_inbox:
            raise TelegramError(f"{name} reply for local inbox {reply.local_inbox}, asked "
                                f"{cmd.local_inbox}")
        return
    if isinstance(reply, (OutputStateReply, InputValuesReply)) \
            and isinstance(cmd, (GetOutputState, GetInputValues)) and reply.port != cmd.port:
        raise TelegramError(f"{name} reply for port {reply.port}, asked {cmd.port}")
    if isinstance(reply, OutputStateReply) and (
            reply.mode > 0x07 or reply.regulation_mode > RegulationMode.SYNC
            or reply.run_state not in (0x00, 0x10, 0x20, 0x40)):
        raise TelegramError(f"{name} reply with a mode the firmware does not report")
    if isinstance(reply, MessageReadReply) and isinstance(cmd, MessageRead):
        if reply.local_inbox != cmd.local_inbox:
            raise TelegramError(f"{name} reply for local inbox {reply.local_inbox}, asked "
                                f"{cmd.local_inbox}")
        if not reply.message or reply.message[-1] != 0:
            raise TelegramError(f"{name} reply with a message that does not end in NUL")
    if isinstance(reply, ProgramNameReply) and (
            not reply.name or not all(0x20 <= ord(c) < 0x7F for c in reply.name)):
        raise TelegramError(f"{name} reply with the unprintable name {reply.name!r}")
