"""Framing to the byte: the prefix, the decoder's counters and clock, and its exact refusals."""
from __future__ import annotations

import pytest

from nxt_link.wire.framing import MAX_TELEGRAM, DecoderStats, FrameDecoder, frame


def test_the_prefix_and_its_limits():
    assert MAX_TELEGRAM == 126
    assert frame(b"\x01") == b"\x01\x00\x01"
    assert frame(bytes(126))[:2] == b"\x7e\x00"
    with pytest.raises(ValueError, match=r"^telegram length 0 outside 1\.\.126$"):
        frame(b"")
    with pytest.raises(ValueError, match=r"^telegram length 127 outside 1\.\.126$"):
        frame(bytes(127))


def test_a_new_decoder():
    d = FrameDecoder()
    assert (d.stale_after_s, d.max_telegram, d.pending) == (0.25, 126, b"")
    assert d.stats == DecoderStats(0, 0, 0, 0)
    assert d.expire(1e9) is False


def test_the_counters_of_a_clean_stream():
    d = FrameDecoder()
    assert d.feed(frame(b"\x02\x0b") + frame(b"\x01") + b"\x03") == [b"\x02\x0b", b"\x01"]
    assert d.stats == DecoderStats(frames=2, desyncs=0, stale_discards=0, bytes_discarded=0)
    assert d.pending == b"\x03"


def test_a_frame_of_exactly_the_limit_and_one_more():
    d = FrameDecoder(max_telegram=3)
    assert d.feed(b"\x03\x00abc") == [b"abc"]
    assert d.feed(b"\x04\x00abcd") == [] and d.stats.desyncs == 1 and d.stats.bytes_discarded == 6


def test_the_stale_clock_starts_at_the_last_byte_and_stops_when_the_buffer_empties():
    d = FrameDecoder(stale_after_s=1.0)
    d.feed(b"\x05\x00ab", now=10.0)
    d.feed(b"c", now=10.8)             # a byte at 10.8 restarts the clock
    assert d.expire(11.7) is False and d.pending == b"\x05\x00abc"
    assert d.feed(b"", now=11.8) == [] and d.pending == b"\x05\x00abc"  # exactly 1 s: kept
    assert d.expire(11.81) is True and d.pending == b""
    assert d.stats.stale_discards == 1 and d.stats.bytes_discarded == 5
    # a complete frame leaves nothing pending, so no clock runs: a much later byte starts afresh
    assert d.feed(frame(b"x"), now=20.0) == [b"x"]
    assert d.feed(b"\x02\x00y", now=50.0) == [] and d.feed(b"z", now=50.5) == [b"yz"]
    assert d.stats.stale_discards == 1


def test_a_decoder_that_never_discards_a_partial_frame():
    d = FrameDecoder(stale_after_s=None)
    d.feed(b"\x05\x00ab", now=0.0)
    assert d.expire(1e9) is False and d.feed(b"cde", now=1e9) == [b"abcde"]


def test_reset_forgets_and_counts():
    d = FrameDecoder()
    d.feed(b"\x05\x00ab", now=3.0)
    d.reset()
    assert d.pending == b"" and d.stats.bytes_discarded == 4 and d.stats.stale_discards == 0
    assert d.expire(100.0) is False
    d.reset()
    assert d.stats.bytes_discarded == 4
