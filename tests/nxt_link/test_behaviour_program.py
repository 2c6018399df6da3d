"""The Legolog brick program (its Python model) speaks the behaviour protocol as documented.

These tests play the PC by hand, message by message, so they can also be the PC that
stops answering (PANIC) or sends what a correct client never sends.
"""
from __future__ import annotations

from nxt_link import delivery_world
from nxt_link.emulator.emulator import BrickEmulator, EmulatorConfig, LinkParams
from nxt_link.emulator.legolog_program import LegologProgram
from nxt_link.emulator.memory_transport import MemoryTransport
from nxt_link.emulator.world import Landmark, Start, Track, WorldSpec
from nxt_link.host.brick import Brick
from nxt_link.programs import behaviour_protocol as bp
from nxt_link.programs.behaviour_protocol import AckCode, Behaviour, State, Status
from nxt_link.wire.clock import VirtualClock
from nxt_link.wire.errors import EmptyMailboxError

S = 4242


class Link:
    """Raw protocol access to an emulated delivery robot on a virtual clock."""

    def __init__(self, world: WorldSpec | None = None) -> None:
        self.clock = VirtualClock()
        self.emu = BrickEmulator(EmulatorConfig(name="robot", world=world or delivery_world(seed=5),
                                                link=LinkParams.instant()))
        self.brick = Brick(MemoryTransport(self.emu, self.clock), name="robot")
        self.clock.sleep(0.1)  # the program sets its sensors up

    def send(self, req: bp.Request) -> None:
        self.brick.message_write(bp.CMD_INBOX, bp.encode_request(req))

    def wait(self, seconds: float) -> None:
        """Let the brick run (nobody reads its mailbox meanwhile)."""
        self.clock.sleep(seconds)
        self.emu.advance_to(self.clock.now() * 1000.0)

    def recv(self, wait_s: float = 0.03) -> bp.Response | None:
        self.wait(wait_s)
        try:
            return bp.decode_response(self.brick.message_read(bp.RESPONSE_MAILBOX))
        except EmptyMailboxError:
            return None

    def drain(self) -> list[bp.Response]:
        out = []
        while (r := self.recv(0.0)) is not None:
            out.append(r)
        return out

    def ask(self, req: bp.Request) -> bp.Response | None:
        self.send(req)
        return self.recv()

    @property
    def program(self) -> LegologProgram:
        p = self.emu.legolog
        assert p is not None
        return p

    def open(self) -> bp.Welcome:
        w = self.ask(bp.Hello(S, 1))
        assert isinstance(w, bp.Welcome) and w.code == AckCode.OK
        return w

    def until_done(self, seq: int, limit_s: float = 30.0) -> tuple[bp.Done, list[bp.Response]]:
        """Read responses, answering MORE_TIME, until the DONE of ``seq``."""
        seen = []
        t_end = self.clock.now() + limit_s
        while self.clock.now() < t_end:
            r = self.recv(0.05)
            if r is None:
                continue
            seen.append(r)
            if isinstance(r, bp.MoreTime):
                self.send(bp.Cont(S, r.seq, r.part))
            if isinstance(r, bp.Done) and r.seq == seq:
                return r, seen
        raise AssertionError(f"no DONE of ACT {seq}: {seen}")


def test_hello_opens_a_session_and_reports_the_protocol():
    link = Link()
    w = link.open()
    assert (w.session, w.seq, w.version, w.last_act, w.action_ms) == (S, 1, 1, 0, bp.ACTION_MS)
    assert w.state == State.IDLE


def test_a_wrong_protocol_version_is_refused():
    link = Link()
    w = link.ask(bp.Hello(S, 1, version=9))
    assert isinstance(w, bp.Welcome) and w.code == AckCode.BAD_VERSION


def test_act_is_acknowledged_then_done_with_sensing_values():
    link = Link()
    link.open()
    ack = link.ask(bp.Act(S, 1, Behaviour.TRAY_UP))
    assert isinstance(ack, bp.Ack) and (ack.code, ack.behaviour, ack.state) == (
        AckCode.OK, Behaviour.TRAY_UP, State.RUNNING)
    done, _ = link.until_done(1)
    assert done.status == Status.OK and done.behaviour == Behaviour.TRAY_UP
    values = dict(done.values)
    assert abs(values[bp.Sense.TRAY] - 90) <= 3 and set(values) == {
        bp.Sense.LIGHT, bp.Sense.TOUCH, bp.Sense.TRAY}


