"""The emulated firmware's 20 mailbox queues: MESSAGEWRITE and MESSAGEREAD as the NXT firmware
handles them (the order of its checks, 5 deep, a write to a full queue drops the oldest).

A part of :class:`~nxt_link.emulator.firmware.Firmware` (a base class of it), kept in its own
module because the mailboxes are the one channel between the PC and a running program and
read best on their own.
"""
from __future__ import annotations

import logging
from collections import deque

from nxt_link.emulator.firmware_types import (
    ERR_INVALID_QUEUE,
    ERR_INVALID_SIZE,
    ERR_NO_PROG,
    ERR_RC_ILLEGAL_VAL,
    MESSAGES_PER_QUEUE,
    NO_ERR,
    STAT_MSG_EMPTY_MAILBOX,
    Program,
)
from nxt_link.wire import telegram as tg
from nxt_link.wire.telegram import Opcode

log = logging.getLogger("nxt_link.emulator.firmware")   # the firmware's one logger


class _Mailboxes:
    """MESSAGEWRITE, MESSAGEREAD and the mailbox queues a running program reads and writes."""

    #: set by :class:`~nxt_link.emulator.firmware.Firmware`: the queues, and the running program
    mailboxes: list[deque[bytes]]
    program: Program | None

    def _message_write(self, telegram: bytes, want_reply: bool) -> bytes | None:
        op = Opcode.MESSAGE_WRITE
        if len(telegram) < 4:
            log.warning("dropping truncated MESSAGEWRITE %s", telegram.hex())
            return None
        inbox, size = telegram[2], telegram[3]
        data = telegram[4:4 + size]
        if size == 0 or size > tg.MAX_MESSAGE_SIZE or len(data) < size or data[size - 1] != 0:
            status = ERR_RC_ILLEGAL_VAL
        else:
            status = self.write_mailbox(inbox, bytes(data))
        if not want_reply:
            return None
        return tg.encode_reply(tg.StatusReply(op, status))

    def write_mailbox(self, queue: int, message: bytes) -> int:
        """Firmware ``cCmdMessageWrite``: the order of its checks, drop-oldest when full."""
        if queue >= tg.MAILBOX_COUNT:
            return ERR_INVALID_QUEUE
        if self.program is None:
            return ERR_NO_PROG
        if len(message) > tg.MAX_MESSAGE_SIZE:
            return ERR_INVALID_SIZE
        box = self.mailboxes[queue]
        if len(box) == MESSAGES_PER_QUEUE:
            log.debug("mailbox %d full: oldest message dropped", queue)
        box.append(message)  # deque(maxlen=5) drops the oldest, like the firmware
        return NO_ERR

    def read_mailbox(self, queue: int, remove: bool) -> tuple[int, bytes]:
        """Firmware ``cCmdMessageGetSize`` + ``cCmdMessageRead``."""
        if self.program is None:
            return ERR_NO_PROG, b""
        if queue >= tg.MAILBOX_COUNT:
            return ERR_INVALID_QUEUE, b""
        box = self.mailboxes[queue]
        if not box:
            return STAT_MSG_EMPTY_MAILBOX, b""
        return NO_ERR, (box.popleft() if remove else box[0])

    def _message_read(self, cmd: tg.MessageRead) -> bytes:
        status, message = self.read_mailbox(cmd.remote_inbox, cmd.remove)
        if status != NO_ERR:
            return tg.error_reply(Opcode.MESSAGE_READ, status, cmd.local_inbox)
        return tg.encode_reply(tg.MessageReadReply(NO_ERR, cmd.local_inbox, message))

    def _incoming_reply(self, telegram: bytes) -> None:
        """A MESSAGEREAD reply sent *to* the brick is stored in the mailbox it names."""
        if len(telegram) < 5 or telegram[1] != Opcode.MESSAGE_READ:
            return
        status, queue, size = telegram[2], telegram[3], telegram[4]
        data = telegram[5:5 + size]
        if (status & 0x80) == 0 and 0 < size <= tg.MAX_MESSAGE_SIZE and len(data) == size \
                and data[-1] == 0:
            self.write_mailbox(queue, bytes(data))
