"""Every kind of damaged reply, at a fixed place, through the in-memory transport.

The brick's replies carry no checksum, so a damaged one must be recognised (wrong length, not
a reply, another opcode, an unknown or implausible status, a wrong echo, a broken length
prefix, a mailbox message whose CRC fails) and treated like a lost one: asked again, with the
same timeouts and the same give-up time. Each test damages a third of the frames the brick
sends, chosen by a seeded generator (an exactly periodic choice would lock onto the rhythm of
the requests and damage the same answer every time), on a virtual clock: every run is the
same. The execution must still deliver exactly the setpoints sent and read back exactly what
the bricks measured.
"""
from __future__ import annotations

import random
from collections.abc import Callable

import pytest

from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming
from nxt_link.wire.framing import frame
from nxt_link.wire.telegram import error_reply

TIMING = SessionTiming(ack_timeout_s=0.3, max_silent_s=5.0, homing_timeout_s=3.0)
OPTIONS = ExecutionOptions(timing=TIMING)
MESSAGE_READ = 0x13


def _telegram(data: bytes) -> bytes:
    return data[2:]


def _is_message(data: bytes) -> bool:
    """A MESSAGEREAD reply that carries a message (status 0)."""
    return len(data) > 5 and data[3] == MESSAGE_READ and data[4] == 0


def _status(value: int) -> Callable[[bytes], bytes]:
    return lambda d: d[:4] + bytes((value,)) + d[5:]


KINDS: dict[str, tuple[Callable[[bytes], bytes], bool, str]] = {
    # name: (damage, only on MESSAGEREAD replies carrying a message, event expected)
    "unknown status 0x72": (_status(0x72), False, "damaged reply"),
    "status the command cannot get (C0)": (_status(0xC0), False, "damaged reply"),
    "a 'no program' status the brick does not confirm": (
        lambda d: frame(error_reply(MESSAGE_READ, 0xEC)), True, "damaged reply"),
    "an 'empty mailbox' status hiding a message": (_status(0x40), True, "damaged reply"),
    "one byte short": (lambda d: frame(_telegram(d)[:-1]), False, "damaged reply"),
    "one byte too long": (lambda d: frame(_telegram(d) + b"\0"), False, "damaged reply"),
    "unknown opcode": (lambda d: d[:3] + b"\xd8" + d[4:], False, "damaged reply"),
    "a reply to another opcode": (lambda d: frame(bytes.fromhex("02 0b 00 28 23")), False,
                                  "stale reply"),
    "not a reply": (lambda d: d[:2] + b"\x01" + d[3:], False, "damaged reply"),
    "wrong local inbox echoed": (lambda d: d[:5] + b"\x07" + d[6:], True, "damaged reply"),
    "mailbox message damaged (CRC)": (lambda d: d[:9] + bytes((d[9] ^ 0x5A,)) + d[10:], True,
                                      "damaged response"),
    "length prefix one too long": (lambda d: bytes((d[0] + 1,)) + d[1:], False, "timeout"),
    "length prefix zero": (lambda d: b"\0\0" + d[2:], False, "timeout"),
    "length prefix impossible": (lambda d: b"\xff\x00" + d[2:], False, "timeout"),
    "lost": (lambda d: b"", False, "timeout"),
    "delivered twice": (lambda d: d + d, False, None),
}


def a_third(damage: Callable[[bytes], bytes], messages_only: bool, hits: list[int], seed: int
            ) -> Callable[[int, bytes], bytes]:
    rng = random.Random(seed)

    def hook(index: int, data: bytes) -> bytes:
        if messages_only and not _is_message(data):
            return data
        if rng.random() >= 1 / 3:
            return data
        hits.append(index)
        return damage(data)
    return hook


def streams(wave) -> list[SetpointStream]:
    return [SetpointStream("r1", ("A", "B"), 50, wave(40, (120, 90))),
            SetpointStream("r2", ("A", "B", "C"), 50, wave(40, (-100, 45, 30)))]


@pytest.mark.parametrize("kind", list(KINDS))
def test_each_kind_of_damaged_reply_is_asked_again(rig, wave, kind):
    damage, messages_only, event = KINDS[kind]
    hits: dict[str, list[int]] = {"r1": [], "r2": []}
    for seed, name in enumerate(("r1", "r2")):
        rig.add(name, damage=a_third(damage, messages_only, hits[name], seed))
    log = execute_streams(streams(wave), rig.bricks, options=OPTIONS)
    for stream in streams(wave):
        program = rig.emulators[stream.brick].program
        assert len(hits[stream.brick]) >= 5  # the damage did happen, several times
        # exactly the setpoints sent, in order; exactly what the brick measured
        assert program.reference_rows() == list(stream.rows)
        b = log.brick(stream.brick)
        assert b.measured_deg == tuple(program.measured_rows())
        if event is not None:
            assert event in {e.event for e in b.events}
    assert log.complete


def test_damage_of_the_last_valid_frame_kind_does_not_end_the_run_with_its_status(rig, wave):
    """The issue's failure: 'MESSAGE_READ failed: brick status 0x72' ended an execution."""
    hits: list[int] = []
    for seed, name in enumerate(("r1", "r2")):
        rig.add(name, damage=a_third(_status(0x72), True, hits, seed))
    log = execute_streams(streams(wave), rig.bricks, options=OPTIONS)
    assert log.complete and hits