def test_a_copy_of_an_act_is_never_run_twice_and_gets_its_done_again():
    link = Link()
    link.open()
    link.ask(bp.Act(S, 1, Behaviour.TRAY_UP))
    dup = link.ask(bp.Act(S, 1, Behaviour.TRAY_UP))  # still running
    assert isinstance(dup, bp.Ack) and dup.code == AckCode.DUPLICATE
    done, _ = link.until_done(1)
    link.send(bp.Act(S, 1, Behaviour.TRAY_UP))  # after it finished: ACK and the same DONE
    again = [link.recv(), link.recv()]
    assert isinstance(again[0], bp.Ack) and again[0].code == AckCode.DUPLICATE
    assert again[1] == done
    assert link.program.started == [(1, Behaviour.TRAY_UP)]


def test_gap_busy_and_stale_acts_are_refused():
    link = Link()
    link.open()
    gap = link.ask(bp.Act(S, 3, Behaviour.TURN))
    assert isinstance(gap, bp.Ack) and gap.code == AckCode.GAP
    link.ask(bp.Act(S, 1, Behaviour.WAIT_BUTTON))
    busy = link.ask(bp.Act(S, 2, Behaviour.TURN))
    assert isinstance(busy, bp.Ack) and busy.code == AckCode.BUSY
    assert link.program.started == [(1, Behaviour.WAIT_BUTTON)]


def test_bad_requests_are_refused_or_ignored():
    link = Link()
    link.open()
    unknown = link.ask(bp.Act(S, 1, 42))
    assert isinstance(unknown, bp.Ack) and unknown.code == AckCode.UNKNOWN_BEHAVIOUR
    # the refused number is used up; a copy of it gets the same refusal
    assert link.ask(bp.Act(S, 1, 42)).code == AckCode.UNKNOWN_BEHAVIOUR  # type: ignore[union-attr]
    bad = link.ask(bp.Act(S, 2, Behaviour.FOLLOW, (601,)))
    assert isinstance(bad, bp.Ack) and bad.code == AckCode.BAD_ARGS
    # damaged, other session: silently ignored
    raw = bytearray(bp.encode_request(bp.Act(S, 3, Behaviour.TURN)))
    raw[5] ^= 0xFF
    link.brick.message_write(bp.CMD_INBOX, bytes(raw))
    assert link.recv() is None
    assert link.ask(bp.Act(S + 1, 3, Behaviour.TURN)) is None
    assert link.program.started == []
    assert link.program.bad_messages == 2


def test_more_time_every_three_seconds_while_answered():
    link = Link()
    link.open()
    link.ask(bp.Act(S, 1, Behaviour.WAIT_BUTTON, (8,)))
    done, seen = link.until_done(1)
    more = [r for r in seen if isinstance(r, bp.MoreTime)]
    assert [m.part for m in more] == [1, 2]
    assert [round(m.elapsed_ms / 100) for m in more] == [30, 60]
    assert done.elapsed_ms == 8000 and dict(done.values)[bp.Sense.TOUCH] == 0


