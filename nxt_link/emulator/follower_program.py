"""Model of the brick program ``nxc/cplus_follow.nxc``, run by the emulated firmware.

A line-by-line port of the NXC source: same constants, same byte parsing and
validation order, same responses, same integer control law
(``power = kp_num * err / kp_den`` truncated toward zero, clamped to
``max_power``, applied with ``OnFwdEx(port, power, RESET_NONE)``), same fixed
``CONTROL_MS`` loop (handle up to 5 messages, then one control step), same
tick bookkeeping (the measured angle of row k is the RotationCount at the
first control step after tick k ended). Only the LCD output is left out. The
firmware calls :meth:`FollowerProgram.step` once per millisecond; the loop
body runs when the NXC ``Wait`` would have returned.

Keeping the two in step is a test: ``tests/nxt_link/test_nxc_program.py``
compares the NXC ``#define`` values with this module's constants.
"""
from __future__ import annotations

from nxt_link.emulator.firmware import ProgramHost
from nxt_link.emulator.output_module import RESET_NONE
from nxt_link.emulator.program_bytes import MessageBytes, div
from nxt_link.programs.stream_protocol import (
    CMD_INBOX,
    CONTROL_MS,
    LOG_VALUES_PER_MESSAGE,
    MAX_PORTS,
    MAX_VALUES,
    PROTOCOL_VERSION,
    Code,
    Kind,
    State,
    crc16,
)

__all__ = ["FollowerProgram", "MAX_BATCH"]

#: Messages handled per loop iteration (the inbox depth).
MAX_BATCH = 5


