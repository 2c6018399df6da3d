"""The emulated firmware answers direct commands as the NXT firmware does."""
from __future__ import annotations

import pytest

from nxt_link.emulator.firmware import Firmware, FirmwareParams
from nxt_link.programs.stream_protocol import PROGRAM_NAME
from nxt_link.wire import telegram as tg


def fw(running: bool = True, **params) -> Firmware:
    f = Firmware(FirmwareParams(files=("other.rxe",), **params),
                 programs={PROGRAM_NAME: lambda: _Silent()})
    if running:
        f.start_program_now("other.rxe")
    return f


class _Silent:
    def step(self, host) -> None:
        pass


def send(f: Firmware, hex_telegram: str) -> str | None:
    reply = f.handle(bytes.fromhex(hex_telegram))
    return None if reply is None else reply.hex(" ")


def write(f: Firmware, inbox: int, payload: bytes, reply: bool = True) -> str | None:
    return send(f, tg.encode_command(tg.MessageWrite(inbox, payload, reply)).hex())


def read(f: Firmware, box: int, remove: bool = True, local: int = 0) -> bytes:
    return f.handle(tg.encode_command(tg.MessageRead(box, local, remove)))


def test_mailbox_queue_is_five_deep_and_drops_the_oldest():
    f = fw()
    for i in range(7):
        assert write(f, 3, b"m%d" % i) == "02 09 00"  # full queue: still success
    got = []
    while True:
        r = tg.parse_reply(read(f, 3))
        if r.status:
            assert r.status == 0x40
            break
        got.append(r.payload)
    assert got == [b"m2", b"m3", b"m4", b"m5", b"m6"]


def test_message_read_peek_keeps_the_message_and_echoes_local_inbox():
    f = fw()
    write(f, 10, b"12.5")
    peek = read(f, 10, remove=False, local=7)
    assert peek == bytes.fromhex("02 13 00 07 05 31 32 2e 35 00") + bytes(54)
    assert tg.parse_reply(read(f, 10)).payload == b"12.5"  # this read removes it
    empty = read(f, 10, local=4)
    assert empty == bytes.fromhex("02 13 40 04 00") + bytes(59)


def test_message_write_checks_in_firmware_order():
    f = fw(running=False)
    # size/NUL problems first (C0), then the queue number (EE), then the program (EC)
    assert send(f, "00 09 03 03 61 62 63") == "02 09 c0"  # last byte is not NUL
    assert send(f, "00 09 03 00") == "02 09 c0"  # size 0
    assert send(f, "00 09 14 02 61 00") == "02 09 ee"  # inbox 20
    assert send(f, "00 09 03 02 61 00") == "02 09 ec"  # no program
    f.start_program_now("other.rxe")
    assert send(f, "00 09 03 02 61 00") == "02 09 00"
    assert send(f, "00 09 03 3c" + "61" * 59 + "00") == "02 09 c0"  # size 60 > 59


def test_message_read_without_program_and_bad_queue():
    f = fw(running=False)
    assert read(f, 25, local=2) == bytes.fromhex("02 13 ec 02 00") + bytes(59)  # EC first
    f.start_program_now("other.rxe")
    assert read(f, 25) == bytes.fromhex("02 13 ee 00 00") + bytes(59)


def test_payload_may_contain_nuls():
    f = fw()
    write(f, 1, b"\x00\x01\x00")
    assert tg.parse_reply(read(f, 1)).message == b"\x00\x01\x00\x00"


def test_no_reply_is_ever_sent_to_a_no_reply_telegram():
    f = fw(running=False)
    for t in ("80 09 03 02 61 00", "80 06 09", "80 0b", "80 42", "80 13 01 00 01",
              "80 04 07 00 00 00 00 00 00 00 00 00", "81 9b"):
        assert send(f, t) is None, t


def test_unknown_opcode_gets_be_and_unused_types_are_ignored():
    f = fw()
    assert send(f, "00 42") == "02 42 be"
    assert send(f, "00 12") == "02 12 be"  # GETBUTTONSTATE is not modelled
    assert send(f, "05 0b") is None
    assert send(f, "02 0b 00 28 23") is None  # a reply sent to the brick is not answered


def test_get_output_state_errors_are_zero_filled():
    f = fw()
    assert send(f, "00 06 03") == "02 06 c0" + " 00" * 22
    assert send(f, "00 07 04") == "02 07 c0" + " 00" * 13
    assert send(f, "00 0a 05 00") == "02 0a c0"
    assert send(f, "80 04 03 00 00 00 00 00 00 00 00 00") is None


def test_program_lifecycle_and_start_delay():
    f = Firmware(FirmwareParams(start_delay_ms=200), programs={PROGRAM_NAME: _Silent})
    assert send(f, "00 11") == "02 11 ec" + " 00" * 20
    assert send(f, "00 01") == "02 01 ec"
    assert send(f, tg.encode_command(tg.StartProgram("missing.rxe")).hex()) == "02 00 c0"
    assert send(f, tg.encode_command(tg.StartProgram(PROGRAM_NAME)).hex()) == "02 00 00"
    for _ in range(199):
        f.tick()
    assert send(f, "00 11").startswith("02 11 ec")  # not running yet
    f.tick()
    name = tg.decode_reply(f.handle(bytes.fromhex("00 11")), tg.Opcode.GET_CURRENT_PROGRAM_NAME)
    assert name.name == PROGRAM_NAME
    assert send(f, "00 01") == "02 01 00"
    f.tick()
    assert send(f, "00 11").startswith("02 11 ec")


