"""Hostile input on the robot surfaces: every item is refused before anything moves
with a located ``file:line:col: error:`` or a one-line message and exit code 2, in bounded time
and memory, and never with a traceback. Each test reads what a user reads: the exit code and
the stderr line, through the CLI's main function."""
from __future__ import annotations

import io
import os
import shutil
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from walltime import wall

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
        _, err = proc.communicate(timeout=wall(20))
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
    _, err = second.communicate(timeout=wall(20))
    assert second.returncode == 2 and f"--link {link}: it is the link of /dev/pts/" in err and "in use" in err
    assert os.path.exists(os.readlink(link))                    # the first brick's link is untouched
    code, _ = _end(first)
    assert code == 0 and not os.path.lexists(link)


# --- the shell (cplus.shell): hostile command lines ----------------------------------------

@pytest.mark.parametrize("line", [
    "set(num, ²).", "set(num, ٣).", "set(solver, '').",
    "show (((.", "show ).", "show 1: .", "show loc(.", "qurey " + "x " * 2000 + ".", "help(" + "a" * 5000 + ").",
    "'unterminated", "show -- -- p.", "show \x00.", "loadf(" * 100 + ".",
])
def test_a_hostile_shell_line_is_one_located_line_never_a_traceback(line):
    from cplus.shell import Session
    s = Session()
    r = s.run(line)
    assert r.failed and r.err.count("\n") == 1 and r.err.startswith("<stdin>:1:") and "Traceback" not in r.err


def test_a_hostile_show_spec_after_a_load_is_located(tmp_path):
    from cplus.shell import Session
    f = tmp_path / "l.cp"
    f.write_text(":- constants lit :: inertialFluent; flip :: exogenousAction.\nflip causes lit.\n")
    s = Session()
    assert not s.run(f"loadf '{f}'.").failed
    for line in ("show lit(((.", "show 99999999999999999999999: lit.", "show -1: lit.", "show lit=" + "x" * 3000 + ".",
                 "show " + "; ".join(["lit"] * 3000) + "."):
        r = s.run(line)
        assert "Traceback" not in r.err and (not r.failed or r.err.startswith("<stdin>:1:")), (line[:40], r.err)


# == issue 30: grounding bombs, externals, a brick program that never waits (engineer grounding) ==

# -- small grounding bombs: the size check covers conditions and additive encodings -----------------

_BOMB = """:- sorts n.
:- objects 0..{top} :: n.
:- variables X, Y, Z :: n.
:- constants p :: inertialFluent; a :: exogenousAction.
a causes p where {where}.
:- query maxstep :: 1; 0: -p; maxstep: p.
"""


def test_a_sum_that_only_one_pair_satisfies_is_ground_at_once(tmp_path, capsys):
    """``Y - X = 99999`` over 0..99999: one instance, found by solving for Y, not by ten billion tries."""
    path = tmp_path / "sum.cp"
    path.write_text(_BOMB.format(top=99999, where="Y - X = 99999"))
    code, out, _ = run(["plan", str(path)], capsys)
    assert code == 0 and "ACTIONS:  a" in out


@pytest.mark.parametrize("where, names", [("X * Y * Z = 12", "X, Y, Z"), ("X + 2 * Y < 0", "X, Y")])
def test_a_condition_that_would_try_billions_is_refused_at_the_law(tmp_path, capsys, where, names):
    path = tmp_path / "bomb.cp"
    path.write_text(_BOMB.format(top=49999, where=where))
    code, out, err = run(["plan", str(path)], capsys)
    assert code == 2 and out == ""
    first = err.splitlines()[0]
    assert first.startswith(f"{path}:5:1: error: this law is too large to ground: finding its instances means trying about ")
    assert f"combinations of values of {names}, more than the 20,000,000 a law may try" in first


