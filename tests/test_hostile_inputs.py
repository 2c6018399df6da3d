"""Hostile input on the robot surfaces: every item is refused before anything moves
with a located ``file:line:col: error:`` or a one-line message and exit code 2, in bounded time
and memory, and never with a traceback. Each test reads what a user reads: the exit code and
the stderr line, through the CLI's main function."""
from __future__ import annotations

import io
import shutil
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cplus.cli import main
from cplus.errors import Source
from cplus.robot.online import events as ev

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery"


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


@pytest.fixture
def delivery(tmp_path) -> Path:
    """A copy of the delivery domain, its binding and world (so tests may edit them)."""
    for name in ("delivery.cp", "robot.toml", "world.toml"):
        shutil.copy(DELIVERY / name, tmp_path / name)
    return tmp_path / "delivery.cp"


# -- --events --------------------------------------------------------------------------------

@pytest.mark.parametrize("cycle", ["@²", "@٣", "@" + "9" * 5000, "@1000000001", "@0", "@-1", "@"])
def test_an_event_file_cycle_that_is_not_ascii_digits_in_range_is_located(delivery, tmp_path, capsys, cycle):
    events = tmp_path / "ev.txt"
    events.write_text(f"# a comment\n{cycle} press\n", encoding="utf-8")
    code, _, err = run(["online", str(delivery), "--simulate", "--events", str(events)], capsys)
    assert code == 2
    assert err.startswith(f"{events}:2:1: error: '{cycle[:60]}") and "whole number from 1 to 1000000000" in err


def test_a_bad_line_on_standard_input_is_noted_and_later_lines_still_count(delivery, capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.StringIO("@² press\n" + "x" * (ev.MAX_LINE + 5) + "\n@2 press\n"))
    code, _, err = run(["online", str(delivery), "--simulate", "--events", "-"], capsys)
    assert code == 0
    assert "ignored <stdin> line 1: '@²': a cycle is written @N" in err
    assert f"ignored <stdin> line 2: longer than {ev.MAX_LINE} characters" in err
    assert "events press | replan (after press" in err      # line 3 arrived: the reader lived on


def test_a_line_of_standard_input_that_is_not_utf8_is_noted(delivery, capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(b"\xff\xfe press\n@2 press\n"), encoding="utf-8"))
    code, _, err = run(["online", str(delivery), "--simulate", "--events", "-"], capsys)
    assert code == 0 and "ignored <stdin> line 1: not UTF-8 text" in err and "events press" in err


def test_a_long_event_file_costs_linear_work(delivery, tmp_path, capsys, monkeypatch):
    """20,000 lines due at once: delivering them never compares lines with each other (taking
    the due lines out of a list by equality made 4,000 lines take 41 s)."""
    compared = []
    monkeypatch.setattr(ev.EventLine, "__eq__", lambda self, other: compared.append(1) or self is other)
    events = tmp_path / "ev.txt"
    events.write_text("press\n" * 20000 + "@3 press\n" * 20000)
    code, _, err = run(["online", str(delivery), "--simulate", "--events", str(events), "--quiet"], capsys)
    assert code == 0 and len(compared) < 1000


@given(st.text(max_size=40) | st.text(st.sampled_from("@ press()#\t1230²٣\u0966"), max_size=20))
def test_any_event_line_parses_or_is_a_located_error(text):
    try:
        line = ev.parse_line(text, Source("ev.txt", text))
    except ev.EventsError as exc:
        assert exc.loc is not None
        return
    if line is not None:
        assert line.cycle is None or 1 <= line.cycle <= ev.MAX_CYCLE
        assert line.events


@given(st.integers(min_value=-10, max_value=10 ** 12))
def test_every_cycle_in_range_is_read_and_every_other_refused(n):
    text = f"@{n} press"
    try:
        line = ev.parse_line(text, Source("ev.txt", text))
    except ev.EventsError:
        assert not 1 <= n <= ev.MAX_CYCLE
    else:
        assert line is not None and line.cycle == n


# -- world.toml, scene.toml, robot.toml: numbers ---------------------------------------------

