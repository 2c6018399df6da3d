"""BrickSession step by step on one in-memory emulated brick: what each phase sends, reports
and returns, exactly, and the checks of its arguments."""
from __future__ import annotations

import pytest

from nxt_link.host import session as sess
from nxt_link.host.session import BrickSession, ControllerSettings, SessionTiming
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import State
from nxt_link.wire.errors import StreamError

TIMING = SessionTiming(ack_timeout_s=0.3, max_silent_s=3.0)
ROWS = tuple((k, -k) for k in range(0, 60, 2))  # 30 rows of two ports


def new_session(rig, rows=ROWS, **kw):
    brick = rig.add("r1")
    events: list[tuple[str, str]] = []
    kw.setdefault("session_id", 4242)
    s = BrickSession(brick, ("A", "C"), 50, rows, ((-500, 500), (-400, 400)), timing=TIMING,
                     on_event=lambda e, d: events.append((e, d)), **kw)
    return s, events


def test_every_phase_of_a_clean_execution(rig):
    s, events = new_session(rig)
    assert (s.phase, s.go_sent, s.state, s.logged, s.start_window) == ("connect", False, None, 0, None)
    welcome = s.open()
    assert (welcome.session, welcome.state, welcome.expected_seq) == (4242, State.IDLE, 1)
    assert s.state == State.IDLE and s.phase == "connect"
    upload: list[tuple[int, int]] = []
    s.upload(lambda done, total: upload.append((done, total)))
    assert upload == [(0, 30), (12, 30), (24, 30), (30, 30)]  # CONFIG, then 12 rows a message
    assert s.phase == "upload" and s.retransmissions == 0
    emu = rig.emulators["r1"]
    assert emu.program.reference_rows() == list(ROWS)
    s.prepare()
    assert s.phase == "homing"
    s.wait_ready()
    assert s.state == State.READY
    t = rig.clock.now()
    s.post_go(t + 0.5)
    assert s.phase == "start" and s.go_sent
    latest = s.confirm_go()
    assert s.phase == "run" and latest >= t + 0.5
    lo, hi = s.start_window
    assert t + 0.5 - 0.001 <= lo <= hi <= latest
    while s.poll_progress().state != State.DONE:
        rig.clock.sleep(0.25)
    assert s.logged == 30 and s.state == State.DONE
    log: list[tuple[int, int]] = []
    first = s.read_log(lambda done, total: log.append((done, total)), rows=7)
    assert first == tuple(tuple(r) for r in emu.program.measured_rows()[:7]) and log == [(7, 7)]
    assert s.phase == "log" and sorted(s.log_rows) == list(range(7))
    log.clear()
    rows = s.read_log(lambda done, total: log.append((done, total)))
    assert rows == tuple(tuple(r) for r in emu.program.measured_rows()) and len(rows) == 30
    assert log == [(11, 30), (22, 30), (30, 30)]  # 11 rows a LOGDATA, the first 7 kept
    assert s.phase == "done"
    assert s.read_log(rows=-3) == () and s.read_log(rows=99) == rows
    assert s.stop() and s.phase == "stopped"
    assert events == [
        ("link ok", "session 4242, program protocol v1"),
        ("upload verified", f"30 rows, checksum 0x{sp.setpoint_checksum(v for r in ROWS for v in r):04X}, "
                            "0 retransmission(s)"),
        ("homing", "to (0, 0)"),
        ("ready", "largest error 0 deg"),
        ("start sent", f"GO seq 6, start in 500 ms ({sess.GO_COPIES} copies)"),
        ("start acked", "GO seq 6, applied the copy with 500 ms delay"),
        ("log read", "7 rows; 0 message(s) sent again and 0 damaged response(s) in all"),
        ("log read", "30 rows; 0 message(s) sent again and 0 damaged response(s) in all"),
        ("log read", "0 rows; 0 message(s) sent again and 0 damaged response(s) in all"),
        ("log read", "30 rows; 0 message(s) sent again and 0 damaged response(s) in all"),
        ("stopped", "30 rows logged"),
    ]


