"""Malformed and truncated executables are refused with a clear error; uploads work."""
from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nxt_link.emulator.emulator import compiled_follower
from nxt_link.emulator.firmware import Firmware
from nxt_link.emulator.vm import RxeError, load_rxe

FOLLOWER = compiled_follower()[0]["cplus_follow.rxe"]


def test_the_follower_program_loads():
    exe = load_rxe(FOLLOWER, "cplus_follow.rxe")
    assert exe.version == (0, 6) and len(exe.clumps) > 10 and exe.code


@pytest.mark.parametrize("data, text", [
    (b"", "no 'MindstormsNXT' file header"),
    (b"hello world, not a program", "no 'MindstormsNXT' file header"),
    (b"NXTBINARY\0\0\0\0\0\0\0", "native NXTBINARY image"),
    (FOLLOWER[:30], "truncated: 30 bytes, the file header alone has 38"),
    (FOLLOWER[:-2], "truncated: the header promises"),
    (FOLLOWER + b"\0\0", "2 bytes of garbage after the codespace"),
    (FOLLOWER[:14] + b"\x02\x00" + FOLLOWER[16:], "file version 2.0 is not supported"),
    (FOLLOWER[:34] + b"\0\0" + FOLLOWER[36:], "0 clumps"),
])
def test_bad_files_are_refused_with_a_clear_error(data, text):
    with pytest.raises(RxeError, match="^prog.rxe: ") as info:
        load_rxe(data, "prog.rxe")
    assert text in str(info.value)


@settings(max_examples=200)
@given(st.integers(min_value=0, max_value=len(FOLLOWER) - 1))
def test_every_truncation_is_refused(n):
    with pytest.raises(RxeError):
        load_rxe(FOLLOWER[:n])


@settings(max_examples=300)
@given(st.integers(min_value=0, max_value=1200), st.integers(min_value=1, max_value=255))
def test_damaged_headers_and_tables_never_crash_the_loader(pos, xor):
    data = bytearray(FOLLOWER)
    data[pos] ^= xor
    try:
        load_rxe(bytes(data))
    except RxeError as exc:
        assert str(exc).startswith("program.rxe: ")


def test_a_refused_program_does_not_run_and_says_why():
    fw = Firmware(flash_files={"bad.rxe": FOLLOWER[:-2]})
    fw.start_program_now("bad.rxe")
    fw.tick()
    assert fw.program is None
    assert fw.program_errors == ["cannot run bad.rxe: truncated: the header promises 4547 code "
                                 "words ending at byte " + str(len(FOLLOWER)) + ", the file has "
                                 + str(len(FOLLOWER) - 2) + " bytes"]


def _sys(fw: Firmware, op: int, body: bytes) -> bytes:
    reply = fw.handle(bytes((0x01, op)) + body)
    assert reply is not None and reply[:2] == bytes((0x02, op))
    return reply[2:]


def test_upload_with_system_commands_then_start_program():
    fw = Firmware()
    name = b"prog.rxe".ljust(20, b"\0")
    status, handle = _sys(fw, 0x81, name + struct.pack("<I", len(FOLLOWER)))
    assert status == 0
    for i in range(0, len(FOLLOWER), 100):
        st_, h, n = struct.unpack("<BBH", _sys(fw, 0x83, bytes((handle,)) + FOLLOWER[i:i + 100]))
        assert (st_, h) == (0, handle) and n == len(FOLLOWER[i:i + 100])
    assert _sys(fw, 0x86, b"*.rxe".ljust(20, b"\0"))[0] == 0x87  # not visible before CLOSE
    assert _sys(fw, 0x84, bytes((handle,))) == bytes((0, handle))
    found = _sys(fw, 0x86, b"*.rxe".ljust(20, b"\0"))
    assert found[0] == 0 and found[2:10] == b"prog.rxe" and \
        struct.unpack_from("<I", found, 22)[0] == len(FOLLOWER)
    assert _sys(fw, 0x81, name + struct.pack("<I", 10))[0] == 0x8F  # file exists
    assert fw.handle(bytes.fromhex("00 00") + name) == bytes.fromhex("02 00 00")  # STARTPROGRAM
    for _ in range(300):
        fw.tick()
    assert fw.program_name == "prog.rxe" and fw.program_errors == []
    assert _sys(fw, 0x85, name)[0] == 0x8B  # a running program's file is busy
    # read it back
    status, h, size = struct.unpack("<BBI", _sys(fw, 0x80, name))
    assert (status, size) == (0, len(FOLLOWER))
    data = b""
    while len(data) < size:
        r = _sys(fw, 0x82, bytes((h,)) + struct.pack("<H", min(100, size - len(data))))
        data += r[4:4 + struct.unpack_from("<H", r, 2)[0]]
    assert data == FOLLOWER
    assert _sys(fw, 0x84, bytes((h,)))[0] == 0
    assert fw.handle(bytes.fromhex("00 01")) == bytes.fromhex("02 01 00")  # STOPPROGRAM
    fw.tick()
    assert _sys(fw, 0x85, name)[0] == 0  # deleted
    assert _sys(fw, 0x80, name)[0] == 0x87


def test_an_incomplete_upload_leaves_no_file():
    fw = Firmware()
    name = b"half.rxe".ljust(20, b"\0")
    _, handle = _sys(fw, 0x81, name + struct.pack("<I", 50))
    _sys(fw, 0x83, bytes((handle,)) + bytes(20))
    _sys(fw, 0x84, bytes((handle,)))
    assert fw.flash.names() == []
    assert fw.handle(bytes.fromhex("00 00") + name) == bytes.fromhex("02 00 c0")
