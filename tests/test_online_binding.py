"""The binding file (robot.toml, cplus.robot/1): validation with located errors, roles, the
mapping of readings to fluent values."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus.api import Domain
from cplus.robot.online.binding import BindingError, load_binding, parse_binding
from cplus.robot.online.estimation import Act

ROOT = Path(__file__).resolve().parent.parent
DELIVERY = ROOT / "domains" / "delivery"

DOMAIN = """
:- sorts place. :- objects 1..3 :: place. :- variables P :: place.
:- constants at :: inertialFluent(place); dark, lit :: inertialFluent;
  goto(place) :: exogenousAction; speed(place) :: attribute(1..5) of goto(place);
  bump, call(place), night, slip :: exogenousAction.
goto(P) causes at=P.  bump causes dark.  night causes dark.  call(P) causes lit.
:- query label :: g; maxstep :: 0..3; 0: at=1 & -dark & -lit; maxstep: at=3.
"""

GOOD = """format = "cplus.robot/1"
[bricks.r]
sensors = { S1 = "touch", S3 = "light" }
[actions.goto]
brick = "r"
behaviour = 7
args = ["$1", "$speed", 12]
[events.bump]
source = "brick"
brick = "r"
event = "button"
[events.call]
source = "brick"
brick = "r"
event = "event 2"
[events.night]
source = "sensor"
brick = "r"
port = "S3"
below = 20
[events.slip]
source = "inferred"
[sensed.at]
brick = "r"
value = "landmark"
ignore = [0]
[sensed.dark]
brick = "r"
port = "S3"
thresholds = [40]
values = [true, false]
[sensed.lit]
brick = "r"
port = "S1"
"""


@pytest.fixture(scope="module")
def domain():
    return Domain.from_text(DOMAIN, "d.cp")


def parse(text: str, domain):
    return parse_binding(text, "robot.toml", domain)


def test_a_good_binding(domain):
    b = parse(GOOD, domain)
    roles = b.roles()
    assert sorted(gc.text for gc in roles.agent) == ["goto(1)", "goto(2)", "goto(3)"]
    assert sorted(gc.text for gc in roles.observed) == ["bump", "call(1)", "call(2)", "call(3)", "night"]
    assert [gc.text for gc in roles.inferred] == ["slip"]
    assert b.bricks["r"].sensors == {"S1": "touch", "S3": "light"}
    assert b.input_events() == [] and b.input_events(simulated=True) == sorted(
        ["bump", "call(1)", "call(2)", "call(3)", "night"])
    assert b.brick_event("r", "event 2", (2, 9)).text == "call(2)"
    assert b.brick_event("r", "button", ()).text == "bump"
    assert b.brick_event("r", "horn", ()) is None


def test_action_arguments_come_from_the_action_and_its_attributes(domain):
    b = parse(GOOD, domain)
    sig = domain.program.signature
    goto2 = sig.lookup("goto", 1).instances[(2,)]
    speed = sig.lookup("speed", 1).instances[(2,)]
    act = Act(goto2, "true", {speed: 4}, "goto(2,speed=4)")
    assert b.actions[goto2].call_args(act) == (2, 4, 12)


def test_readings_map_to_values(domain):
    b = parse(GOOD, domain)
    by = {gc.text: s for gc, s in b.sensed.items()}
    assert by["at"].map(0) is None and by["at"].map(2) == 2 and by["at"].map(9) == 9
    assert by["dark"].map(10) == "true" and by["dark"].map(40) == "false"
    assert by["lit"].map(1) == "true" and by["lit"].map(0) == "false"
    night = next(e for gc, e in b.events.items() if gc.text == "night")
    assert night.crossed(None, 10) and night.crossed(30, 10) and not night.crossed(10, 5) and not night.crossed(25, 30)


@settings(max_examples=50)
@given(st.lists(st.integers(-100, 200), min_size=1, max_size=4, unique=True).map(sorted), st.integers(-500, 500))
def test_thresholds_pick_the_interval_of_the_reading(thresholds, reading):
    d = Domain.from_text(":- constants lvl :: inertialFluent(0..9).\n:- query label :: g; maxstep :: 0; 0: lvl=0.")
    values = list(range(len(thresholds) + 1))
    text = (f'format = "cplus.robot/1"\n[bricks.r]\nsensors = {{ S2 = "light" }}\n[sensed.lvl]\nbrick = "r"\n'
            f'port = "S2"\nthresholds = {thresholds}\nvalues = {values}\n')
    s = next(iter(parse(text, d).sensed.values()))
    expected = sum(1 for t in thresholds if reading >= t)
    assert s.map(reading) == expected
    assert expected == 0 or reading >= thresholds[expected - 1]
    assert expected == len(thresholds) or reading < thresholds[expected]


def test_the_delivery_binding_loads():
    d = Domain.load(str(DELIVERY / "delivery.cp"))
    b = load_binding(str(DELIVERY / "robot.toml"), d)
    assert sorted(gc.text for gc in b.roles().agent) == ["follow", "lowerTray", "raiseTray", "turn"]
    assert b.bricks["robot"].world is not None and b.bricks["robot"].world.name == "world.toml"
    assert [a.behaviour for gc, a in sorted(b.actions.items(), key=lambda kv: kv[1].behaviour)] == [1, 2, 3, 4]


def edit(old: str, new: str) -> str:
    assert old in GOOD
    return GOOD.replace(old, new)


BAD = [
    ("unsupported", edit('format = "cplus.robot/1"', 'format = "cplus.robot/9"'),
     "unsupported binding format 'cplus.robot/9'", "robot.toml:1:1"),
    ("toml", edit("behaviour = 7", "behaviour = = 7"), "invalid TOML", "robot.toml:6:13"),
    ("top", GOOD + "[motors]\n", "unknown top-level field 'motors'", "robot.toml:35:1"),
    ("unknown action", edit("[actions.goto]", "[actions.gogo]"), "unknown action constant 'gogo'", "robot.toml:4:1"),
    ("fluent as action", edit("[events.slip]", "[events.at]"), "'at' is an inertialFluent of d.cp, not an action",
     "robot.toml:21:1"),
    ("unbound action", edit("[events.slip]\nsource = \"inferred\"\n", ""), "action 'slip' has no binding",
     "d.cp:5:29"),
    ("twice", edit("[events.slip]", "[events.goto]"), "goto(1) is bound both as the robot's action and as an event",
     "robot.toml:21:1"),
    ("unknown brick", edit('behaviour = 7', 'behaviour = 7\n').replace('brick = "r"\nbehaviour', 'brick = "q"\n'
                                                                       'behaviour'),
     "unknown brick 'q' (the [bricks] of this file: r)", "robot.toml:5:1"),
    ("behaviour range", edit("behaviour = 7", "behaviour = 300"), "actions.goto.behaviour = 300 is outside 1..255",
     "robot.toml:6:1"),
    ("behaviour type", edit("behaviour = 7", 'behaviour = "follow"'), "must be an integer, not a string",
     "robot.toml:6:1"),
    ("arg", edit('args = ["$1", "$speed", 12]', 'args = ["$2"]'), "$2: goto(1) has 1 argument(s)", "robot.toml:7:9"),
    ("attr", edit('args = ["$1", "$speed", 12]', 'args = ["$colour"]'), "goto has no attribute 'colour'",
     "robot.toml:7:9"),
    ("arg text", edit('args = ["$1", "$speed", 12]', 'args = ["fast"]'), "write an integer, \"$N\"",
     "robot.toml:7:9"),
    ("motor port sensor", edit('sensors = { S1 = "touch", S3 = "light" }', 'sensors = { A = "touch", S3 = "light" }'),
     "port A is a motor port; sensors are on S1, S2, S3, S4", "robot.toml:3:13"),
    ("motor port sensed", edit('port = "S1"\n', 'port = "B"\n'), "port B is a motor port", "robot.toml:34:1"),
    ("undeclared port", edit('port = "S1"\n', 'port = "S4"\n'), "brick 'r' has no sensor on S4", "robot.toml:34:1"),
    ("sensor type", edit('S3 = "light"', 'S3 = "laser"'), "expected one of touch, light", "robot.toml:3:27"),
    ("source", edit('source = "inferred"', 'source = "magic"'), "events.slip.source = 'magic'", "robot.toml:22:1"),
    ("source field", edit('source = "inferred"', 'source = "inferred"\nbrick = "r"'),
     "'brick' has no meaning for an event from source 'inferred'", "robot.toml:23:1"),
    ("sensor event", edit("below = 20", "below = 20\nabove = 90"), "exactly one of 'below' or 'above'",
     "robot.toml:16:1"),
    ("missing", edit('event = "button"\n', ''), "missing required field 'event' in events.bump", "robot.toml:8:1"),
    ("value and port", edit('value = "landmark"', 'value = "landmark"\nport = "S1"'),
     "exactly one of 'value'", "robot.toml:23:1"),
    ("values count", edit("values = [true, false]", "values = [true]"), "1 threshold(s) need 2 values, not 1",
     "robot.toml:31:1"),
    ("value domain", edit("values = [true, false]", "values = [true, 3]"), "3 is not a value of dark",
     "robot.toml:31:17"),
    ("thresholds order", edit("thresholds = [40]", "thresholds = [40, 10]"), "increasing integers",
     "robot.toml:30:1"),
    ("not a fluent", edit("[sensed.lit]", "[sensed.bump]"), "'bump' is an exogenousAction of d.cp, not a fluent",
     "robot.toml:32:1"),
    ("stop event", edit("args = [\"$1\", \"$speed\", 12]", "args = [\"$1\", \"$speed\", 12]\nstop = \"slip\""),
     "stop = 'slip': bind the event slip with source = \"stop\" in [events] (events from source stop: none)",
     "robot.toml:8:1"),
]


def test_an_action_that_may_be_stopped_names_its_stop_event(domain):
    text = edit('args = ["$1", "$speed", 12]', 'args = ["$1", "$speed", 12]\nstop = "slip"').replace(
        'source = "inferred"', 'source = "stop"')
    b = parse(text, domain)
    assert {a.stop.text for a in b.actions.values()} == {"slip"}
    assert {gc.text for gc in b.roles().observed} >= {"slip"}


@pytest.mark.parametrize("name, text, message, where", BAD, ids=[b[0] for b in BAD])
def test_errors_are_located(domain, name, text, message, where):
    with pytest.raises(BindingError) as info:
        parse(text, domain)
    rendered = info.value.render()
    assert message in rendered
    assert rendered.startswith(where + ": error:"), rendered


def test_a_missing_file_is_one_line(domain, tmp_path):
    with pytest.raises(BindingError, match="cannot read binding file"):
        load_binding(str(tmp_path / "nope.toml"), domain)
