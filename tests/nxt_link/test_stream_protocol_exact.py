"""Streaming protocol to the byte: every message's layout, the wire constants the NXC program
shares, and the exact refusals of the session layer."""
from __future__ import annotations

import struct

import pytest

from nxt_link.programs import stream_protocol as sp
from nxt_link.wire.errors import TelegramError


def sealed(hex_body: str) -> bytes:
    body = bytes.fromhex(hex_body)
    return body + struct.pack("<H", sp.crc16(body))


@pytest.mark.parametrize("req, body", [
    (sp.Hello(0x1234), "48 3412 0000 01"),
    (sp.Hello(1, 2, 7), "48 0100 0200 07"),
    (sp.Config(0x0102, 3, (0, 2), 0x0304, 50, 2, 1, 100, 3, (-500, -400), (500, 400)),
     "43 0201 0300 02 00 02 ff 0403 3200 02 01 64 03 0cfe 70fe 0000 f401 9001 0000"),
    (sp.Config(1, 1, (1, 0, 2), 9, 10, 1, 2, 3, 4, (1, 2, 3), (4, 5, 6)),
     "43 0100 0100 03 01 00 02 0900 0a00 01 02 03 04 0100 0200 0300 0400 0500 0600"),
    (sp.Setpoints(1, 4, 0x0102, (1, -1, 256)), "53 0100 0400 0201 03 0100 ffff 0001"),
    (sp.Prepare(5, 6), "50 0500 0600"),
    (sp.Go(5, 7), "47 0500 0700 0000"),
    (sp.Go(5, 7, 30000), "47 0500 0700 3075"),
    (sp.Query(5, 0x8001), "51 0500 0180"),
    (sp.LogRead(5, 0x8002, 300, 11), "4c 0500 0280 2c01 0b"),
    (sp.Stop(5, 9), "58 0500 0900"),
])
def test_requests_byte_for_byte(req, body):
    assert sp.encode_request(req) == sealed(body)
    assert sp.decode_request(sealed(body)) == req


@pytest.mark.parametrize("resp, body", [
    (sp.Welcome(5, 0, 0, 1, 0, 1, 3000, 0, 0, 10), "57 0500 0000 00 01 00 0100 b80b 0000 0000 0a"),
    (sp.Ack(5, 3, 4, 2, 4, 30, 7, -3, 0xBEEF), "41 0500 0300 04 02 0400 1e00 0700 fdff efbe"),
    (sp.LogData(5, 0x8003, 6, 11, (1, -2)), "44 0500 0380 06 0b00 02 0100 feff"),
    (sp.LogData(5, 1, 6, 0, ()), "44 0500 0100 06 0000 00"),
])
def test_responses_byte_for_byte(resp, body):
    assert sp.encode_response(resp) == sealed(body)
    assert sp.decode_response(sealed(body)) == resp


def test_the_constants_the_brick_program_shares():
    assert (sp.PROTOCOL_VERSION, sp.PROGRAM_NAME, sp.CMD_INBOX, sp.RESPONSE_QUEUE, sp.RESPONSE_MAILBOX) == (
        1, "cplus_follow.rxe", 1, 1, 11)
    assert (sp.MAX_VALUES, sp.MAX_PORTS, sp.CONTROL_MS, sp.MAX_MESSAGE) == (3000, 3, 10, 58)
    assert (sp.SETPOINT_VALUES_PER_MESSAGE, sp.LOG_VALUES_PER_MESSAGE) == (24, 23)
    assert [sp.rows_per_setpoint_message(n) for n in (1, 2, 3)] == [24, 12, 8]
    assert [sp.rows_per_log_message(n) for n in (1, 2, 3)] == [23, 11, 7]
    assert {k.name: chr(k.value) for k in sp.Kind} == {
        "HELLO": "H", "CONFIG": "C", "SETPOINTS": "S", "PREPARE": "P", "GO": "G", "QUERY": "Q",
        "LOGREAD": "L", "STOP": "X", "WELCOME": "W", "ACK": "A", "LOGDATA": "D"}
    assert [s.value for s in sp.State] == list(range(8))
    assert [c.name for c in sp.Code] == ["OK", "DUPLICATE", "GAP", "BAD_STATE", "BAD_CONFIG", "OUT_OF_LIMITS",
                                         "BAD_ORDER", "BAD_RANGE", "BAD_LENGTH", "BAD_VERSION"]
    assert [c.value for c in sp.Code] == list(range(10))
    assert sp.SEQUENCED_KINDS == {sp.Kind.CONFIG, sp.Kind.SETPOINTS, sp.Kind.PREPARE, sp.Kind.GO}


