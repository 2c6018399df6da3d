"""The Python model of cplus_follow.nxc against the compiled program, millisecond by millisecond.

The same sessions (a whole streamed execution, faults, a program started by
STARTPROGRAM, a reconnect) run on two firmwares at once: one with the model,
one with the compiled ``.rxe`` on the interpreter. Every reply, every mailbox
and every output port must be identical after every command and every
millisecond; a difference fails the test (no tolerance).
"""
from __future__ import annotations

import pytest
from vmtools import Disagreement, make_twin

from nxt_link.emulator import follower_program
from nxt_link.emulator.emulator import FaultParams, compiled_follower
from nxt_link.emulator.vm import Compiled
from nxt_link.host.execution import ExecutionOptions, SetpointStream, execute_streams
from nxt_link.host.session import SessionTiming

TIMING = SessionTiming(ack_timeout_s=0.3, max_silent_s=5.0, homing_timeout_s=3.0)


@pytest.fixture(scope="module")
def follower() -> Compiled:
    files, symbols = compiled_follower()
    return Compiled(files["cplus_follow.rxe"], symbols["cplus_follow.rxe"])


def run(rig, wave, follower, *, faults: FaultParams | None = None, program_running: bool = True,
        ports=("A", "B", "C"), n: int = 60):
    rig.add("r1", faults=faults or FaultParams(), program_running=program_running)
    twin = make_twin(rig.emulators["r1"], follower)
    stream = SetpointStream("r1", ports, 50, wave(n, (90, -60, 30)[:len(ports)]))
    log = execute_streams([stream], rig.bricks, options=ExecutionOptions(timing=TIMING))
    return twin, stream, log


def test_a_whole_execution_is_identical_tick_by_tick(rig, wave, follower):
    twin, stream, log = run(rig, wave, follower)
    assert log.brick("r1").reference_deg == stream.rows
    assert twin.ticks > 3000 and twin.commands > 40
    # both really moved the motors and logged a row per tick
    assert twin.compiled.outputs[0].rotation_count != 0
    assert len(log.brick("r1").measured_deg) == len(stream.rows)


def test_faults_and_a_disconnect_are_identical(rig, wave, follower):
    faults = FaultParams(drop=0.1, corrupt=0.05, disconnect_after=25, seed=7)
    twin, stream, log = run(rig, wave, follower, faults=faults, ports=("A", "C"))
    assert log.brick("r1").reference_deg == stream.rows
    assert rig.emulators["r1"].stats.dropped_in + rig.emulators["r1"].stats.dropped_out > 0
    assert twin.ticks > 3000


def test_a_program_started_by_the_pc_is_identical(rig, wave, follower):
    twin, stream, log = run(rig, wave, follower, program_running=False, ports=("B",), n=30)
    assert log.brick("r1").reference_deg == stream.rows
    assert twin.compiled.program_name == "cplus_follow.rxe"


def test_a_model_that_drifts_from_the_program_is_caught(rig, wave, follower, monkeypatch):
    # the model answers a QUERY with the wrong value: the comparison must notice
    original = follower_program.FollowerProgram.send_ack

    def wrong(self, code, value):
        original(self, code, value + 1 if self.rq_kind == 0x51 else value)
    monkeypatch.setattr(follower_program.FollowerProgram, "send_ack", wrong)
    with pytest.raises(Disagreement, match="mailbox 11"):
        run(rig, wave, follower, n=20)


def test_a_control_law_that_drifts_is_caught(rig, wave, follower, monkeypatch):
    original = follower_program.FollowerProgram.control_row

    def stronger(self, row):  # one more %/degree than the NXC program
        self.kp_num += 1
        original(self, row)
        self.kp_num -= 1
    monkeypatch.setattr(follower_program.FollowerProgram, "control_row", stronger)
    with pytest.raises(Disagreement, match="outputs"):
        run(rig, wave, follower, n=20)
