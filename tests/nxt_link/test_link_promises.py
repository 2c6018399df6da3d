"""The streaming link's numbers that the README promises (a window of 4, 10 s of silence, ticks
up to 10000 ms), held to the README's sentence and to what a session on an emulated brick does.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = " ".join(" ".join(p.read_text(encoding="utf-8") for p in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]).split())  # the README and docs/, lines joined


def says(pattern: str) -> re.Match[str]:
    m = re.search(pattern, README)
    assert m, f"the README no longer says {pattern!r}"
    return m


# -- the streaming session: a window of 4, 10 s of silence ----------------------------------------


def spied_session(rig, rows, **kw):
    """A session on an emulated brick that records, at every sequenced post, how many
    messages are out and not yet acknowledged, and at every LOGREAD, how many are out."""
    from nxt_link.host.session import BrickSession
    from nxt_link.programs import stream_protocol as sp
    s = BrickSession(rig.add("r1"), ("A",), 50, rows, ((-500, 500),), **kw)
    in_flight: list[int] = []
    log_reads_out: list[int] = []
    acked = [0]
    answered: set[int] = set()
    log_reads: set[int] = set()
    post, poll = s._post, s._poll

    def spy_post(req, **kw):
        if req.seq and req.kind in sp.SEQUENCED_KINDS:
            in_flight.append(req.seq - acked[0])
            # a window the mailbox cannot hold loses messages over and over: fail, not hang
            assert len(in_flight) <= 20 * len(rows), "the stream makes no progress"
        if isinstance(req, sp.LogRead):  # (no loss here, so no request is given up)
            log_reads.add(req.seq)
            log_reads_out.append(len(log_reads - answered))
        post(req, **kw)

    def spy_poll(**kw):
        resp = poll(**kw)
        if isinstance(resp, sp.Ack):
            acked[0] = max(acked[0], resp.expected_seq - 1)
        if resp is not None:
            answered.add(resp.seq)
        return resp

    s._post, s._poll = spy_post, spy_poll  # type: ignore[method-assign]
    return s, in_flight, log_reads_out


def test_the_stream_keeps_at_most_4_messages_unacknowledged(rig, wave):
    window = says(r"go-back-N, window (\d) < the mailbox depth of 5")
    from nxt_link.host.session import WINDOW
    assert WINDOW == int(window[1]) == 4
    rows = wave(240, (100,))
    s, in_flight, _ = spied_session(rig, rows)
    s.open()
    s.upload()
    assert len(in_flight) >= 10  # CONFIG and 10 SETPOINTS messages
    assert max(in_flight) == 4  # the window is used, and never exceeded
    assert rig.emulators["r1"].program.reference_rows() == list(rows)


def test_the_log_is_read_with_at_most_4_requests_out(rig, wave):
    from nxt_link.programs.stream_protocol import State
    rows = wave(150, (100,))
    s, _, out = spied_session(rig, rows)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    s.post_go(rig.clock.now())
    s.confirm_go()
    while s.poll_progress().state != State.DONE:
        rig.clock.sleep(0.25)
    out.clear()
    assert list(s.read_log()) == rig.emulators["r1"].program.measured_rows()
    assert len(out) >= 7 and max(out) == 4


def test_a_brick_is_given_up_after_10_s_without_a_valid_answer(rig):
    says(r"gives up only when a brick has sent nothing valid for 10 s \(counted from its last valid answer\)")
    from nxt_link.host.session import BrickSession, SessionTiming
    from nxt_link.wire.errors import LinkTimeoutError
    assert SessionTiming().max_silent_s == 10.0
    lost: list[bool] = []
    brick = rig.add("r1", damage=lambda _i, data: b"" if lost and data[3:4] == b"\x13" else data)
    s = BrickSession(brick, ("A",), 50, ((0,),), ((-500, 500),))  # the default timing
    s.open()
    lost.append(True)  # from here on, no MESSAGEREAD reply arrives
    last_valid = rig.clock.now()
    with pytest.raises(LinkTimeoutError, match=r"no valid answer from the brick program for 10 s$"):
        s.query()
    assert 10.0 < rig.clock.now() - last_valid <= 12.0  # on the virtual clock


@pytest.mark.parametrize("tick, accepted", [(10000, True), (10001, False), (10, True), (9, False)])
def test_the_brick_program_takes_ticks_from_10_to_10000_ms(rig, tick, accepted):
    says(r"a whole number of milliseconds from 10 to 10000")
    from nxt_link.host.session import BrickSession, SessionTiming
    from nxt_link.wire.errors import StreamError
    s = BrickSession(rig.add("r1"), ("A",), tick, ((0,), (1,)), ((-500, 500),),
                     timing=SessionTiming(max_silent_s=3.0))
    s.open()
    if accepted:
        s.upload()
        assert rig.emulators["r1"].program.tick_ms == tick
    else:
        with pytest.raises(StreamError, match="bad config"):
            s.upload()
