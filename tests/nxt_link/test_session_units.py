"""BrickSession step by step on one in-memory emulated brick: what each phase sends, reports
and returns, exactly, and the checks of its arguments."""
from __future__ import annotations

import pytest

from nxt_link import session as sess
from nxt_link import stream_protocol as sp
from nxt_link.errors import StreamError
from nxt_link.session import BrickSession, ControllerSettings, SessionTiming
from nxt_link.stream_protocol import State

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