BIG = "9" * 5000


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def line_of(path: Path, needle: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if needle in line)


@pytest.mark.parametrize("old, new, message", [
    ("seed = 1", f"seed = {BIG}", "invalid TOML: a number of more than 4300 digits"),
    ("seed = 1", "seed = 100000000000000000000", "seed = an integer of 21 digits is outside"),
    ("at_mm = 400", "at_mm = 1e300", "landmarks[0].at_mm = 1e+300 is outside"),
    ("noise_percent = 1.0", "noise_percent = nan", "noise_percent must be finite, not nan"),
])
def test_a_number_of_the_world_file_out_of_range_is_located(delivery, capsys, old, new, message):
    world = delivery.parent / "world.toml"
    edit(world, old, new)
    code, _, err = run(["online", str(delivery), "--max-cycles", "0"], capsys)
    assert code == 2 and err.startswith(f"{world}:{line_of(world, new[:12])}:") and message in err, err


def test_a_negative_distance_in_the_world_file_is_located(delivery, capsys):
    world = delivery.parent / "world.toml"
    world.write_text(world.read_text() + "\n[[presses]]\nat_landmark = 3\nnear_mm = -5\n")
    code, _, err = run(["online", str(delivery), "--max-cycles", "0"], capsys)
    assert code == 2 and err.startswith(f"{world}:{line_of(world, 'near_mm = -5')}:")
    assert "near_mm = -5 is outside 0..1e+09" in err


@pytest.mark.parametrize("old, new, message", [
    ('event = "button"', 'event = "buton"', "events.press.event = 'buton': a brick reports button (or 'event N'"),
    ('value = "landmark"', 'value = "landmrk"', "sensed.atLandmark.value = 'landmrk': a brick reports landmark, light"),
    ("args = [30]", "args = [100000]", "actions.follow.args[0] = 100000 is outside -32768..32767"),
    ("args = [30]", f"args = [{BIG}]", "invalid TOML: a number of more than 4300 digits"),
    ("args = [30]", "args = [1, 2, 3, 4, 5, 6, 7, 8, 9]", "9 arguments: a behaviour takes at most 8"),
    ("ignore = [0]", "ignore = [0]\nmap = { \"٣\" = 3 }", "map key '٣' must be an integer reading, written in ASCII"),
])
def test_a_binding_that_could_never_work_is_located_at_load(delivery, capsys, old, new, message):
    """Found at load, before anything moves: not at the first action (exit 8, "robot lost"), nor
    as presses silently ignored (exit 0) or a fluent never sensed (exit 7)."""
    robot = delivery.parent / "robot.toml"
    edit(robot, old, new)
    code, _, err = run(["online", str(delivery), "--simulate"], capsys)
    needle = new.splitlines()[-1][:10]
    assert code == 2 and err.startswith(f"{robot}:{line_of(robot, needle)}:") and message in err, err


def test_a_scene_number_too_large_is_located(tmp_path, capsys):
    for name in ("payload.cp", "scene.toml"):
        shutil.copy(ROOT / "domains" / "payload" / name, tmp_path / name)
    scene = tmp_path / "scene.toml"
    text = scene.read_text()
    first = next(line for line in text.splitlines() if line.startswith("arm_length"))
    scene.write_text(text.replace(first, "arm_length = 1" + "0" * 400, 1))
    code, _, err = run(["plan", str(tmp_path / "payload.cp")], capsys)
    assert code == 2 and err.startswith(f"{scene}:{line_of(scene, 'arm_length = 1000')}:")
    assert "arm_length = an integer of 401 digits is outside -1e+09..1e+09" in err, err


# -- the trajectory JSON -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def trajectory_json(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("traj") / "t.json"
    assert main(["plan", str(ROOT / "domains" / "payload" / "payload.cp"), "--trajectory", str(out)]) == 0
    return out