class FollowerProgram(MessageBytes):
    """State of one run of ``cplus_follow.rxe`` (globals of the NXC program)."""

    def __init__(self) -> None:
        super().__init__()
        self.session = -1
        self.expected = 1
        self.state = State.IDLE
        self.nports = 0
        self.port = [0] * MAX_PORTS
        self.nrows = 0
        self.tick_ms = 50
        self.kp_num = 3
        self.kp_den = 1
        self.max_power = 100
        self.tolerance = 3
        self.min_deg = [0] * MAX_PORTS
        self.max_deg = [0] * MAX_PORTS
        self.rows_stored = 0
        self.logged = 0
        self.ck = 0xFFFF
        self.t0 = 0
        self.max_err = 0
        self.go_delay = 0
        self.refs: list[int] = []
        self.meas: list[int] = []
        self._next: int | None = None

    # -- the task main() loop ---------------------------------------------------

    def step(self, host: ProgramHost) -> None:
        """One VM millisecond: run the loop body when the previous Wait has elapsed."""
        now = host.current_tick()
        if self._next is None:
            self._next = now  # unsigned long next = CurrentTick();
        if now < self._next:
            return
        self._host = host
        for _ in range(MAX_BATCH):
            status, message = host.receive_remote_string(CMD_INBOX, True)
            if status != 0:
                break
            self.msg = message[:-1]  # StrToByteArray drops the trailing NUL
            self.handle_message()
        self.control(host.current_tick())
        self._next += CONTROL_MS
        now = host.current_tick()
        if self._next <= now:
            self._next = now

    # -- byte helpers -------------------------------------------------------------

    def checksum_add(self, v: int) -> None:
        if v < 0:
            v += 65536
        self.ck = crc16(bytes((v & 0xFF, (v // 256) & 0xFF)), self.ck)

    # -- responses ------------------------------------------------------------------

    def begin(self, kind: int, length: int) -> None:
        self.out = bytearray(length)
        self.wr_u8(0, kind)
        self.wr_16(1, self.rq_session)
        self.wr_16(3, self.rq_seq)
        self.wr_u8(5, self.state)

    def send_ack(self, code: int, value: int) -> None:
        self.begin(Kind.ACK, 19)
        self.wr_u8(6, code)
        self.wr_16(7, self.expected)
        self.wr_16(9, self.rows_stored)
        self.wr_16(11, self.logged)
        self.wr_16(13, value)
        self.wr_16(15, self.ck)
        self.send_out(17)

    def send_welcome(self, code: int) -> None:
        self.begin(Kind.WELCOME, 19)
        self.wr_u8(6, PROTOCOL_VERSION)
        self.wr_u8(7, code)
        self.wr_16(8, self.expected)
        self.wr_16(10, MAX_VALUES)
        self.wr_16(12, self.rows_stored)
        self.wr_16(14, self.logged)
        self.wr_u8(16, CONTROL_MS)
        self.send_out(17)

    # -- motors ---------------------------------------------------------------------

    def coast_all(self) -> None:
        assert self._host is not None
        for j in range(self.nports):
            self._host.coast_ex(self.port[j], RESET_NONE)

    def control_row(self, row: int) -> None:
        assert self._host is not None
        worst = 0
        for j in range(self.nports):
            p = self.port[j]
            ref = self.refs[row * self.nports + j]
            err = ref - self._host.motor_rotation_count(p)
            pwr = div(self.kp_num * err, self.kp_den)
            if pwr > self.max_power:
                pwr = self.max_power
            if pwr < -self.max_power:
                pwr = -self.max_power
            self._host.on_fwd_ex(p, pwr, RESET_NONE)
            err = abs(err)
            if err > worst:
                worst = err
        self.max_err = worst

    def record_row(self) -> None:
        assert self._host is not None
        for j in range(self.nports):
            self.meas[self.logged * self.nports + j] = self._host.motor_rotation_count(self.port[j])
        self.logged += 1

    def control(self, now: int) -> None:
        if self.state in (State.HOMING, State.READY):
            self.control_row(0)
            if self.state == State.HOMING and self.max_err <= self.tolerance:
                self.state = State.READY
        elif self.state == State.RUNNING and now < self.t0:
            self.control_row(0)
        elif self.state == State.RUNNING:
            k = div(now - self.t0, self.tick_ms)
            while self.logged < k and self.logged < self.nrows:
                self.record_row()
            if self.logged >= self.nrows:
                self.state = State.DONE
                self.control_row(self.nrows - 1)
            else:
                self.control_row(k)
        elif self.state == State.DONE:
            self.control_row(self.nrows - 1)

    # -- requests -------------------------------------------------------------------

    def apply_config(self, n: int) -> int:
        if self.state != State.IDLE:
            return Code.BAD_STATE
        if n != 29:
            return Code.BAD_LENGTH
        np_ = self.rd_u8(5)
        rows = self.rd_u16(9)
        tick = self.rd_u16(11)
        kn = self.rd_u8(13)
        kd = self.rd_u8(14)
        mp = self.rd_u8(15)
        if np_ < 1 or np_ > MAX_PORTS:
            return Code.BAD_CONFIG
        if rows < 1 or rows * np_ > MAX_VALUES:
            return Code.BAD_CONFIG
        if tick < CONTROL_MS or tick > 10000:
            return Code.BAD_CONFIG
        if kd < 1 or kn < 1 or mp < 1 or mp > 100:
            return Code.BAD_CONFIG
        for j in range(np_):
            p = self.rd_u8(6 + j)
            if p > 2:
                return Code.BAD_CONFIG
            for i in range(j):
                if self.port[i] == p:
                    return Code.BAD_CONFIG
            self.port[j] = p
            self.min_deg[j] = self.rd_s16(17 + 2 * j)
            self.max_deg[j] = self.rd_s16(23 + 2 * j)
            if self.min_deg[j] > self.max_deg[j]:
                return Code.BAD_CONFIG
        self.nports = np_
        self.nrows = rows
        self.tick_ms = tick
        self.kp_num = kn
        self.kp_den = kd
        self.max_power = mp
        self.tolerance = self.rd_u8(16)
        nvalues = rows * np_
        self.refs = [0] * nvalues
        self.meas = [0] * nvalues
        self.rows_stored = 0
        self.logged = 0
        self.ck = 0xFFFF
        self.state = State.LOADING
        return Code.OK

    def apply_setpoints(self, n: int) -> int:
        if self.state != State.LOADING:
            return Code.BAD_STATE
        first = self.rd_u16(5)
        count = self.rd_u8(7)
        if n != 8 + 2 * count:
            return Code.BAD_LENGTH
        if count < 1 or count % self.nports != 0:
            return Code.BAD_LENGTH
        if first != self.rows_stored:
            return Code.BAD_ORDER
        rows = count // self.nports
        if first + rows > self.nrows:
            return Code.BAD_RANGE
        for i in range(count):
            v = self.rd_s16(8 + 2 * i)
            j = i % self.nports
            if v < self.min_deg[j] or v > self.max_deg[j]:
                return Code.OUT_OF_LIMITS
        for i in range(count):
            v = self.rd_s16(8 + 2 * i)
            self.refs[first * self.nports + i] = v
            self.checksum_add(v)
        self.rows_stored = first + rows
        if self.rows_stored == self.nrows:
            self.state = State.LOADED
        return Code.OK

    def apply_sequenced(self, n: int) -> int:
        if self.rq_kind == Kind.CONFIG:
            return self.apply_config(n)
        if self.rq_kind == Kind.SETPOINTS:
            return self.apply_setpoints(n)
        if self.rq_kind == Kind.GO:
            if n != 7:
                return Code.BAD_LENGTH
            if self.state != State.READY:
                return Code.BAD_STATE
            assert self._host is not None
            self.go_delay = self.rd_u16(5)
            self.t0 = self._host.current_tick() + self.go_delay
            self.logged = 0
            self.state = State.RUNNING
            return Code.OK
        if n != 5:
            return Code.BAD_LENGTH
        if self.rq_kind == Kind.PREPARE:
            if self.state != State.LOADED:
                return Code.BAD_STATE
            self.state = State.HOMING
            return Code.OK
        return Code.BAD_LENGTH

    def handle_logread(self, n: int) -> None:
        if n != 8:
            self.send_ack(Code.BAD_LENGTH, 0)
            return
        first = self.rd_u16(5)
        count = self.rd_u8(7)
        if count < 1 or count * self.nports > LOG_VALUES_PER_MESSAGE or first + count > self.logged:
            self.send_ack(Code.BAD_RANGE, 0)
            return
        nv = count * self.nports
        self.begin(Kind.LOGDATA, 11 + 2 * nv)
        self.wr_16(6, first)
        self.wr_u8(8, nv)
        for i in range(nv):
            self.wr_16(9 + 2 * i, self.meas[first * self.nports + i])
        self.send_out(9 + 2 * nv)

    def handle_message(self) -> None:
        n = self.open_message()
        if not n:
            return
        s = self.rq_session
        if self.rq_kind == Kind.HELLO:
            if n != 6 or self.rd_u8(5) != PROTOCOL_VERSION:
                self.send_welcome(Code.BAD_VERSION)
                return
            if s != self.session:
                self.coast_all()
                self.session = s
                self.expected = 1
                self.state = State.IDLE
                self.nports = 0
                self.nrows = 0
                self.rows_stored = 0
                self.logged = 0
                self.ck = 0xFFFF
                self.max_err = 0
            self.send_welcome(Code.OK)
            return
        if s != self.session:
            self.bad_messages += 1
            return
        if self.rq_kind == Kind.QUERY:
            self.send_ack(Code.OK, self.max_err)
            return
        if self.rq_kind == Kind.LOGREAD:
            self.handle_logread(n)
            return
        if self.rq_kind == Kind.STOP:
            self.coast_all()
            self.state = State.STOPPED
            self.send_ack(Code.OK, 0)
            return
        if self.rq_kind in (Kind.CONFIG, Kind.SETPOINTS, Kind.PREPARE, Kind.GO):
            v = self.go_delay if self.rq_kind == Kind.GO else 0
            if self.rq_seq < self.expected:
                self.send_ack(Code.DUPLICATE, v)
                return
            if self.rq_seq > self.expected:
                self.send_ack(Code.GAP, 0)
                return
            code = self.apply_sequenced(n)
            if code == Code.OK:
                self.expected += 1
            if self.rq_kind == Kind.GO:
                v = self.go_delay
            self.send_ack(code, v)
            return
        self.bad_messages += 1

    # -- inspection (tests, emulator status) ------------------------------------------

    def reference_rows(self) -> list[tuple[int, ...]]:
        """The setpoints stored so far, as rows (what the brick will follow)."""
        n = self.nports
        return [tuple(self.refs[r * n:(r + 1) * n]) for r in range(self.rows_stored)]

    def measured_rows(self) -> list[tuple[int, ...]]:
        n = self.nports
        return [tuple(self.meas[r * n:(r + 1) * n]) for r in range(self.logged)]