def test_crc_values():
    assert sp.crc16(b"") == 0xFFFF and sp.crc16(b"", 0x1234) == 0x1234
    assert sp.crc16(b"\x00") == 0xE1F0 and sp.crc16(b"\xff") == 0xFF00
    assert sp.crc16(b"56789", sp.crc16(b"1234")) == 0x29B1
    assert sp.setpoint_checksum([]) == 0xFFFF
    assert sp.setpoint_checksum([-1, 256]) == sp.crc16(bytes.fromhex("ffff 0001"))


def test_seal_and_unseal_at_their_limits():
    assert len(sp.seal(bytes(56))) == 58
    with pytest.raises(TelegramError, match="^message of 59 bytes exceeds 58$"):
        sp.seal(bytes(57))
    with pytest.raises(TelegramError, match="^message of 60 bytes exceeds 58$"):
        sp.seal(bytes(58))
    assert sp.unseal(sp.seal(b"\x07")) == b"\x07"
    with pytest.raises(TelegramError, match="^message too short$"):
        sp.unseal(sp.seal(b"")[:2])
    with pytest.raises(TelegramError, match="^message check failed$"):
        sp.unseal(b"\x07" + sp.seal(b"\x08")[1:])


def test_refusals_name_what_is_wrong():
    def refused(fn, arg) -> str:
        with pytest.raises(TelegramError) as info:
            fn(arg)
        return str(info.value)
    assert refused(sp.decode_request, sealed("48 0100")) == "request header truncated"
    assert refused(sp.decode_response, sealed("41 0100 0200")) == "response header truncated"
    assert refused(sp.decode_request, sealed("48 0100 0200")) == "malformed request of kind 0x48"
    assert refused(sp.decode_response, sealed("57 0100 0200 00 01")) == "malformed response of kind 0x57"
    assert refused(sp.decode_request, sealed("5a 0100 0200")) == "unknown request kind 0x5A"
    assert refused(sp.decode_response, sealed("51 0100 0200 00")) == "unknown response kind 0x51"
    assert refused(sp.decode_request, sealed("51 0100 0200 00")) == "unknown request kind 0x51"  # QUERY with a body
    assert refused(sp.encode_request, sp.Go(1, 2, 0x10000)).startswith("field out of range: ")
    assert refused(sp.encode_request, sp.Setpoints(1, 2, 0, tuple(range(25)))) == "25 values exceed 24"
    assert refused(sp.encode_response, sp.LogData(1, 2, 3, 0, tuple(range(24)))) == "24 values exceed 23"
    assert refused(sp.encode_request, sp.Config(1, 1, (), 1, 1, 1, 1, 1, 1, (), ())) == (
        "CONFIG needs 1-3 ports with one min and max each")
    assert refused(sp.encode_request, sp.Config(1, 1, (0, 1, 2, 0), 1, 1, 1, 1, 1, 1, (0,) * 4, (0,) * 4)) == (
        "CONFIG needs 1-3 ports with one min and max each")
    assert refused(sp.encode_request, sp.Config(1, 1, (0,), 1, 1, 1, 1, 1, 1, (0, 0), (0,))) == (
        "CONFIG needs 1-3 ports with one min and max each")
    assert refused(sp.encode_request, sp.Config(1, 1, (0,), 1, 1, 1, 1, 1, 1, (0,), ())) == (
        "CONFIG needs 1-3 ports with one min and max each")
    config = "43 0100 0100 {n} 00 01 02 0100 0100 01 01 01 01 0000 0000 0000 0000 0000 0000"
    assert refused(sp.decode_request, sealed(config.format(n="00"))) == "CONFIG with 0 ports"
    assert refused(sp.decode_request, sealed(config.format(n="04"))) == "CONFIG with 4 ports"
    assert sp.decode_request(sealed(config.format(n="03"))).ports == (0, 1, 2)
    assert refused(sp.decode_request, sealed("53 0100 0200 0000 02 0100")) == (
        "SETPOINTS length does not match its count")
    assert refused(sp.decode_response, sealed("44 0100 0200 06 0000 01 0100 0200")) == (
        "LOGDATA length does not match its count")