def test_the_start_delay_is_clamped_to_what_the_brick_can_echo(rig):
    s, events = new_session(rig)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    now = rig.clock.now()
    s.post_go(now - 5.0, copies=1)
    assert events[-1] == ("start sent", "GO seq 6, start in 0 ms")
    s.post_go(now + 100.0, copies=2)
    assert events[-1] == ("start sent", "GO seq 6, start in 30000 ms (2 copies)")
    assert sess.MAX_GO_DELAY_MS == 30000


def test_a_brick_clock_running_faster_gets_a_scaled_delay(rig):
    s, events = new_session(rig, time_scale=4.0)
    assert s._brick_ms(0.25) == 1000 and s._brick_ms(0.0004) == 2
    with pytest.raises(ValueError, match="^time_scale must be > 0$"):
        new_session(rig, time_scale=0.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"kp_num": 0}, "controller gain: kp_num and kp_den must be in 1..255"),
    ({"kp_num": 256}, "controller gain: kp_num and kp_den must be in 1..255"),
    ({"kp_den": 0}, "controller gain: kp_num and kp_den must be in 1..255"),
    ({"kp_den": 256}, "controller gain: kp_num and kp_den must be in 1..255"),
    ({"max_power": 0}, "controller max_power must be in 1..100"),
    ({"max_power": 101}, "controller max_power must be in 1..100"),
    ({"tolerance_deg": -1}, "controller tolerance must be in 0..255 degrees"),
    ({"tolerance_deg": 256}, "controller tolerance must be in 0..255 degrees"),
])
def test_controller_settings_out_of_range(kwargs, message):
    with pytest.raises(ValueError) as info:
        ControllerSettings(**kwargs)
    assert str(info.value) == message


def test_controller_settings_at_their_limits_and_defaults():
    ControllerSettings(kp_num=1, kp_den=1, max_power=1, tolerance_deg=0)
    ControllerSettings(kp_num=255, kp_den=255, max_power=100, tolerance_deg=255)
    assert ControllerSettings() == ControllerSettings(2, 1, 100, 3)
    assert SessionTiming() == SessionTiming(0.6, 0.01, 0.25, 10.0, 15.0, 5.0, 0.05)


def test_the_config_carries_the_controller_and_limits(rig):
    s, _ = new_session(rig, controller=ControllerSettings(3, 2, 80, 5))
    config, *setpoints = s._messages()
    assert config == sp.Config(4242, 0, (0, 2), 30, 50, 3, 2, 80, 5, (-500, -400), (500, 400))
    assert [(m.first_row, len(m.values)) for m in setpoints] == [(0, 24), (12, 24), (24, 12)]
    assert setpoints[1].values[:4] == (24, -24, 26, -26)


def test_unsequenced_ids_wrap_within_their_range(rig):
    s, _ = new_session(rig)
    assert s._new_id() == 0x8001
    s._next_id = 0x8000 + 0x7FFE
    assert s._new_id() == 0x8000
    assert s._new_id() == 0x8001


def test_a_random_session_id_is_in_range(rig):
    s, _ = new_session(rig, session_id=None)
    assert 1 <= s.session <= 0xFFFF


def test_refusals_and_states_are_named():
    req = sp.Setpoints(1, 3, 48, (1, 2))
    assert sess._refusal("r1", req, sp.Code.BAD_VERSION) == "brick r1 refused SETPOINTS from row 48: bad version"
    assert sess._refusal("r2", sp.Prepare(1, 2), 99) == "brick r2 refused PREPARE: code 99"
    assert sess._state_name(State.HOMING) == "HOMING" and sess._state_name(77) == "77"


def test_a_brick_running_another_program_is_taken_over_only_when_asked(rig):
    brick = rig.add("r1", start_program="cplus_legolog.rxe")
    s = BrickSession(brick, ("A",), 50, ((0,),), ((-5, 5),), timing=TIMING, session_id=7)
    with pytest.raises(StreamError) as info:
        s.open()
    assert str(info.value) == ("brick r1 is running 'cplus_legolog.rxe', not 'cplus_follow.rxe'; "
                               "stop it on the brick first")
    assert s.open(replace_program=True).session == 7
    assert rig.emulators["r1"].firmware.program_name == sp.PROGRAM_NAME
    assert sess.PORT_NUMBERS == {"A": 0, "B": 1, "C": 2} and sess.WINDOW == 4


# -- recovery, with the brick's own messages dropped or rewritten on the way ---------------------


