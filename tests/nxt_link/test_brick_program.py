"""The brick program (its Python model) speaks the streaming protocol as documented."""
from __future__ import annotations

import pytest

from nxt_link.emulator.follower_program import FollowerProgram
from nxt_link.programs import stream_protocol as sp
from nxt_link.programs.stream_protocol import Code, State
from nxt_link.wire.errors import EmptyMailboxError

S = 4242  # session id used throughout


class Link:
    """Raw protocol access: write a request, read the brick's next response."""

    def __init__(self, rig, **kw) -> None:
        self.brick = rig.add("r1", **kw)
        self.emu = rig.emulators["r1"]
        self.clock = rig.clock

    def send(self, req: sp.Request, raw: bytes | None = None) -> None:
        self.brick.message_write(sp.CMD_INBOX, raw if raw is not None else sp.encode_request(req))

    def recv(self, wait_s: float = 0.05) -> sp.Response | None:
        self.clock.sleep(wait_s)  # one or more 10 ms program loops
        try:
            return sp.decode_response(self.brick.message_read(sp.RESPONSE_MAILBOX))
        except EmptyMailboxError:
            return None

    def ask(self, req: sp.Request) -> sp.Response | None:
        self.send(req)
        return self.recv()

    @property
    def program(self) -> FollowerProgram:
        p = self.emu.program
        assert p is not None
        return p


def config(seq: int = 1, ports=(0, 1), n_rows: int = 30, tick_ms: int = 50, lo=(-500, -500),
           hi=(500, 500), kp=(2, 1)) -> sp.Config:
    return sp.Config(S, seq, ports, n_rows, tick_ms, kp[0], kp[1], 100, 3, lo, hi)


@pytest.fixture
def link(rig) -> Link:
    return Link(rig)


def open_session(link: Link) -> sp.Welcome:
    w = link.ask(sp.Hello(S))
    assert isinstance(w, sp.Welcome)
    return w


def test_hello_opens_a_session(link):
    w = open_session(link)
    assert (w.session, w.version, w.code, w.expected_seq, w.max_values, w.state, w.control_ms) \
        == (S, sp.PROTOCOL_VERSION, Code.OK, 1, sp.MAX_VALUES, State.IDLE, sp.CONTROL_MS)


def test_wrong_version_is_refused(link):
    w = link.ask(sp.Hello(S, 0, version=9))
    assert isinstance(w, sp.Welcome) and w.code == Code.BAD_VERSION


def test_other_sessions_and_damaged_messages_get_no_answer(link):
    open_session(link)
    assert link.ask(sp.Query(S + 1, 0x8001)) is None
    raw = bytearray(sp.encode_request(sp.Query(S, 0x8002)))
    raw[3] ^= 0x40
    link.send(None, bytes(raw))
    assert link.recv() is None
    assert link.program.bad_messages == 2
    ack = link.ask(sp.Query(S, 0x8003))
    assert isinstance(ack, sp.Ack) and ack.seq == 0x8003


@pytest.mark.parametrize("bad, why", [
    (config(tick_ms=5), "tick below the control period"),
    (config(ports=(1, 1)), "the same port twice"),
    (config(ports=(0, 3)), "no port D"),
    (config(n_rows=1501), "1501 x 2 values exceed 3000"),
    (config(lo=(10, 0), hi=(5, 0)), "min above max"),
    (config(kp=(2, 0)), "division by zero gain"),
])
def test_bad_configurations_are_refused_and_not_applied(link, bad, why):
    open_session(link)
    ack = link.ask(bad)
    assert isinstance(ack, sp.Ack) and ack.code == Code.BAD_CONFIG, why
    assert ack.expected_seq == 1 and ack.state == State.IDLE


def test_sequenced_messages_apply_once_in_order(link):
    open_session(link)
    assert link.ask(config()).code == Code.OK
    rows = [(k, -k) for k in range(30)]
    chunk = lambda first, seq: sp.Setpoints(S, seq, first,  # noqa: E731
                                            tuple(v for r in rows[first:first + 12] for v in r))
    # a message ahead of the expected one is not applied (GAP)
    ack = link.ask(chunk(12, 3))
    assert (ack.code, ack.expected_seq, ack.rows_stored) == (Code.GAP, 2, 0)
    ack = link.ask(chunk(0, 2))
    assert (ack.code, ack.expected_seq, ack.rows_stored) == (Code.OK, 3, 12)
    # the same message again is acknowledged but not stored twice (DUPLICATE)
    ack = link.ask(chunk(0, 2))
    assert (ack.code, ack.expected_seq, ack.rows_stored) == (Code.DUPLICATE, 3, 12)
    # rows must follow on: first_row 24 while 12 are stored is refused
    ack = link.ask(chunk(24, 3))
    assert (ack.code, ack.expected_seq) == (Code.BAD_ORDER, 3)
    assert link.ask(chunk(12, 3)).code == Code.OK
    ack = link.ask(chunk(24, 4))
    assert (ack.code, ack.rows_stored, ack.state) == (Code.OK, 30, State.LOADED)
    assert link.program.reference_rows() == rows
    assert ack.checksum == sp.setpoint_checksum(v for r in rows for v in r)


