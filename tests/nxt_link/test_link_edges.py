"""The link's edges that damage tests never reach: the CRC catches random damage first, so
these build messages that pass it (sealed, yet malformed), frames at exactly the limits, and a
brick whose program stops. Each test here was written against a mutant that survived the
whole suite (docs/testing.md)."""
from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nxt_link.programs import stream_protocol as sp
from nxt_link.wire.errors import TelegramError
from nxt_link.wire.framing import MAX_TELEGRAM, FrameDecoder, frame

# ---------------------------------------------------------------------------------------------
# framing


def test_a_telegram_of_exactly_the_maximum_is_framed_and_decoded():
    telegram = bytes(range(MAX_TELEGRAM))
    assert MAX_TELEGRAM == 126  # the brick's 128-byte Bluetooth buffer less the prefix
    framed = frame(telegram)
    assert framed[:2] == b"\x7e\x00" and framed[2:] == telegram
    d = FrameDecoder()
    assert d.feed(framed) == [telegram] and d.stats.desyncs == 0
    assert frame(b"\x01") == b"\x01\x00\x01"  # the least, too


@pytest.mark.parametrize("prefix", [b"\x00\x00", bytes([MAX_TELEGRAM + 1, 0]), b"\xff\xff"])
def test_a_lone_impossible_prefix_does_not_take_the_next_frame_with_it(prefix):
    """Two bytes that cannot start a frame, read on their own: discarded at once, so the valid
    frame of the next read is decoded (kept, they would desync it away)."""
    d = FrameDecoder()
    assert d.feed(prefix, now=0.0) == []
    assert d.pending == b"" and d.stats.desyncs == 1
    assert d.feed(frame(b"\x02\x0b\x00"), now=0.01) == [b"\x02\x0b\x00"]


@given(st.binary(min_size=2, max_size=2).filter(lambda p: not 0 < int.from_bytes(p, "little") <= 126),
       st.binary(min_size=1, max_size=MAX_TELEGRAM))
def test_any_impossible_prefix_alone_then_any_frame(prefix, telegram):
    d = FrameDecoder(stale_after_s=None)
    assert d.feed(prefix) == []
    assert d.feed(frame(telegram)) == [telegram]


def test_the_length_limit_is_the_decoders_too():
    d = FrameDecoder()
    assert d.feed(b"\x7f\x00" + bytes(127)) == [] and d.stats.desyncs == 1
    assert d.feed(b"\x7e\x00" + bytes(126)) == [bytes(126)]


# ---------------------------------------------------------------------------------------------
# stream protocol: sealed (the CRC holds) but malformed


def sealed_request(kind: int, rest: bytes, session: int = 7, seq: int = 3) -> bytes:
    return sp.seal(sp.REQ_HEAD.pack(kind, session, seq) + rest)


def sealed_response(kind: int, rest: bytes, session: int = 7, seq: int = 3, state: int = 0) -> bytes:
    return sp.seal(sp.RESP_HEAD.pack(kind, session, seq, state) + rest)


@pytest.mark.parametrize("kind, rest", [
    (sp.Kind.HELLO, b""), (sp.Kind.HELLO, b"\x01\x02"), (sp.Kind.GO, b"\x01"),
    (sp.Kind.LOGREAD, b"\x00\x00"), (sp.Kind.CONFIG, bytes(10)), (sp.Kind.SETPOINTS, b"\x00"),
])
def test_a_malformed_request_is_a_telegram_error_naming_its_kind(kind, rest):
    with pytest.raises(TelegramError, match=f"^malformed request of kind 0x{kind:02X}$"):
        sp.decode_request(sealed_request(kind, rest))


@pytest.mark.parametrize("kind, rest", [
    (sp.Kind.WELCOME, b""), (sp.Kind.ACK, bytes(5)), (sp.Kind.LOGDATA, b"\x00"),
])
def test_a_malformed_response_is_a_telegram_error_naming_its_kind(kind, rest):
    with pytest.raises(TelegramError, match=f"^malformed response of kind 0x{kind:02X}$"):
        sp.decode_response(sealed_response(kind, rest))