def drop_writes(brick, *, when):
    """Lose the PC's mailbox writes for which ``when(request)`` holds (each at most once)."""
    write = brick.message_write
    dropped: list[sp.Request] = []

    def lossy(inbox, message, *, reply=True):
        req = sp.decode_request(message)
        if when(req) and req not in dropped:
            dropped.append(req)
            return None
        return write(inbox, message, reply=reply)
    brick.message_write = lossy
    return dropped


def test_a_gap_before_anything_was_acknowledged_goes_back_at_once(rig):
    """CONFIG lost: the brick answers the first SETPOINTS with GAP, and the client sends
    everything again from CONFIG at once, not after an empty mailbox or a timeout says so."""
    s, events = new_session(rig)
    s.open()
    dropped = drop_writes(s.brick, when=lambda r: isinstance(r, sp.Config))
    start = rig.clock.now()
    s.upload()
    assert len(dropped) == 1 and s.retransmissions == 1
    assert rig.clock.now() - start < TIMING.empty_after_s  # before an empty mailbox would tell
    assert rig.emulators["r1"].program.reference_rows() == list(ROWS)


def test_a_lost_last_message_is_sent_again_after_the_timeout(rig):
    s, events = new_session(rig)
    s.open()
    dropped = drop_writes(s.brick, when=lambda r: isinstance(r, sp.Setpoints) and r.first_row == 24)
    s.upload()
    assert len(dropped) == 1 and s.retransmissions == 1
    assert events[-1][1].endswith(", 1 retransmission(s)")


def test_the_start_window_is_the_acknowledged_copy_s_bounds(rig):
    s, events = new_session(rig)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    t = rig.clock.now()
    s.post_go(t + 0.5)
    latest = s.confirm_go()
    acked = rig.clock.now()
    # started at T (+ the copy's one-way delay, at most until the ack), give or take a 1 ms tick
    assert acked < t + 0.5  # acknowledged before the start time
    assert s.start_window == pytest.approx((t + 0.5 - 0.001, t + 0.5 + (acked - t) + 0.001), abs=1e-9)
    assert latest == s.start_window[1]
    assert s.start_window[0] <= rig.emulators["r1"].program.t0 / 1000 <= s.start_window[1]


def test_a_lost_go_is_sent_again_as_one_copy(rig):
    s, events = new_session(rig)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    drop_writes(s.brick, when=lambda r: isinstance(r, sp.Go) and r.delay_ms == 500)
    copies = []
    write = s.brick.message_write

    def counting(inbox, message, *, reply=True):
        if isinstance(sp.decode_request(message), sp.Go):
            copies.append(rig.clock.now())
        return write(inbox, message, reply=reply)
    s.brick.message_write = counting
    t = rig.clock.now()
    s.post_go(t + 0.5, copies=1)
    s.confirm_go()
    sent = [d for e, d in events if e == "start sent"]
    assert sent[0] == "GO seq 6, start in 500 ms" and len(sent) >= 2
    assert all(not d.endswith("copies)") for d in sent)
    assert len(copies) == len(sent) and s.retransmissions == len(sent) - 1
    # before the start time a copy goes out every GO_RESEND_S, not every query interval
    assert copies[1] - copies[0] <= sess.GO_RESEND_S + 2 * TIMING.poll_gap_s < TIMING.query_interval_s


def test_progress_reports_narrow_the_start_window(rig):
    """``logged`` rows at a moment in [sent, answered]: t0 in (sent - (logged + 1) tick - slack,
    answered - logged tick]; with 50 ms ticks and a 20 ms slack (two control steps)."""
    s, events = new_session(rig)
    s._go_window = (10.0, 10.2)
    s.start_window = s._go_window
    s._narrow_start(10.2, 10.21, 0)             # nothing logged yet: only the lower bound moves
    assert s.start_window == pytest.approx((10.13, 10.2))
    s.start_window = s._go_window
    s._narrow_start(10.2, 10.21, 1)
    assert s.start_window == pytest.approx((10.08, 10.16))
    s.start_window = s._go_window
    s._narrow_start(11.6, 11.61, 30)            # all logged: only the upper bound moves
    assert s.start_window == pytest.approx((10.0, 10.11))
    assert events == []


