"""The behaviour protocol's codec: round trips, sizes, damage detection."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nxt_link.programs import behaviour_protocol as bp
from nxt_link.programs import stream_protocol as sp
from nxt_link.wire.errors import TelegramError

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
s16 = st.integers(-0x8000, 0x7FFF)
u32 = st.integers(0, 0xFFFFFFFF)

requests = st.one_of(
    st.builds(bp.Hello, u16, u16, u8),
    st.builds(bp.Act, u16, u16, u8, st.lists(s16, max_size=bp.MAX_ARGS).map(tuple)),
    st.builds(bp.Cont, u16, u16, u8),
    st.builds(bp.Exog, u16, u16, u16),
    st.builds(bp.Abort, u16, u16),
)

# the program's events have no arguments (8 fit); with two arguments each, 7 fit in 58 bytes
events = st.one_of(
    st.lists(st.tuples(u8, st.just(())), max_size=bp.MAX_EVENTS_PER_MESSAGE),
    st.lists(st.tuples(u8, st.lists(s16, max_size=2).map(tuple)), max_size=7)).map(tuple)
responses = st.one_of(
    st.builds(bp.Welcome, u16, u16, u8, u8, u8, u16, u16, u16),
    st.builds(bp.Ack, u16, u16, u8, u8, u8),
    st.builds(bp.MoreTime, u16, u16, u8, u8, u32),
    st.builds(bp.Done, u16, u16, u8, u8, u8, u32,
              st.lists(st.tuples(u8, s16), max_size=8).map(tuple)),
    st.builds(bp.Events, u16, u16, u8, u16, u16, events),
    st.builds(bp.NoEvents, u16, u16, u8, u16, u16),
    st.builds(bp.Aborted, u16, u16, u8, u16, u16),
    st.builds(bp.Panic, u16, u16, u8, u16, u8),
)


@given(requests)
def test_requests_round_trip_within_a_mailbox_message(req):
    data = bp.encode_request(req)
    assert len(data) <= sp.MAX_MESSAGE
    assert bp.decode_request(data) == req


@given(responses)
def test_responses_round_trip_within_a_mailbox_message(resp):
    data = bp.encode_response(resp)
    assert len(data) <= sp.MAX_MESSAGE
    assert bp.decode_response(data) == resp


@given(st.one_of(requests.map(bp.encode_request), responses.map(bp.encode_response)),
       st.data())
def test_any_single_byte_damage_is_detected(data, draw):
    i = draw.draw(st.integers(0, len(data) - 1))
    flip = draw.draw(st.integers(1, 255))
    damaged = bytearray(data)
    damaged[i] ^= flip
    decode = bp.decode_request if data[0] in {k.value for k in (
        bp.Kind.HELLO, bp.Kind.ACT, bp.Kind.CONT, bp.Kind.EXOG, bp.Kind.ABORT)} \
        else bp.decode_response
    with pytest.raises(TelegramError):
        decode(bytes(damaged))


def test_the_message_kinds_differ_from_the_streaming_protocols():
    # each program ignores the other's messages instead of misreading them
    assert not {k.value for k in bp.Kind} & {k.value for k in sp.Kind}


def test_fields_that_do_not_fit_are_refused():
    with pytest.raises(TelegramError, match="arguments"):
        bp.encode_request(bp.Act(1, 1, 1, tuple(range(bp.MAX_ARGS + 1))))
    with pytest.raises(TelegramError, match="out of range"):
        bp.encode_request(bp.Act(1, 1, 1, (40000,)))
    with pytest.raises(TelegramError, match="exceeds"):
        bp.encode_response(bp.Events(1, 1, 0, 1, 0, ((1, (1, 2)),) * 12))


def test_malformed_messages_are_refused():
    with pytest.raises(TelegramError, match="too short"):
        bp.decode_response(b"\x01")
    body = bytes([bp.Kind.ACT, 1, 0, 1, 0, 1, 3, 0, 0])  # three arguments announced, one sent
    with pytest.raises(TelegramError, match="argument count"):
        bp.decode_request(body + sp.crc16(body).to_bytes(2, "little"))
    body = bytes([0x21, 1, 0, 1, 0])
    with pytest.raises(TelegramError, match="unknown request kind"):
        bp.decode_request(body + sp.crc16(body).to_bytes(2, "little"))


def test_golden_bytes_of_an_act():
    # kind 'a', session 7, ACT 1, FOLLOW, one argument 30 s, CRC-16/CCITT-FALSE
    data = bp.encode_request(bp.Act(7, 1, bp.Behaviour.FOLLOW, (30,)))
    assert data[:-2].hex(" ") == "61 07 00 01 00 01 01 1e 00"
    assert int.from_bytes(data[-2:], "little") == sp.crc16(data[:-2])