@pytest.mark.parametrize("values, count", [(b"", 1), (struct.pack("<2h", 1, 2), 3),
                                           (struct.pack("<3h", 1, 2, 3), 2), (b"\x00", 0)])
def test_logdata_whose_length_does_not_match_its_count_is_refused(values, count):
    raw = sealed_response(sp.Kind.LOGDATA, struct.pack("<HB", 0, count) + values)
    with pytest.raises(TelegramError, match="^LOGDATA length does not match its count$"):
        sp.decode_response(raw)


@pytest.mark.parametrize("values, count", [(b"", 1), (struct.pack("<2h", 1, 2), 3), (b"\x00", 0)])
def test_setpoints_whose_length_does_not_match_its_count_are_refused(values, count):
    raw = sealed_request(sp.Kind.SETPOINTS, struct.pack("<HB", 0, count) + values)
    with pytest.raises(TelegramError, match="^SETPOINTS length does not match its count$"):
        sp.decode_request(raw)


def test_config_with_a_port_count_out_of_range_is_refused():
    for n in (0, 4):
        raw = sealed_request(sp.Kind.CONFIG, struct.pack("<B3BHHBBBB3h3h", n, 0, 1, 2, 5, 50, 1, 1,
                                                         100, 3, 0, 0, 0, 1, 1, 1))
        with pytest.raises(TelegramError, match=f"^CONFIG with {n} ports$"):
            sp.decode_request(raw)


@pytest.mark.parametrize("kind", [0x00, 0x7F, sp.Kind.HELLO, sp.Kind.ACK ^ 0x20])
def test_an_unknown_response_kind_is_refused(kind):
    with pytest.raises(TelegramError, match=f"^unknown response kind 0x{kind:02X}$"):
        sp.decode_response(sealed_response(kind, b"\x00" * 12))


@pytest.mark.parametrize("kind, rest", [(0x00, b""), (sp.Kind.WELCOME, b""), (sp.Kind.QUERY, b"\x00"),
                                        (sp.Kind.STOP, b"x"), (sp.Kind.PREPARE, b"\x00\x00")])
def test_an_unknown_request_kind_or_a_simple_one_with_a_body_is_refused(kind, rest):
    with pytest.raises(TelegramError, match=f"^unknown request kind 0x{kind:02X}$"):
        sp.decode_request(sealed_request(kind, rest))


def test_a_header_cut_short_and_a_message_too_short_are_refused():
    with pytest.raises(TelegramError, match="^request header truncated$"):
        sp.decode_request(sp.seal(b"\x48\x00"))
    with pytest.raises(TelegramError, match="^response header truncated$"):
        sp.decode_response(sp.seal(bytes(sp.RESP_HEAD.size - 1)))
    for short in (b"", b"\x01\x02"):
        with pytest.raises(TelegramError, match="^message too short$"):
            sp.decode_response(short)
    assert sp.unseal(sp.seal(b"\x01")) == b"\x01"  # one byte and its check: the least


def test_the_mailbox_limit_is_exact():
    body = bytes(sp.MAX_MESSAGE - 2)
    assert len(sp.seal(body)) == sp.MAX_MESSAGE == 58
    with pytest.raises(TelegramError, match="^message of 59 bytes exceeds 58$"):
        sp.seal(body + b"\x00")


@given(st.sampled_from(list(sp.Kind)) | st.integers(0, 255), st.integers(0, 0xFFFF), st.integers(0, 0xFFFF),
       st.integers(0, 255), st.binary(max_size=50))
def test_any_sealed_message_decodes_to_what_encodes_back_or_is_a_telegram_error(kind, session, seq, state, rest):
    """Whatever passes the CRC: a message that encodes back to the same bytes, or a
    TelegramError; never another exception."""
    for head, decode, encode in ((sp.REQ_HEAD.pack(kind, session, seq), sp.decode_request, sp.encode_request),
                                 (sp.RESP_HEAD.pack(kind, session, seq, state), sp.decode_response,
                                  sp.encode_response)):
        body = head + rest
        if len(body) + 2 > sp.MAX_MESSAGE:
            continue
        raw = sp.seal(body)
        try:
            msg = decode(raw)
        except TelegramError:
            continue
        assert msg.kind == kind and msg.session == session and msg.seq == seq
        assert decode(encode(msg)) == msg  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------