def test_a_huge_additive_fluent_is_refused_at_its_declaration(tmp_path, capsys, monkeypatch):
    """A million values and 25 increments, under the budget of a 2 GB ``ulimit -v``."""
    import cplus.limits
    monkeypatch.setattr(cplus.limits, "memory_budget", lambda: 1 << 30)
    path = tmp_path / "add.cp"
    path.write_text(":- maxAdditive :: 999999.\n:- sorts i.\n:- objects 1..25 :: i.\n:- variables I :: i.\n"
                    ":- constants level :: additiveFluent(0..999999); pour(i) :: exogenousAction.\n"
                    "pour(I) increments level by 2 * I.\n:- query maxstep :: 2; 0: level = 0; maxstep: level = 8.\n")
    code, out, err = run(["plan", str(path)], capsys)
    assert code == 2 and out == ""
    assert err.startswith(f"{path}:5:14: error: the additive fluent 'level' is too large to encode: it sums 25 "
                          "contributions over 1,000,000 values, about 50,000,000 partial sums at every step: that needs")


# -- --extern: what a function returns, and what it prints -------------------------------------------

_LINE = """:- sorts pos. :- objects 0..9 :: pos. :- variables P, Q :: pos.
:- constants at :: inertialFluent(pos); hop(pos) :: exogenousAction.
hop(P) causes at=P.
nonexecutable hop(P) if at=Q where -allowed(Q, P).
nonexecutable hop(P) & hop(Q) where P @< Q.
:- query maxstep :: 0..9; 0: at=0; maxstep: at=goal.
"""


def _line(tmp_path, allowed: str, goal: str = "return 4") -> tuple[str, str]:
    domain, ext = tmp_path / "line.cp", tmp_path / "rules.py"
    domain.write_text(_LINE.replace("at=goal", "at=goal(0)"))
    ext.write_text(f"import os\n\n\ndef allowed(q, p):\n    {allowed}\n\n\ndef goal(k):\n    {goal}\n")
    return str(domain), str(ext)


@pytest.mark.parametrize("allowed, goal, message", [
    ("return {0: True}.get(p - q)", "return 4", ":4:37: error: external predicate 'allowed(1,0)' returned None, not "
                                                "True or False"),
    ("return p - q in (0, 1)", "return [4]", ":6:48: error: external 'goal(0)' returned [4], which is neither an "
                                             "integer nor an object of this domain"),
    ("return p - q in (0, 1)", "return -2 ** 64", ":6:48: error: external 'goal(0)' returned about -10^19, "
                                                  "outside the integers (-2^63..2^63-1)"),
    ("raise SystemExit", "return 4", ":4:37: error: external 'allowed(0,0)' tried to end the program (sys.exit(None))"),
])
def test_an_external_returning_a_wrong_value_is_a_located_error(tmp_path, capsys, allowed, goal, message):
    domain, ext = _line(tmp_path, allowed, goal)
    code, out, err = run(["plan", domain, "--extern", ext, "--json"], capsys)
    assert code == 2 and out == "" and err.startswith(domain + message), err


def test_an_external_that_prints_leaves_the_json_whole(tmp_path, capfd):
    domain, ext = _line(tmp_path, "os.write(1, b'{not json\\n'); print(p, q); return p - q in (0, 1)")
    code = main(["plan", domain, "--extern", ext, "--json"])
    out, err = capfd.readouterr()
    import json
    assert code == 0 and json.loads(out)["results"][0]["maxstep"] == 4
    assert "{not json" in err and "{not json" not in out


# -- a brick program whose tasks hand over to each other without end --------------------------------

_RING = ("int laps;\ntask second();\ntask third();\n"
         "task first() { laps++; ExitTo(second); }\ntask second() { ExitTo(third); }\n"
         "task third() { ExitTo(first); }\ntask main() { ExitTo(first); }\n")


