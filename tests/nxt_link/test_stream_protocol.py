"""Streaming protocol codec: round trips, size limit, damage detection."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nxt_link.programs import stream_protocol as sp
from nxt_link.wire.errors import TelegramError

u16 = st.integers(0, 0xFFFF)
i16 = st.integers(-32768, 32767)
u8 = st.integers(0, 255)


@st.composite
def configs(draw):
    n = draw(st.integers(1, 3))
    ports = tuple(draw(st.permutations([0, 1, 2]))[:n])
    return sp.Config(draw(u16), draw(u16), ports, draw(u16), draw(u16), draw(u8), draw(u8),
                     draw(u8), draw(u8), tuple(draw(i16) for _ in range(n)),
                     tuple(draw(i16) for _ in range(n)))


requests = st.one_of(
    st.builds(sp.Hello, u16, u16, u8),
    configs(),
    st.builds(sp.Setpoints, u16, u16, u16,
              st.lists(i16, max_size=sp.SETPOINT_VALUES_PER_MESSAGE).map(tuple)),
    st.builds(sp.Prepare, u16, u16),
    st.builds(sp.Go, u16, u16, u16),
    st.builds(sp.Query, u16, u16),
    st.builds(sp.LogRead, u16, u16, u16, u8),
    st.builds(sp.Stop, u16, u16),
)
responses = st.one_of(
    st.builds(sp.Welcome, u16, u16, u8, u8, u8, u16, u16, u16, u16, u8),
    st.builds(sp.Ack, u16, u16, u8, u8, u16, u16, u16, i16, u16),
    st.builds(sp.LogData, u16, u16, u8, u16,
              st.lists(i16, max_size=sp.LOG_VALUES_PER_MESSAGE).map(tuple)),
)


@given(requests)
def test_request_round_trip_within_the_mailbox_limit(req):
    raw = sp.encode_request(req)
    assert len(raw) <= sp.MAX_MESSAGE == 58
    assert sp.decode_request(raw) == req


@given(responses)
def test_response_round_trip_within_the_mailbox_limit(resp):
    raw = sp.encode_response(resp)
    assert len(raw) <= 58
    assert sp.decode_response(raw) == resp


@given(st.one_of(requests, responses), st.data())
def test_any_single_byte_damage_is_detected(msg, data):
    is_request = isinstance(msg, (sp.Hello, sp.Config, sp.Setpoints, sp.Prepare, sp.Go,
                                  sp.Query, sp.LogRead, sp.Stop))
    raw = bytearray(sp.encode_request(msg) if is_request else sp.encode_response(msg))
    i = data.draw(st.integers(0, len(raw) - 1))
    raw[i] ^= data.draw(st.integers(1, 255))
    with pytest.raises(TelegramError):
        (sp.decode_request if is_request else sp.decode_response)(bytes(raw))


def test_crc16_is_ccitt_false():
    # the standard check value of CRC-16/CCITT-FALSE, and the empty message
    assert sp.crc16(b"123456789") == 0x29B1
    assert sp.crc16(b"") == 0xFFFF


def test_setpoint_checksum_is_the_crc_of_the_little_endian_values():
    values = [0, 1, -1, 300, -32768, 32767]
    raw = b"".join(v.to_bytes(2, "little", signed=True) for v in values)
    assert sp.setpoint_checksum(values) == sp.crc16(raw)


def test_messages_pack_as_many_rows_as_fit():
    assert sp.rows_per_setpoint_message(2) == 12 and sp.rows_per_setpoint_message(3) == 8
    assert sp.rows_per_log_message(2) == 11 and sp.rows_per_log_message(3) == 7
    full = sp.Setpoints(1, 2, 0, tuple(range(sp.SETPOINT_VALUES_PER_MESSAGE)))
    assert len(sp.encode_request(full)) == 58
    with pytest.raises(TelegramError, match="exceed"):
        sp.encode_request(sp.Setpoints(1, 2, 0, tuple(range(25))))