def test_setpoints_outside_the_limits_are_refused_whole(link):
    open_session(link)
    link.ask(config(lo=(-100, -100), hi=(100, 100)))
    ack = link.ask(sp.Setpoints(S, 2, 0, (0, 0, 50, 101)))
    assert (ack.code, ack.rows_stored, ack.expected_seq) == (Code.OUT_OF_LIMITS, 0, 2)
    assert link.program.reference_rows() == []


def test_go_before_ready_is_refused(link):
    open_session(link)
    link.ask(config(n_rows=1))
    link.ask(sp.Setpoints(S, 2, 0, (0, 0)))
    ack = link.ask(sp.Go(S, 3, 0))
    assert ack.code == Code.BAD_STATE and ack.state == State.LOADED


def test_full_cycle_homing_delayed_start_log(link):
    open_session(link)
    rows = [(2 * k, -k) for k in range(20)]
    link.ask(config(n_rows=20, tick_ms=50))
    link.ask(sp.Setpoints(S, 2, 0, tuple(v for r in rows[:12] for v in r)))
    link.ask(sp.Setpoints(S, 3, 12, tuple(v for r in rows[12:] for v in r)))
    ack = link.ask(sp.Prepare(S, 4))
    assert ack.code == Code.OK
    assert link.ask(sp.Query(S, 0x8000)).state == State.READY  # already at row 0
    ack = link.ask(sp.Go(S, 5, 300))
    assert (ack.code, ack.state, ack.value) == (Code.OK, State.RUNNING, 300)  # echoes delay
    link.clock.sleep(0.2)
    assert link.ask(sp.Query(S, 0x8001)).logged == 0  # start time not reached yet
    link.clock.sleep(1.2)
    q = link.ask(sp.Query(S, 0x8002))
    assert q.state == State.DONE and q.logged == 20
    data = link.ask(sp.LogRead(S, 0x8003, 0, 11))
    assert isinstance(data, sp.LogData) and data.first_row == 0 and len(data.values) == 22
    measured = link.program.measured_rows()
    assert data.values == tuple(v for r in measured[:11] for v in r)
    # the motors followed: the last measured row is near the last reference
    assert abs(measured[-1][0] - 38) <= 6 and abs(measured[-1][1] + 19) <= 6
    ack = link.ask(sp.LogRead(S, 0x8004, 15, 11))
    assert isinstance(ack, sp.Ack) and ack.code == Code.BAD_RANGE


def test_stop_coasts_the_motors(link):
    open_session(link)
    link.ask(config(n_rows=1))
    link.ask(sp.Setpoints(S, 2, 0, (90, 0)))
    link.ask(sp.Prepare(S, 3))
    assert link.emu.firmware.outputs[0].power > 0  # homing drives motor A
    ack = link.ask(sp.Stop(S, 0x8000))
    assert ack.state == State.STOPPED
    out = link.emu.firmware.outputs[0]
    assert out.run_state == 0 and not out.mode & 0x01


class FakeHost:
    def __init__(self, counts: dict[int, int]) -> None:
        self.counts = counts
        self.calls: list[tuple[int, int, int]] = []
        self.now = 0

    def current_tick(self) -> int:
        return self.now

    def motor_rotation_count(self, port: int) -> int:
        return self.counts[port]

    def on_fwd_ex(self, port: int, power: int, reset: int) -> None:
        self.calls.append((port, power, reset))

    def coast_ex(self, port: int, reset: int) -> None:
        pass


@pytest.mark.parametrize("kp, err, power", [
    ((2, 1), 10, 20), ((3, 2), -5, -7), ((3, 2), 5, 7), ((2, 1), 80, 60), ((2, 1), -200, -60),
])
def test_control_law_is_integer_p_control_truncated_and_clamped(kp, err, power):
    p = FollowerProgram()
    p.nports, p.port, p.kp_num, p.kp_den, p.max_power = 1, [2, 0, 0], kp[0], kp[1], 60
    p.refs = [100]
    host = FakeHost({2: 100 - err})
    p._host = host
    p.control_row(0)
    # RESET_NONE: the program never resets a counter when it updates the power
    assert host.calls == [(2, power, 0)]
    assert p.max_err == abs(err)


def test_each_measured_row_is_sampled_when_its_tick_ends():
    p = FollowerProgram()
    p.nports, p.port, p.nrows, p.tick_ms = 1, [0, 0, 0], 3, 50
    p.refs, p.meas = [0, 0, 0], [0, 0, 0]
    p.state, p.t0 = State.RUNNING, 1000
    host = FakeHost({0: 0})
    p._host = host
    samples = {}
    for t in range(1000, 1200, sp.CONTROL_MS):
        host.now = t
        host.counts[0] = t  # the "angle" is the time, so each sample shows when it was taken
        p.control(t)
        for k in range(p.logged):
            samples.setdefault(k, p.meas[k])
    assert samples == {0: 1050, 1: 1100, 2: 1150}
    assert p.state == State.DONE