@pytest.mark.parametrize("old, new, message", [
    ('"turns": 0', '"turns": 1000000000000000000000000000000',
     "robots[0].kinematics.turns: expected an integer in -4..4, got an integer of 31 digits"),
    ('"arm_length": 7,', '"arm_length": 1' + "0" * 400 + ",",
     "robots[0].kinematics.arm_length: expected a number in -1e+09..1e+09, got an integer of 401 digits"),
    ('"arm_length": 7,', '"arm_length": NaN,', "robots[0].kinematics.arm_length: expected a finite number, got nan"),
    ('"tick_ms": 100', '"tick_ms": 1' + "0" * 5000, "invalid JSON: Exceeds the limit (4300 digits)"),
])
def test_a_trajectory_number_out_of_range_is_one_line(trajectory_json, tmp_path, capsys, old, new, message):
    edited = tmp_path / "t.json"
    text = trajectory_json.read_text()
    assert old in text, old
    edited.write_text(text.replace(old, new, 1))
    code, _, err = run(["execute", str(edited), "--scene", str(ROOT / "domains" / "payload" / "scene.toml")], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


# -- any text where a number goes: a located error or a value ----------------------------------

NUMBERISH = st.text(st.sampled_from("0123456789-+._eEinfa ²٣\u0966x\"'"), max_size=12) | st.text(max_size=8) | \
    st.integers(min_value=-10 ** 30, max_value=10 ** 30).map(str) | st.just("9" * 4400)


@given(NUMBERISH)
def test_any_world_number_is_a_value_or_a_located_error(text):
    from cplus.robot.online.world_file import WorldFileError, parse_world
    source = (DELIVERY / "world.toml").read_text()
    for old in ("noise_percent = 1.0", "seed = 1", "at_mm = 400"):
        edited = source.replace(old, f"{old.split(' =')[0]} = {text}", 1)
        try:
            parse_world(edited, "w.toml")
        except WorldFileError as exc:
            assert exc.loc is not None and exc.render().startswith("w.toml:")


@given(NUMBERISH)
def test_any_binding_number_is_a_value_or_a_located_error(text):
    from cplus.api import Domain
    from cplus.robot.online.binding import BindingError, parse_binding
    domain = _delivery_domain()
    source = (DELIVERY / "robot.toml").read_text()
    for edited in (source.replace("args = [30]", f"args = [{text}]"),
                   source.replace("ignore = [0]", f"ignore = [{text}]"),
                   source.replace("ignore = [0]", f"map = {{ {_toml_string(text)} = 3 }}")):
        try:
            b = parse_binding(edited, "r.toml", domain)
        except BindingError as exc:
            assert exc.loc is not None and exc.render().startswith("r.toml:")
        else:
            for s in b.sensed.values():
                assert all(isinstance(k, int) and -2 ** 31 <= k < 2 ** 31 for k in s.table)
            for a in b.actions.values():
                assert all(-2 ** 15 <= x < 2 ** 15 for x in a.args if isinstance(x, int))
    assert Domain is not None


@given(NUMBERISH)
def test_any_trajectory_turns_is_a_value_or_a_one_line_error(text):
    import json

    from trajectory import TrajectoryError
    from trajectory.export import trajectory_from_dict
    base = json.loads(_payload_trajectory_text())
    try:
        value = json.loads(text)
    except ValueError:
        return                                  # not JSON: the loader's own JSON error, tested above
    base["robots"][0]["kinematics"]["turns"] = value
    try:
        traj = trajectory_from_dict(base, "t.json")
    except TrajectoryError as exc:
        assert "\n" not in str(exc) and exc.message.startswith("t.json: robots[0].kinematics.turns")
    else:
        assert -4 <= traj.robots[0].branch.turns <= 4


_CACHE: dict[str, object] = {}


def _delivery_domain():
    from cplus.api import Domain
    if "domain" not in _CACHE:
        _CACHE["domain"] = Domain.load(str(DELIVERY / "delivery.cp"))
    return _CACHE["domain"]


def _payload_trajectory_text() -> str:
    if "traj" not in _CACHE:
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            out = Path(d) / "t.json"
            assert main(["plan", str(ROOT / "domains" / "payload" / "payload.cp"), "--trajectory", str(out)]) == 0
            _CACHE["traj"] = out.read_text()
    return _CACHE["traj"]  # type: ignore[return-value]


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


# -- command-line options ------------------------------------------------------------------------

@pytest.mark.parametrize("argv, message", [
    (["--delay", "inf"], "--delay: must be at least 0 and at most 10000 milliseconds, got 'inf'"),
    (["--delay", "nan"], "--delay: must be at least 0 and at most 10000 milliseconds, got 'nan'"),
    (["--time-scale", "inf"], "--time-scale: must be at least 0.001 and at most 1000 times real time, got 'inf'"),
    (["--backlash-deg", "nan"], "--backlash-deg: must be at least 0 and at most 45 degrees, got 'nan'"),
])
def test_a_non_finite_brick_option_is_one_line(capsys, argv, message):
    code, _, err = run(["brick", "--name", "r1", *argv], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_two_stalls_on_one_motor_are_one_line(capsys):
    code, _, err = run(["online", str(ROOT / "domains" / "payload" / "payload.cp"), "--stall", "r1:A@4+2",
                        "--stall", "r1:a@5"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "--stall r1:a@5 and --stall r1:A@4+2 are both on r1's motor A: give one stall per motor" in err


@pytest.mark.parametrize("kind", ["file", "directory", "symlink"])
def test_brick_link_never_replaces_what_it_did_not_make(tmp_path, capsys, kind):
    link = tmp_path / "f"
    if kind == "file":
        link.write_text("precious")
    elif kind == "directory":
        link.mkdir()
    else:
        (tmp_path / "target").write_text("precious")
        link.symlink_to(tmp_path / "target")
    code, out, err = run(["brick", "--name", "r1", "--link", str(link)], capsys)
    assert code == 2 and out == "" and err.startswith(f"cplus brick: error: --link {link}: ")
    assert "choose another path, or remove it" in err
    assert link.is_dir() if kind == "directory" else link.read_text() == "precious"


# -- cplus brick as a process ----------------------------------------------------------------------

def _brick(argv: list[str], **kw):
    import subprocess
    import sys
    return subprocess.Popen([sys.executable, "-m", "cplus", "brick", "--no-latency", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT, **kw)


def _end(proc) -> tuple[int, str]:
    import signal
    proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err


@pytest.mark.slow
def test_a_press_on_standard_input_that_is_not_a_duration_is_refused_and_the_next_counts():
    import subprocess
    proc = _brick(["--name", "robot", "--world", str(DELIVERY / "world.toml")], stdin=subprocess.PIPE)
    assert proc.stdout.readline().strip()                       # type: ignore[union-attr]
    proc.stdin.write("press nan\npress inf\npress 0.5\n")       # type: ignore[union-attr]
    proc.stdin.flush()                                          # type: ignore[union-attr]
    seen = ""
    while "pressed for 0.5 s" not in seen:
        line = proc.stderr.readline()                           # type: ignore[union-attr]
        assert line, seen
        seen += line
    code, err = _end(proc)
    assert code == 0 and "Traceback" not in seen + err
    assert "ignored standard input line 1: 'press nan': a press lasts more than 0 and at most 60 s" in seen
    assert "ignored standard input line 2: 'press inf'" in seen


@pytest.mark.slow
def test_brick_link_replaces_a_stale_link_refuses_a_live_one_and_removes_only_its_own(tmp_path):
    import os
    link = tmp_path / "tty"
    os.symlink("/dev/pts/987654", link)                         # left by a brick killed with SIGKILL
    first = _brick(["--name", "r1", "--link", str(link)])
    assert first.stdout.readline().strip() == str(link)         # type: ignore[union-attr]
    assert os.readlink(link).startswith("/dev/pts/") and os.path.exists(os.readlink(link))
    second = _brick(["--name", "r2", "--link", str(link)])
    _, err = second.communicate(timeout=20)
    assert second.returncode == 2 and f"--link {link}: it is the link of /dev/pts/" in err and "in use" in err
    assert os.path.exists(os.readlink(link))                    # the first brick's link is untouched
    code, _ = _end(first)
    assert code == 0 and not os.path.lexists(link)