@pytest.mark.slow
def test_a_brick_running_a_ring_of_exitto_tasks_answers_and_stops_on_sigterm(tmp_path):
    import nxt.locator

    from nxt_link.emulator.vm import compile_nxc
    source = tmp_path / "ring.nxc"
    source.write_text(_RING)
    rxe = tmp_path / "ring.rxe"
    rxe.write_bytes(compile_nxc(source).rxe)
    proc = _brick(["--name", "ring", "--program", str(rxe)])
    try:
        path = proc.stdout.readline().strip()                   # type: ignore[union-attr]
        brick = nxt.locator.find(backends=["devfile"], filename=path, config=None)
        try:
            names = [brick.get_current_program_name() for _ in range(25)]
        finally:
            brick.close()
    finally:
        code, err = _end(proc)
    assert names == ["ring.rxe"] * 25
    assert code == 0 and "cplus brick: ring: 25 frames in, 25 out," in err
# -- outputs: every command's paths, checked before any work ----------------------------------------
#
# A command line whose outputs point at its inputs (the file itself, a symbolic or a hard link to
# it), at a folder, into a folder that does not exist, next to harmless ones (a device, a fresh
# path): refused with one line naming an output option, exit 2, before any work; no input's bytes
# change, nothing is created, a device stays a device.

MAILBOT = ROOT / "domains" / "mailbot"
PAYLOAD = ROOT / "domains" / "payload"


def _sandbox(folder: Path) -> None:
    """Every command's inputs, copied into one folder."""
    (folder / "task").mkdir()         # the robot task in a folder of its own: its scene makes a robot task
    shutil.copy(PAYLOAD / "payload.cp", folder / "task" / "payload.cp")
    shutil.copy(PAYLOAD / "scene.toml", folder / "task" / "scene.toml")
    for src in (ROOT / "domains/examples/lamp.cp",
                DELIVERY / "delivery.cp", DELIVERY / "robot.toml", DELIVERY / "world.toml",
                MAILBOT / "mailbot.cp", MAILBOT / "core.cp", MAILBOT / "moves.cp", MAILBOT / "requests.toml",
                MAILBOT / "table1.jsonl", ROOT / "domains/pddl/blocks-domain.pddl",
                ROOT / "domains/pddl/blocks-problem.pddl"):
        shutil.copy(src, folder / src.name)
    (folder / "t.json").write_text(_payload_trajectory_text())
    (folder / "jobs.jsonl").write_text('{"domain": "lamp.cp"}\n')
    (folder / "run.jsonl").write_text(_online_log_text())


def _online_log_text() -> str:
    if "log" not in _CACHE:
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            for name in ("delivery.cp", "robot.toml", "world.toml"):
                shutil.copy(DELIVERY / name, Path(d) / name)
            log = Path(d) / "run.jsonl"
            assert main(["online", str(Path(d) / "delivery.cp"), "--simulate", "--quiet", "--log", str(log)]) == 0
            _CACHE["log"] = log.read_text()
    return _CACHE["log"]  # type: ignore[return-value]


#: Each command: its arguments (inputs in the sandbox ``S``), its inputs, its outputs with a
#: suffix each takes (``/`` a folder the option creates).
PATH_COMMANDS: dict[str, tuple[list[str], list[str], dict[str, str]]] = {
    "plan": (["S/task/payload.cp"], ["task/payload.cp", "task/scene.toml"],
             {"--trajectory": ".json", "--csv": ".csv", "--plot": ".png", "--animate": ".gif"}),
    "ground": (["S/lamp.cp", "--maxstep", "1"], ["lamp.cp"], {"--dimacs": ".cnf"}),
    "run": (["S/task/payload.cp"], ["task/payload.cp", "task/scene.toml"], {"--out": "/", "--animate": ".gif"}),
    "execute": (["S/t.json", "--scene", "S/task/scene.toml"], ["t.json", "task/scene.toml"],
                {"--log": ".json", "--report": ".txt", "--plot": ".png", "--animate": ".gif"}),
    "online": (["S/delivery.cp", "--simulate", "--quiet"], ["delivery.cp", "robot.toml", "world.toml"],
               {"--log": ".jsonl"}),
    "serve": (["S/mailbot.cp", "--script", "S/table1.jsonl", "--quiet"], ["mailbot.cp", "requests.toml",
                                                                         "table1.jsonl"], {"--log": ".jsonl"}),
    "replay": (["S/run.jsonl"], ["run.jsonl"], {"--animate": ".gif"}),
    "batch": (["S/jobs.jsonl", "--quiet"], ["jobs.jsonl", "lamp.cp"], {"--results": ".jsonl", "--csv": ".csv"}),
    "brick": (["--name", "r1", "--world", "S/world.toml"], ["world.toml"], {"--link": ""}),
    "translate": (["S/blocks-domain.pddl", "S/blocks-problem.pddl"], ["blocks-domain.pddl", "blocks-problem.pddl"],
                  {"--output": ".cp"}),
}