def test_the_brick_panics_when_the_pc_stops_acknowledging_and_only_abort_ends_it():
    # landmark 2 is 6 m away: half a minute of line following
    link = Link(WorldSpec(track=Track(((0.0, 0.0), (7000.0, 0.0))),
                          landmarks=(Landmark(1, 400.0), Landmark(2, 6500.0)),
                          start=Start(landmark=1), seed=5))
    link.open()
    link.ask(bp.Act(S, 1, Behaviour.FOLLOW, (60,)))
    started = link.program.act_t0 / 1000.0
    link.wait(1.0)
    assert link.emu.world is not None and link.emu.world.position_mm > 500  # driving
    # nobody answers MORE_TIME: copies at 3, 6.5 and 10 s, PANIC at 13.5 s
    link.wait(started + 13.4 - link.clock.now())
    assert link.program.status != 2
    link.wait(0.2)
    assert link.program.status == 2
    copies = link.drain()
    mores = [r for r in copies if isinstance(r, bp.MoreTime)]
    assert [m.part for m in mores] == [1, 1, 1] and len(mores) == bp.MAX_SENDS
    assert any(isinstance(r, bp.Panic) for r in copies)
    # motors released, the robot stops; it beeps and repeats PANIC every second
    fw = link.emu.firmware
    assert all(not fw.outputs[p].mode & 0x01 for p in (0, 1, 2))
    here = link.emu.world.position_mm
    tones = len(fw.tones)
    link.wait(3.0)
    assert abs(link.emu.world.position_mm - here) < 30
    assert len(fw.tones) >= tones + 3
    panics = [r for r in link.drain() if isinstance(r, bp.Panic)]
    assert panics and all(p.state == State.PANIC and p.behaviour == Behaviour.FOLLOW
                          and p.aborts == 0 for p in panics)
    # everything but ABORT is ignored
    link.send(bp.Hello(S + 1, 2))
    link.send(bp.Exog(S, 3, 0))
    link.send(bp.Act(S, 2, Behaviour.TURN))
    link.wait(1.5)
    ignored = link.drain()
    assert ignored and all(isinstance(r, bp.Panic) for r in ignored)
    assert link.program.started == [(1, Behaviour.FOLLOW)]
    # ABORT, even from another session, ends it
    link.send(bp.Abort(S + 7, 0x9000))
    answers = link.drain() + [link.recv()]
    aborted = [r for r in answers if isinstance(r, bp.Aborted)]
    assert len(aborted) == 1 and (aborted[0].seq, aborted[0].session, aborted[0].aborts,
                                  aborted[0].state) == (0x9000, S + 7, 1, State.IDLE)
    assert link.program.status == 0
    link.wait(2.0)
    assert not [r for r in link.drain() if isinstance(r, bp.Panic)]
    # and the session goes on
    ack = link.ask(bp.Act(S, 2, Behaviour.TRAY_UP))
    assert isinstance(ack, bp.Ack) and ack.code == AckCode.OK


def test_abort_stops_a_running_behaviour():
    link = Link()
    link.open()
    link.ask(bp.Act(S, 1, Behaviour.FOLLOW))
    link.wait(0.5)
    link.send(bp.Abort(S, 0x8001))
    r = link.recv()
    assert isinstance(r, bp.Aborted) and r.last_act == 1 and r.state == State.IDLE
    assert link.program.running == 0
    # no DONE for the aborted act, not even for a copy of it
    link.send(bp.Act(S, 1, Behaviour.FOLLOW))
    assert [type(x) for x in link.drain() + [link.recv()] if x is not None] == [bp.Ack]


def test_events_are_kept_until_acknowledged():
    link = Link()
    link.open()
    world = link.emu.world
    assert world is not None
    none = link.ask(bp.Exog(S, 0x8001, 0))
    assert isinstance(none, bp.NoEvents) and none.next_event == 1
    for _ in range(3):
        world.press(0.2)
        link.wait(0.5)
    ev = link.ask(bp.Exog(S, 0x8002, 0))
    assert isinstance(ev, bp.Events) and ev.first == 1 and ev.events == ((1, ()),) * 3
    again = link.ask(bp.Exog(S, 0x8003, 0))  # answer lost: the same events again
    assert again is not None and isinstance(again, bp.Events) and again.events == ev.events
    ack = link.ask(bp.Exog(S, 0x8004, 3))
    assert isinstance(ack, bp.NoEvents) and ack.next_event == 4


def test_a_full_event_queue_counts_what_it_drops():
    link = Link()
    link.open()
    world = link.emu.world
    assert world is not None
    for _ in range(bp.EVENT_SLOTS + 2):
        world.press(0.05)
        link.wait(0.15)
    first = link.ask(bp.Exog(S, 0x8001, 0))
    assert isinstance(first, bp.Events) and first.lost == 2
    assert len(first.events) == bp.MAX_EVENTS_PER_MESSAGE
    second = link.ask(bp.Exog(S, 0x8002, first.first + len(first.events) - 1))
    assert isinstance(second, bp.Events) and second.first == 9 and len(second.events) == 8


def test_a_press_while_waiting_is_the_behaviours_not_an_event():
    link = Link()
    link.open()
    link.ask(bp.Act(S, 1, Behaviour.WAIT_BUTTON))
    world = link.emu.world
    assert world is not None
    world.press(0.2)
    done, _ = link.until_done(1)
    assert dict(done.values)[bp.Sense.TOUCH] == 1
    assert isinstance(link.ask(bp.Exog(S, 0x8001, 0)), bp.NoEvents)


def test_a_new_session_stops_the_old_ones_behaviour():
    link = Link()
    link.open()
    link.ask(bp.Act(S, 1, Behaviour.FOLLOW))
    link.wait(0.3)
    w = link.ask(bp.Hello(S + 1, 9))
    assert isinstance(w, bp.Welcome) and w.last_act == 0 and w.state == State.IDLE
    assert link.program.running == 0