def test_program_start_clears_mailboxes_and_resets_counters():
    f = fw()
    write(f, 2, b"old")
    f.handle(tg.encode_command(tg.SetOutputState(0, 100, 1, 0, 0, 0x20, 0)))
    for _ in range(300):
        f.tick()
    assert f.outputs[0].rotation_count > 100
    f.start_program_now("other.rxe")
    assert tg.parse_reply(read(f, 2)).status == 0x40
    out = tg.decode_reply(f.handle(bytes.fromhex("00 06 00")), tg.Opcode.GET_OUTPUT_STATE)
    assert (out.power, out.mode, out.run_state, out.tacho_count, out.block_tacho_count,
            out.rotation_count) == (0, 0, 0, 0, 0, 0)


def test_reset_motor_position_resets_only_the_named_counter():
    f = fw()
    f.handle(tg.encode_command(tg.SetOutputState(1, 60, 1, 0, 0, 0x20, 0)))
    for _ in range(200):
        f.tick()
    f.handle(tg.encode_command(tg.SetOutputState(1, 0, 0, 0, 0, 0, 0)))  # coast
    for _ in range(500):
        f.tick()
    o = f.outputs[1]
    moved = o.tacho_count
    assert moved > 20 and o.block_tacho_count == moved == o.rotation_count
    assert send(f, "00 0a 01 01") == "02 0a 00"
    assert (o.tacho_count, o.block_tacho_count, o.rotation_count) == (moved, 0, moved)
    assert send(f, "00 0a 01 00") == "02 0a 00"
    assert (o.tacho_count, o.block_tacho_count, o.rotation_count) == (moved, 0, 0)


def _run_until_idle(f: Firmware, port: int) -> int:
    """Tick until the port's run state drops to IDLE; return the count at that moment."""
    o = f.outputs[port]
    for _ in range(5000):
        f.tick()
        if o.run_state == tg.RunState.IDLE:
            return o.tacho_count
    raise AssertionError("the tacho limit was never reached")


def test_tacho_limit_stops_by_coasting_past_and_targets_accumulate():
    f = fw()
    o = f.outputs[0]
    f.handle(tg.encode_command(tg.SetOutputState(0, 75, 1, 0, 0, 0x20, 360)))
    assert 360 <= _run_until_idle(f, 0) <= 362  # power cut at the target
    for _ in range(1000):
        f.tick()
    first = o.tacho_count
    assert first > 400  # ... and the motor coasted well past it
    # the next limited move is counted from the previous *target* (360), not from
    # where the motor stopped: the firmware's error correction
    f.handle(tg.encode_command(tg.SetOutputState(0, 75, 1, 0, 0, 0x20, 360)))
    assert 720 <= _run_until_idle(f, 0) <= 722
    # a reset of the tacho count forgets the accumulated target
    o.reset_counters(0x08)
    f.handle(tg.encode_command(tg.SetOutputState(0, -75, 1, 0, 0, 0x20, 90)))
    assert -92 <= _run_until_idle(f, 0) <= -90


def test_speed_regulation_holds_the_requested_counts_per_100_ms():
    f = fw()
    f.handle(tg.encode_command(tg.SetOutputState(2, 50, 0x05, 1, 0, 0x20, 0)))
    for _ in range(1000):
        f.tick()
    before = f.outputs[2].tacho_count
    for _ in range(1000):
        f.tick()
    assert abs((f.outputs[2].tacho_count - before) - 500) <= 15  # 50 counts per 100 ms


def test_input_ports_report_the_mode_that_was_set():
    f = fw()
    assert send(f, "00 05 02 01 20") == "02 05 00"
    v = tg.decode_reply(f.handle(bytes.fromhex("00 07 02")), tg.Opcode.GET_INPUT_VALUES)
    assert (v.port, v.valid, v.sensor_type, v.sensor_mode) == (2, False, 1, 0x20)
    for _ in range(20):  # the input module holds new-type data invalid for 20 ms
        f.tick()
    v = tg.decode_reply(f.handle(bytes.fromhex("00 07 02")), tg.Opcode.GET_INPUT_VALUES)
    assert not v.valid
    f.inputs[2].raw = 183  # a pressed touch sensor
    f.tick()
    v = tg.decode_reply(f.handle(bytes.fromhex("00 07 02")), tg.Opcode.GET_INPUT_VALUES)
    assert (v.valid, v.raw_value, v.normalized_value, v.scaled_value) == (True, 183, 183, 1)
    # a mode change alone: invalid until the next sample
    assert send(f, "00 05 02 01 00") == "02 05 00"
    v = tg.decode_reply(f.handle(bytes.fromhex("00 07 02")), tg.Opcode.GET_INPUT_VALUES)
    assert not v.valid
    f.tick()
    v = tg.decode_reply(f.handle(bytes.fromhex("00 07 02")), tg.Opcode.GET_INPUT_VALUES)
    assert (v.valid, v.scaled_value) == (True, 183)


def test_battery_keepalive_tone():
    f = fw(battery_mv=7600, sleep_minutes=30)
    assert send(f, "00 0b") == "02 0b 00 b0 1d"
    assert send(f, "00 0d") == "02 0d 00 40 77 1b 00"  # 1 800 000 ms
    assert send(f, "80 03 b8 01 64 00") is None
    assert (f.tones[-1].frequency_hz, f.tones[-1].duration_ms) == (440, 100)


def test_incoming_message_read_reply_is_stored_in_the_named_mailbox():
    f = fw()
    assert send(f, "02 13 00 04 03 68 69 00") is None
    assert tg.parse_reply(read(f, 4)).payload == b"hi"


@pytest.mark.parametrize("hex_telegram", ["00", "00 06", "00 00 61 62", "80 04 01"])
def test_truncated_commands_are_dropped_without_reply(hex_telegram):
    assert send(fw(), hex_telegram) is None