BAD = ("input", "symlink", "hardlink", "folder", "missing")
GOOD = ("device", "fresh")


def _target(kind: str, folder: Path, inputs: list[str], suffix: str, k: int) -> str:
    """A path of this kind in ``folder`` (made now, before the snapshot)."""
    source = folder / inputs[k % len(inputs)]
    if kind == "input":
        return str(source)
    if kind in ("symlink", "hardlink"):
        link = folder / f"{kind}{k}{suffix.strip('/')}"
        if not link.exists():
            (link.symlink_to if kind == "symlink" else link.hardlink_to)(source)
        return str(link)
    if kind == "folder":
        return str(folder) if suffix != "/" else str(folder / "lamp.cp")      # --out: a file is the bad kind
    if kind == "missing":
        return str(folder / "missing" / f"out{k}{suffix.strip('/')}")
    if kind == "device":        # a link to the device, in the sandbox: code that would replace it cannot harm
        if suffix == "/":
            return str(folder)                                                 # --out: a folder that exists
        link = folder / f"null{k}{suffix}"
        link.symlink_to("/dev/null")
        return str(link)
    return str(folder / f"fresh{k}{suffix.strip('/')}")


def _snapshot(folder: Path) -> dict[str, object]:
    out: dict[str, object] = {}
    for p in sorted(folder.rglob("*")):
        rel = str(p.relative_to(folder))
        if p.is_symlink():
            out[rel] = ("link", os.readlink(p))
        elif p.is_dir():
            out[rel] = "folder"
        else:
            out[rel] = p.read_bytes()
    return out


@given(st.sampled_from(sorted(PATH_COMMANDS)), st.data())
@settings(max_examples=60)
def test_outputs_never_touch_inputs_nor_create_what_was_not_asked(command, data):
    import tempfile
    argv, inputs, outputs = PATH_COMMANDS[command]
    kinds = {option: data.draw(st.sampled_from(BAD + (GOOD if command != "brick" else ())), option)
             for option in outputs}
    if not set(kinds.values()) & set(BAD):
        kinds[data.draw(st.sampled_from(sorted(outputs)), "bad one")] = data.draw(st.sampled_from(BAD), "bad kind")
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        _sandbox(folder)
        line = [command, *(a.replace("S/", f"{folder}/") for a in argv)]
        for k, (option, kind) in enumerate(sorted(kinds.items())):
            line += [option, _target(kind, folder, inputs, outputs[option], k)]
        before = _snapshot(folder)
        code = main(line)
        after = _snapshot(folder)
    assert after == before, f"{line}: changed {sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))}"
    assert code == 2, line