def test_progress_reports_that_contradict_the_clock_fall_back_to_the_start_signal(rig):
    s, events = new_session(rig)
    s._go_window = (10.0, 10.2)
    s.start_window = (10.05, 10.15)
    s._narrow_start(10.5, 10.51, 1)             # t0 > 10.38 but <= 10.15: cannot be
    assert s.start_window == (10.0, 10.2)
    assert events == [("start window", "progress reports disagree with the clock; using the start signal's bound")]
    events.clear()
    s._narrow_start(100.0, 100.01, 1)          # contradicts the start signal itself: kept, no event
    assert s.start_window == (10.0, 10.2) and events == []
    s._go_window = None
    s._narrow_start(10.2, 10.21, 1)             # before GO was acknowledged: nothing to narrow
    assert s.start_window == (10.0, 10.2)


def test_a_busy_session_id_is_given_up_for_the_next(rig):
    """A HELLO with the brick's current session id finds it busy: the client takes the next id,
    wrapping from 65535 to 1."""
    s, _ = new_session(rig, session_id=0xFFFF)
    s.open()
    s.upload()
    again = BrickSession(s.brick, ("A", "C"), 50, ROWS, ((-500, 500), (-400, 400)), timing=TIMING,
                         session_id=0xFFFF)
    assert again.open().session == 1 and again.session == 1
    third = BrickSession(s.brick, ("A", "C"), 50, ROWS, ((-500, 500), (-400, 400)), timing=TIMING,
                         session_id=1)
    assert third.open().session == 1  # the brick's session 1 is still idle: no need to move


def test_a_brick_sending_more_log_rows_than_asked_gets_only_those_kept(rig):
    s, _ = new_session(rig)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    s.post_go(rig.clock.now() + 0.1)
    s.confirm_go()
    while s.poll_progress().state != State.DONE:
        rig.clock.sleep(0.25)
    read = s.brick.message_read

    def generous(remote, local=0, remove=True):
        raw = read(remote, local, remove)
        resp = sp.decode_response(raw)
        if isinstance(resp, sp.LogData):
            raw = sp.encode_response(sp.LogData(resp.session, resp.seq, resp.state, resp.first_row,
                                                resp.values + (99, 99)))
        return raw
    s.brick.message_read = generous
    assert len(s.read_log(rows=7)) == 7 and sorted(s.log_rows) == list(range(7))


def test_every_mailbox_read_asks_for_local_inbox_0(rig):
    echoed = set()

    def watch(_index, data):
        if len(data) > 5 and data[3] == 0x13:
            echoed.add(data[5])
        return data
    brick = rig.add("r1", damage=watch)
    s = BrickSession(brick, ("A",), 50, ((0,), (1,)), ((-5, 5),), timing=TIMING, session_id=3)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    s.post_go(rig.clock.now() + 0.1)
    s.confirm_go()
    assert echoed == {0}


def test_settings_are_values():
    for cls in (ControllerSettings, SessionTiming):
        assert cls.__dataclass_params__.frozen and "__slots__" in vars(cls)


def test_before_the_start_time_go_is_sent_again_every_go_resend_s(rig):
    """GO lost and the mailbox reads timing out (so no empty mailbox tells): the next copy
    still goes out after GO_RESEND_S, not only after the query interval."""
    lose_reads = []

    def damage(_index, data):
        return b"" if lose_reads and data[3:4] == b"\x13" else data
    brick = rig.add("r1", damage=damage)
    s = BrickSession(brick, ("A",), 50, ((0,), (1,)), ((-5, 5),), timing=TIMING, session_id=3)
    s.open()
    s.upload()
    s.prepare()
    s.wait_ready()
    drop_writes(brick, when=lambda r: isinstance(r, sp.Go) and r.delay_ms == 1000)
    copies = []
    write = brick.message_write

    def counting(inbox, message, *, reply=True):
        if isinstance(sp.decode_request(message), sp.Go):
            copies.append(rig.clock.now())
            if len(copies) == 2:
                lose_reads.clear()
        return write(inbox, message, reply=reply)
    brick.message_write = counting
    lose_reads.append(True)
    s.post_go(rig.clock.now() + 1.0, copies=1)
    s.confirm_go()
    assert sess.GO_RESEND_S < copies[1] - copies[0] < TIMING.query_interval_s
