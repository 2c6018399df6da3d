"""The emulated firmware's system commands: the versions, the device info and the flash file
system (OPENWRITE, WRITE, CLOSE, ... as nxt-python's file API sends them).

A part of :class:`~nxt_link.emulator.firmware.Firmware` (a base class of it): the file
commands are a protocol of their own next to the direct commands, so they have a module of
their own.
"""
from __future__ import annotations

import logging
import struct
from collections.abc import Callable

from nxt_link.emulator.firmware_types import ERR_RC_UNKNOWN_CMD, NO_ERR, FirmwareParams
from nxt_link.emulator.vm import flash as fl
from nxt_link.wire import telegram as tg
from nxt_link.wire.telegram import Opcode

log = logging.getLogger("nxt_link.emulator.firmware")   # the firmware's one logger


class _FileCommands:
    """The system commands; ``_FILE_COMMANDS`` names the handler of each file opcode."""

    #: set by :class:`~nxt_link.emulator.firmware.Firmware`: its settings and its flash
    params: FirmwareParams
    flash: fl.Flash

    def _system(self, telegram: bytes, want_reply: bool) -> bytes | None:
        """System commands: versions, device info, and the flash file system.

        A no-reply system command is still carried out (a file write with no
        acknowledgement writes); a telegram too short for its opcode is dropped."""
        op = telegram[1]
        body = telegram[2:]
        if op == Opcode.GET_FIRMWARE_VERSION:
            (fmaj, fmin), (pmaj, pmin) = self.params.firmware_version, self.params.protocol_version
            reply = tg.encode_reply(tg.FirmwareVersionReply(NO_ERR, pmin, pmaj, fmin, fmaj))
        elif op == Opcode.GET_DEVICE_INFO:
            reply = tg.encode_reply(tg.DeviceInfoReply(
                NO_ERR, self.params.name, self.params.bt_address, (0, 0, 0, 0), 65536))
        else:
            handler = _FILE_COMMANDS.get(op)
            if handler is None:
                reply = bytes((tg.CommandType.REPLY, op, ERR_RC_UNKNOWN_CMD))
            else:
                payload = handler(self, body)
                if payload is None:
                    log.warning("dropping malformed system command %s", telegram.hex())
                    return None
                reply = bytes((tg.CommandType.REPLY, op)) + payload
        return reply if want_reply else None

    def _file_open_write(self, body: bytes, data_file: bool = False) -> bytes | None:
        if len(body) < 24:
            return None
        size = struct.unpack_from("<I", body, 20)[0]
        status, handle = self.flash.open_write(_filename(body), size, data_file=data_file)
        return bytes((status, handle))

    def _file_write(self, body: bytes) -> bytes | None:
        if len(body) < 1:
            return None
        status, handle, n = self.flash.write(body[0], body[1:])
        return bytes((status, handle)) + struct.pack("<H", n)

    def _file_close(self, body: bytes) -> bytes | None:
        if len(body) < 1:
            return None
        status, handle = self.flash.close(body[0])
        return bytes((status, handle))

    def _file_open_read(self, body: bytes) -> bytes | None:
        if len(body) < 1:
            return None
        status, handle, size = self.flash.open_read(_filename(body))
        return bytes((status, handle)) + struct.pack("<I", size if status == 0 else 0)

    def _file_read(self, body: bytes) -> bytes | None:
        if len(body) < 3:
            return None
        count = struct.unpack_from("<H", body, 1)[0]
        if count > _MAX_READ:
            log.warning("READ of %d bytes needs the firmware's extended mode, not modelled", count)
            return None
        status, handle, data = self.flash.read(body[0], count)
        return bytes((status, handle)) + struct.pack("<H", count) + data.ljust(count, b"\0")

    def _file_delete(self, body: bytes) -> bytes | None:
        if len(body) < 1:
            return None
        name = _filename(body)
        status = self.flash.delete(name)
        return bytes((status,)) + name.encode("latin-1")[:fl.FILENAME_LENGTH].ljust(20, b"\0")

    def _file_find(self, body: bytes, first: bool) -> bytes | None:
        if len(body) < 1:
            return None
        if first:
            status, handle, name, size = self.flash.find_first(_filename(body))
        else:
            status, handle, name, size = self.flash.find_next(body[0])
        if status != 0:
            return bytes((status, handle)) + bytes(24)
        return (bytes((status, handle)) + name.encode("latin-1").ljust(20, b"\0")
                + struct.pack("<I", size))

    def _file_open_append(self, body: bytes) -> bytes | None:
        if len(body) < 1:
            return None
        status, handle, room = self.flash.open_append(_filename(body))
        return bytes((status, handle)) + struct.pack("<I", room)



def _filename(body: bytes) -> str:
    """A file name field: up to the NUL (names longer than 19 characters are refused
    by the loader)."""
    raw = body[:20] if b"\0" in body[:20] else body[:21]
    return raw.split(b"\0", 1)[0].decode("latin-1")


#: READ sizes a reply can carry in one Bluetooth packet
_MAX_READ = 120

_FILE_COMMANDS: dict[int, Callable[[_FileCommands, bytes], bytes | None]] = {
    0x80: _FileCommands._file_open_read,
    0x81: _FileCommands._file_open_write,
    0x82: _FileCommands._file_read,
    0x83: _FileCommands._file_write,
    0x84: _FileCommands._file_close,
    0x85: _FileCommands._file_delete,
    0x86: lambda fw, body: fw._file_find(body, True),
    0x87: lambda fw, body: fw._file_find(body, False),
    0x89: _FileCommands._file_open_write,
    0x8B: lambda fw, body: fw._file_open_write(body, data_file=True),
    0x8C: _FileCommands._file_open_append,
}