def test_output_path_errors_name_the_option_and_the_input(tmp_path, capsys):
    _sandbox(tmp_path)
    capsys.readouterr()                 # what building the sandbox's trajectory printed
    scene = tmp_path / "task" / "scene.toml"
    code, out, err = run(["plan", str(tmp_path / "task" / "payload.cp"), "--trajectory", str(scene)], capsys)
    assert code == 2 and out == "" and err == f"cplus plan: error: --trajectory {scene}: it is the scene this command reads\n"
    code, _, err = run(["ground", str(tmp_path / "lamp.cp"), "--maxstep", "1", "--dimacs", str(tmp_path / "lamp.cp")],
                       capsys)
    assert code == 2 and err == f"cplus ground: error: --dimacs {tmp_path / 'lamp.cp'}: it is the domain this command reads\n"
    code, _, err = run(["execute", str(tmp_path / "t.json"), "--log", str(tmp_path / "t.json")], capsys)
    assert code == 2 and err == f"cplus execute: error: --log {tmp_path / 't.json'}: it is the trajectory this command reads\n"
    code, _, err = run(["online", str(tmp_path / "delivery.cp"), "--simulate", "--log", str(tmp_path / "robot.toml")],
                       capsys)
    assert code == 2 and err.endswith(f"cplus online: error: --log {tmp_path / 'robot.toml'}: it is the binding this "
                                      "command reads\n")
    code, _, err = run(["serve", str(tmp_path / "mailbot.cp"), "--script", str(tmp_path / "table1.jsonl"),
                        "--log", str(tmp_path / "requests.toml")], capsys)
    assert code == 2 and err.endswith(f"--log {tmp_path / 'requests.toml'}: it is the requests file this command "
                                      "reads\n")
    code, _, err = run(["batch", str(tmp_path / "jobs.jsonl"), "--results", str(tmp_path / "jobs.jsonl")], capsys)
    assert code == 2 and err == f"cplus batch: error: --results {tmp_path / 'jobs.jsonl'}: it is the job file this " \
                                "command reads\n"
    results = tmp_path / "r.jsonl"
    code, _, err = run(["batch", str(tmp_path / "jobs.jsonl"), "--results", str(results), "--csv", str(results)],
                       capsys)
    assert code == 2 and err == f"cplus batch: error: --results and --csv are the same file {results}\n"
    assert not results.exists()


def test_a_folder_that_does_not_exist_is_not_created(tmp_path, capsys):
    _sandbox(tmp_path)
    capsys.readouterr()                 # what building the sandbox's trajectory printed
    for argv, option in ((["plan", str(tmp_path / "task" / "payload.cp"), "--plot"], "--plot"),
                         (["run", str(tmp_path / "task" / "payload.cp"), "--out"], "--out"),
                         (["online", str(tmp_path / "delivery.cp"), "--simulate", "--log"], "--log")):
        target = tmp_path / "no" / "such" / "x.png"
        code, out, err = run([*argv, str(target)], capsys)
        assert code == 2 and out == "" and "% refinement" not in err
        assert err.endswith(f"cplus {argv[0]}: error: {option} {target}: no such directory {tmp_path / 'no'}"
                            + (" (only x.png itself is created)\n" if option == "--out" else " (it is not created)\n"))
        assert not (tmp_path / "no").exists()


@pytest.mark.parametrize("argv, option", [
    (["plan", "PAYLOAD", "--plot", "/proc/x.png"], "--plot /proc/x.png"),
    (["plan", "PAYLOAD", "--trajectory", "/proc/t.json"], "--trajectory /proc/t.json"),
    (["run", "PAYLOAD", "--out", "/proc/outdir"], "--out /proc/outdir"),
])
def test_a_place_where_nothing_can_be_created_is_refused_before_planning(tmp_path, capsys, argv, option):
    _sandbox(tmp_path)
    capsys.readouterr()                 # what building the sandbox's trajectory printed
    code, out, err = run([a.replace("PAYLOAD", str(tmp_path / "task" / "payload.cp")) for a in argv], capsys)
    assert code == 2 and out == "" and err == f"cplus {argv[0]}: error: {option}: cannot create files in /proc " \
                                              "(No such file or directory)\n"


