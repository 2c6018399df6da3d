"""Length-prefix framing: any read boundaries, desync and stale-frame recovery."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nxt_link.wire.framing import MAX_TELEGRAM, FrameDecoder, frame

telegrams = st.lists(st.binary(min_size=1, max_size=MAX_TELEGRAM), min_size=1, max_size=8)


@given(telegrams, st.lists(st.integers(0, 2000), max_size=20))
def test_any_split_of_any_sequence_gives_the_same_telegrams(items, cuts):
    stream = b"".join(frame(t) for t in items)
    points = sorted({c % (len(stream) + 1) for c in cuts})
    pieces = [stream[a:b] for a, b in zip([0] + points, points + [len(stream)])]
    decoder = FrameDecoder(stale_after_s=None)
    out = []
    for piece in pieces:
        out.extend(decoder.feed(piece))
    assert out == items
    assert decoder.pending == b""


def test_byte_by_byte_and_coalesced():
    items = [bytes.fromhex("02 0b 00 28 23"), bytes.fromhex("02 0d 00 c0 27 09 00")]
    stream = b"".join(frame(t) for t in items)
    d = FrameDecoder()
    got = [t for b in stream for t in d.feed(bytes([b]))]
    assert got == items
    assert FrameDecoder().feed(stream + stream) == items + items


@pytest.mark.parametrize("prefix", [b"\x00\x00", bytes([MAX_TELEGRAM + 1, 0]), b"\xff\xff"])
def test_impossible_length_discards_the_buffer_and_resyncs(prefix):
    d = FrameDecoder()
    assert d.feed(prefix + b"garbage") == []
    assert d.stats.desyncs == 1 and d.pending == b""
    assert d.feed(frame(b"\x02\x01\x00")) == [b"\x02\x01\x00"]


def test_truncated_frame_is_dropped_after_silence():
    d = FrameDecoder(stale_after_s=0.25)
    assert d.feed(frame(bytes(10))[:6], now=1.0) == []
    # more of the same frame in time: still assembling
    assert d.feed(b"", now=1.2) == [] and len(d.pending) == 6
    # the rest never came; a new frame after a silence is read cleanly
    assert d.feed(frame(b"\x02\x0b\x00\x28\x23"), now=1.6) == [b"\x02\x0b\x00\x28\x23"]
    assert d.stats.stale_discards == 1


def test_frame_refuses_impossible_lengths():
    with pytest.raises(ValueError):
        frame(b"")
    with pytest.raises(ValueError):
        frame(bytes(MAX_TELEGRAM + 1))