# the session: a brick whose program stopped says so (it is no link timeout)


def opened(rig, **kw):
    from nxt_link.host.session import BrickSession, SessionTiming
    brick = rig.add("r1", **kw)
    s = BrickSession(brick, ("A",), 50, ((0,), (5,), (10,)), ((-500, 500),),
                     timing=SessionTiming(ack_timeout_s=0.3, max_silent_s=3.0))
    s.open()
    return s, brick


def test_a_program_stopped_under_the_session_is_named_as_such(rig):
    from nxt_link.wire.errors import StreamError
    s, brick = opened(rig)
    brick.stop_program()
    start = rig.clock.now()
    with pytest.raises(StreamError, match=r"^brick r1: the program cplus_follow\.rxe is no longer running$"):
        s.query()
    assert rig.clock.now() - start < 1.0  # from the reply that said so, not after a silence (3 s)


def test_a_program_stopped_while_its_answers_are_lost_is_named_after_the_silence(rig):
    """Every MESSAGEREAD reply is lost, so only the silence check finds out; it asks what runs
    before it calls the brick gone."""
    from nxt_link.wire.errors import StreamError
    lose_reads = []

    def damage(_index: int, data: bytes) -> bytes:
        telegram = data[2:]
        return b"" if lose_reads and telegram[1:2] == b"\x13" else data  # MESSAGEREAD's reply
    s, brick = opened(rig, damage=damage)
    brick.stop_program()
    lose_reads.append(True)
    start = rig.clock.now()
    with pytest.raises(StreamError, match=r"^brick r1: the program cplus_follow\.rxe is no longer running$"):
        s.query()
    assert rig.clock.now() - start > 3.0  # found by the silence check, not by a reply


def test_a_silent_brick_whose_program_runs_is_a_link_timeout(rig):
    from nxt_link.wire.errors import LinkTimeoutError
    lose_reads = []

    def damage(_index: int, data: bytes) -> bytes:
        return b"" if lose_reads and data[3:4] == b"\x13" else data
    s, _ = opened(rig, damage=damage)
    lose_reads.append(True)
    last_valid = rig.clock.now()  # the WELCOME
    with pytest.raises(LinkTimeoutError, match=r"^brick r1: no valid answer from the brick program for 3 s$"):
        s.query()
    # on the virtual clock: given up after 3 s of silence, within one more try
    assert 3.0 < rig.clock.now() - last_valid <= 3.0 + 1.0


def test_a_decoder_with_a_larger_limit_reads_both_length_bytes():
    """The prefix is little-endian over both bytes (what the brick's 126 never shows)."""
    d = FrameDecoder(max_telegram=1000)
    telegram = bytes(range(256)) + bytes(44)
    assert frame_long(telegram)[:2] == b"\x2c\x01"
    assert d.feed(frame_long(telegram)) == [telegram] and d.stats.desyncs == 0
    assert d.feed(b"\xe9\x03" + bytes(1001)) == [] and d.stats.desyncs == 1  # 1001 > 1000


def frame_long(telegram: bytes) -> bytes:
    return struct.pack("<H", len(telegram)) + telegram


def test_a_partial_frame_is_stale_only_after_more_than_the_limit():
    d = FrameDecoder(stale_after_s=0.25)
    assert d.feed(frame(bytes(4))[:3], now=0.75) == []
    assert d.feed(b"", now=1.0) == [] and len(d.pending) == 3  # exactly 0.25 s: still assembling
    assert d.stats.stale_discards == 0
    assert d.feed(bytes(3), now=1.0) == [bytes(4)]


def test_discarded_bytes_are_counted():
    d = FrameDecoder(stale_after_s=0.25)
    d.feed(b"\x00\x00\x01\x02\x03")  # a desync: all five
    assert (d.stats.desyncs, d.stats.bytes_discarded) == (1, 5)
    d.feed(frame(bytes(10))[:7], now=1.0)
    d.feed(b"", now=2.0)  # stale: seven more
    assert (d.stats.stale_discards, d.stats.bytes_discarded) == (1, 12)
    d.reset()  # nothing buffered: nothing counted
    assert d.stats.bytes_discarded == 12 and d.stats.frames == 0