def test_a_device_is_written_through_and_a_regular_file_replaced_whole(tmp_path, capsys):
    """The device is reached through a link in the test's folder (``/dev/stdout`` is such a
    link): code that replaced what it writes would replace the link, not the machine's device."""
    import stat
    lamp = tmp_path / "lamp.cp"
    shutil.copy(ROOT / "domains/examples/lamp.cp", lamp)
    null = tmp_path / "null.cnf"
    null.symlink_to("/dev/null")
    code, _, err = run(["ground", str(lamp), "--maxstep", "1", "--dimacs", str(null)], capsys)
    assert code == 0 and null.is_symlink() and stat.S_ISCHR(os.stat(null).st_mode) and f"% wrote {null}" in err
    null.unlink()
    old = tmp_path / "old.cnf"
    old.write_text("old")
    old.chmod(0o640)
    keep = tmp_path / "keep.cnf"
    os.link(old, keep)                                      # the old file's other name keeps its bytes
    link = tmp_path / "via.cnf"
    target = tmp_path / "target.cnf"
    target.write_text("x")
    link.symlink_to(target)
    assert run(["ground", str(lamp), "--maxstep", "1", "--dimacs", str(old)], capsys)[0] == 0
    assert run(["ground", str(lamp), "--maxstep", "1", "--dimacs", str(link)], capsys)[0] == 0
    assert old.read_text().startswith("c ") and keep.read_text() == "old"      # renamed over, not rewritten
    assert stat.S_IMODE(old.stat().st_mode) == 0o640
    assert link.is_symlink() and target.read_text() == old.read_text()       # a link is written through
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.cnf", "lamp.cp", "old.cnf", "target.cnf", "via.cnf"]


def test_a_fifo_is_written_through(tmp_path, capsys):
    import threading
    lamp = tmp_path / "lamp.cp"
    shutil.copy(ROOT / "domains/examples/lamp.cp", lamp)
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()), daemon=True)
    reader.start()
    jobs = tmp_path / "jobs.jsonl"
    jobs.write_text('{"domain": "lamp.cp"}\n')
    code, _, err = run(["batch", str(jobs), "--csv", str(fifo), "--quiet"], capsys)
    reader.join(60)
    assert code == 0 and not reader.is_alive()
    assert got[0].startswith("id,status,maxstep") and "\nlamp,no_plan_proved," in got[0]    # lamp's `maxstep :: any` query
    assert stat_kind(fifo) == "fifo"


def stat_kind(path: Path) -> str:
    import stat
    mode = os.lstat(path).st_mode
    return "fifo" if stat.S_ISFIFO(mode) else "link" if stat.S_ISLNK(mode) else "file" if stat.S_ISREG(mode) else "?"


# -- numbers on the command line: honoured or refused with the range ---------------------------------

@pytest.mark.parametrize("argv, message", [
    (["online", "DELIVERY", "--simulate", "--action-time", "1e300"],
     "argument --action-time: at most 3600 seconds, got '1e300'"),
    (["serve", "MAILBOT", "--script", "SCRIPT", "--action-time", "1e300"],
     "argument --action-time: at most 3600 seconds, got '1e300'"),
    (["online", "DELIVERY", "--time-scale", "1e-300"],
     "argument --time-scale: must be at least 0.001 and at most 1000 times real time, got '1e-300'"),
    (["serve", "MAILBOT", "--script", "SCRIPT", "--time-scale", "1e300"],
     "argument --time-scale: must be at least 0.001 and at most 1000 times real time, got '1e300'"),
    (["execute", "T", "--time-scale", "1e300"],
     "argument --time-scale: must be at least 0.001 and at most 1000 times real time, got '1e300'"),
    (["run", "PAYLOAD", "--time-scale", "1e-300"],
     "argument --time-scale: must be at least 0.001 and at most 1000 times real time, got '1e-300'"),
    (["brick", "--name", "r1", "--time-scale", "1e300"],
     "argument --time-scale: must be at least 0.001 and at most 1000 times real time, got '1e300'"),
    (["brick", "--name", "r1", "--battery-mv", "70000"],
     "argument --battery-mv: must be at least 1000 and at most 12000 millivolts, got '70000'"),
    (["brick", "--name", "r1", "--backlash-deg", "1e308"],
     "argument --backlash-deg: must be at least 0 and at most 45 degrees, got '1e308'"),
    (["brick", "--name", "r1", "--delay", "1e300"],
     "argument --delay: must be at least 0 and at most 10000 milliseconds, got '1e300'"),
    (["batch", "JOBS", "--timeout", "1e300"], "argument --timeout: must be > 0 and at most 1,000,000 seconds"),
    (["batch", "JOBS", "--workers", "100000000000000000000"], "argument --workers: expected a positive integer up to"),
    (["batch", "JOBS", "--portfolio", ",".join(["glucose4"] * 40)], "argument --portfolio: 'glucose4' twice"),
    (["plan", "LAMP", "--jobs", "100000000000000000000"],
     "argument --jobs/-j: expected a positive integer up to 1024 (worker processes), or auto, got an integer of 21"),
    (["plan", "LAMP", "-q", ""], "argument --query/-q: expected a query label, got an empty one"),
    (["plan", "LAMP", "--solver", ""], "argument --solver: an empty solver name"),
    (["plan", "LAMP", "--minimize", ""], "argument --minimize: expected a term to minimize"),
    (["plan", "LAMP", "--time-limit", "1e300"], "argument --time-limit: must be > 0 and at most 1,000,000 seconds"),
    (["plan", "LAMP", "--max-horizon", "1" + "0" * 30], "argument --max-horizon: expected a non-negative maxstep"),
    (["plan", "LAMP", "--minimise", "cost"], "unrecognized arguments: --minimise cost (did you mean --minimize?)"),
    (["run", "PAYLOAD", "--solver", "glucose"], "argument --solver: unknown SAT solver 'glucose' (did you mean"),
])
def test_a_number_or_a_name_out_of_range_is_one_line_with_the_range(tmp_path, capsys, argv, message):
    _sandbox(tmp_path)
    capsys.readouterr()                 # what building the sandbox's trajectory printed
    names = {"DELIVERY": "delivery.cp", "MAILBOT": "mailbot.cp", "SCRIPT": "table1.jsonl", "T": "t.json",
             "PAYLOAD": "task/payload.cp", "JOBS": "jobs.jsonl", "LAMP": "lamp.cp"}
    code, out, err = run([str(tmp_path / names[a]) if a in names else a for a in argv], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert err.startswith(f"cplus {argv[0]}: error: ") and message in err, err


def test_the_emulator_configuration_is_checked_where_it_is_built():
    """A caller that builds the options itself (not through the parser) gets the same range."""
    from cplus.cli.brick import build_parser, config_from_args
    args = build_parser().parse_args(["--name", "r1"])
    args.battery_mv = 70000
    with pytest.raises(ValueError, match="--battery-mv 70000: must be at least 1000 and at most 12000"):
        config_from_args(args)


def test_a_solver_that_does_not_exist_is_refused_before_any_query_runs(tmp_path, capsys):
    domain = tmp_path / "two.cp"
    domain.write_text((ROOT / "domains/examples/lamp.cp").read_text())
    code, out, err = run(["plan", str(domain), "--solver", "glucose"], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and "% query" not in out + err


def test_an_unlocated_error_of_the_library_has_the_command_prefix(tmp_path, capsys):
    """``--over-lengths`` on an open range without ``--max-horizon``: the planner's error has no
    place in a file; the command says whose it is."""
    domain = tmp_path / "open.cp"
    domain.write_text(":- maxAdditive :: 9.\n:- constants c :: additiveFluent(0..9); a :: exogenousAction.\n"
                      "a increments c by 1.\n:- query maxstep :: 1..infinity; 0: c=0; maxstep: c=1.\n")
    code, _, err = run(["plan", str(domain), "--minimize", "c", "--over-lengths"], capsys)
    assert code == 2 and err.startswith("cplus plan: error: --over-lengths searches every length") and \
        err.count("\n") == 1


def test_a_time_limit_never_ends_the_search_before_the_first_plan(tmp_path, capsys):
    """The tiniest limit still waits for the first plan: exit 12 with a plan and its bound, never
    'no solution' (exit 3) for a query that has plans."""
    vacuum = ROOT / "domains/examples/vacuum.cp"
    code, out, err = run(["plan", str(vacuum), "--minimize", "cost", "--over-lengths", "--time-limit", "0.000001"],
                         capsys)
    assert code == 12, err
    assert "ACTIONS:" in out and "(not proved optimal (--time-limit)" in out and "no solution up to" not in err


def test_jobs_start_no_more_workers_than_horizons(tmp_path, capsys):
    import json
    one = tmp_path / "one.cp"
    one.write_text(":- constants lit :: inertialFluent; flip :: exogenousAction.\nflip causes lit.\n"
                   ":- query maxstep :: 3; 0: -lit; maxstep: lit.\n")
    code, out, _ = run(["plan", str(one), "--jobs", "64", "--json"], capsys)
    par = json.loads(out)["results"][0]["parallel"]
    assert code == 0 and par["jobs_asked"] == 64 and par["jobs"] == 1 and {r["worker"] for r in par["runs"]} == {0}


@given(st.integers(1, 10 ** 6), st.one_of(st.none(), st.integers(1, 10 ** 6)))
def test_the_worker_bound_never_exceeds_the_cores_nor_what_can_work(asked, useful):
    from cplus.options import WORKERS_PER_CORE, available_cores, worker_bound
    n = worker_bound(asked, useful)
    assert 1 <= n <= min(asked, WORKERS_PER_CORE * available_cores(), useful or asked)


def test_a_race_runs_no_more_variants_at_once_than_the_bound(tmp_path, monkeypatch):
    """A portfolio of more solvers than the bound allows at once: they run in turn, and the
    race still has its answer."""
    import multiprocessing

    from cplus.batch import read_jobs
    from cplus.cli import batch_job
    monkeypatch.setattr("cplus.options.available_cores", lambda: 1)
    monkeypatch.setattr("cplus.options.WORKERS_PER_CORE", 2)
    ctx = multiprocessing.get_context("fork")
    live: list = []
    most = [0]

    class Counted(ctx.Process):  # type: ignore[name-defined,misc]
        def start(self) -> None:
            super().start()
            live.append(self)
            most[0] = max(most[0], sum(p.is_alive() for p in live))
    monkeypatch.setattr(ctx, "Process", Counted)
    jobs = tmp_path / "j.jsonl"
    jobs.write_text('{"domain": "%s", "query": "on", "portfolio": ["glucose4", "minisat22", "cadical195", '
                    '"maplesat", "glucose3"]}\n' % (ROOT / "domains/examples/lamp.cp"))
    rec = batch_job.run_job(read_jobs(str(jobs))[0].to_dict())
    assert rec["status"] == "found" and rec["portfolio"]["winner"] in rec["portfolio"]["variants"]
    assert 1 <= most[0] <= 2 and len(live) <= 5


# -- standard output that cannot be written ---------------------------------------------------------

@pytest.mark.parametrize("how", ["full", "closed"])
def test_standard_output_that_cannot_be_written_is_one_line(how):
    import subprocess
    import sys
    cmd = [sys.executable, "-m", "cplus", "plan", str(ROOT / "domains/examples/lamp.cp")]
    if how == "full":
        with open("/dev/full", "w") as full:
            r = subprocess.run(cmd, stdout=full, stderr=subprocess.PIPE, text=True, cwd=ROOT, timeout=120)
    else:
        r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, cwd=ROOT, timeout=120,
                           preexec_fn=lambda: os.close(1))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.startswith("cplus plan: error: cannot write standard output: ")
    assert ("No space left on device" if how == "full" else "standard output is closed") in r.stderr
