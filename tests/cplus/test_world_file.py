"""World files (cplus.world/1): every section, and every error located at file:line:col."""
from __future__ import annotations

from pathlib import Path

import pytest

from cplus.robot.online.world_file import WorldFileError, load_world, parse_world
from nxt_link.emulator.world import Blocked, Landmark, Markers, Press, RobotBody, Start

ROOT = Path(__file__).resolve().parents[2]

FULL = """\
format = "cplus.world/1"
name = "corridor"
seed = 7
noise_percent = 0.5

[track]
points = [[0, 0], [2000, 0], [2000, 1500]]
width_mm = 25
line_percent = 25
floor_percent = 65

[[landmarks]]
number = 1
at_mm = 300
name = "mail room"

[[landmarks]]
number = 2
at_mm = 2500
misses = 1

[[landmarks]]
number = 3
at_mm = 3000
visible = false

[start]
at_mm = 100
direction = "backward"

[ports]
touch = 1
light = 3
left = "b"
right = "C"
tray = "A"

[robot]
wheel_diameter_mm = 43.2
axle_track_mm = 120

[markers]
bar_mm = 12
bar_percent = 95

[[presses]]
at_s = 3
hold_s = 1

[[presses]]
at_landmark = 2
visit = 2
delay_s = 0.5

[[blocked]]
from_mm = 1000
to_mm = 1100
times = 2
"""


def test_every_section_is_read():
    w = parse_world(FULL)
    assert (w.name, w.seed, w.noise_percent) == ("corridor", 7, 0.5)
    assert w.track.points_mm == ((0.0, 0.0), (2000.0, 0.0), (2000.0, 1500.0))
    assert (w.track.width_mm, w.track.line_percent, w.track.floor_percent) == (25.0, 25.0, 65.0)
    assert w.track.length_mm == 3500.0
    assert w.landmarks == (Landmark(1, 300.0, "mail room"), Landmark(2, 2500.0, misses=1),
                           Landmark(3, 3000.0, visible=False))
    assert w.start == Start(at_mm=100.0, direction=-1)
    assert (w.ports.left, w.ports.right, w.ports.tray, w.ports.touch, w.ports.light) == (
        1, 2, 0, 0, 2)
    assert w.robot == RobotBody(wheel_diameter_mm=43.2, axle_track_mm=120.0)
    assert w.markers == Markers(bar_mm=12.0, bar_percent=95.0)
    assert w.presses == (Press(at_s=3.0, hold_s=1.0),
                         Press(at_landmark=2, visit=2, delay_s=0.5))
    assert w.blocked == (Blocked(1000.0, 1100.0, 2),)


def test_the_delivery_world_loads():
    w = load_world(ROOT / "domains" / "delivery" / "world.toml")
    assert [lm.name for lm in w.landmarks] == ["office1", "office2", "office3", "office4"]
    assert w.start.landmark == 1 and w.presses == (Press(at_s=4.0),)


def test_defaults():
    w = parse_world('format = "cplus.world/1"\n[track]\npoints = [[0, 0], [500, 0]]\n'
                    '[start]\nat_mm = 0\n', "plain.toml")
    assert w.name == "plain" and w.noise_percent == 1.0 and w.landmarks == ()
    assert w.start.direction == 1 and w.seed is None


BASE = 'format = "cplus.world/1"\n[track]\npoints = [[0, 0], [1000, 0]]\n[start]\nat_mm = 10\n'


@pytest.mark.parametrize("text, where, message", [
    ("format = 1\n", "1:1", "format must be a string, not a number"),
    ('format = "cplus.world/2"\n', "1:1", "unsupported world format 'cplus.world/2'"),
    ('format = "cplus.world/1"\n[start]\nat_mm = 1\n', "1:1", "missing required field 'track'"),
    (BASE + "colour = 3\n", "6:1", "unknown field 'colour' in start"),
    (BASE + "[tracks]\n", "6:1", "unknown top-level field 'tracks'"),
    (BASE.replace("[[0, 0], [1000, 0]]", "[[0, 0]]"), "3:1", "at least two [x, y] points"),
    (BASE.replace("[[0, 0], [1000, 0]]", "[[0, 0], [1000]]"), "3:19", "track.points[1] must be "
                                                                       "a point [x, y]"),
    (BASE.replace("[[0, 0], [1000, 0]]", '[[0, 0], [1000, "x"]]'), "3:26",
     "track.points[1][1] must be a number, not a string"),
    (BASE.replace("[[0, 0], [1000, 0]]", "[[0, 0], [0, 0]]"), "2:1", "two consecutive track "
                                                                     "points are equal"),
    (BASE + "[[landmarks]]\nnumber = 1\nat_mm = 995\n", "8:1", "landmark 1 (995..1005 mm) is "
                                                               "not on the track"),
    (BASE + "[[landmarks]]\nnumber = 1\nat_mm = 100\n[[landmarks]]\nnumber = 1\nat_mm = 500\n",
     "10:1", "landmark 1 is defined twice"),
    (BASE + "[[landmarks]]\nnumber = 16\nat_mm = 100\n", "7:1", "number = 16 is outside 1..15"),
    (BASE + "[[landmarks]]\nnumber = 1.5\nat_mm = 100\n", "7:1", "must be an integer"),
    (BASE + "[[landmarks]]\nnumber = 1\nat_mm = 100\nvisible = 1\n", "9:1", "true or false"),
    (BASE.replace("at_mm = 10", "at_mm = 10\nlandmark = 1"), "6:1", "no landmark 1"),
    (BASE.replace("at_mm = 10", 'direction = "left"'), "5:1", "\"forward\" or \"backward\""),
    (BASE.replace("at_mm = 10", "at_mm = 5000"), "4:1", "the start (5000 mm) is not on the track"),
    (BASE.replace("at_mm = 10", ""), "4:1", "exactly one of at_mm and landmark"),
    (BASE + "[ports]\nlight = 5\n", "7:1", "ports.light must be an input port 1..4, not 5 "
                                           "(sensors go on input ports"),
    (BASE + '[ports]\nleft = "D"\n', "7:1", "ports.left must be an output port"),
    (BASE + "[ports]\ntouch = 2\n", "7:1", "ports.touch: the brick program cplus_legolog.rxe "
                                           "uses port 1 for it"),
    (BASE + '[ports]\ntray = "B"\n', "6:1", "three different output ports"),
    (BASE + "[robot]\naxle_track_mm = 0\n", "6:1", "axle_track_mm must be a positive number"),
    (BASE + "[markers]\nbar_percent = 120\n", "6:1", "bar_percent must be a percentage"),
    (BASE + "[[presses]]\nhold_s = 1\n", "6:1", "exactly one of at_s and at_landmark"),
    (BASE + "[[presses]]\nat_landmark = 4\n", "7:1", "no landmark 4"),
    (BASE + "[[presses]]\nat_s = -1\n", "7:1", "presses[0].at_s = -1 is outside 0..1e+09"),
    (BASE + "[[blocked]]\nfrom_mm = 5\nto_mm = 20\n", "4:1", "starts inside a blocked stretch"),
    (BASE + "[[blocked]]\nfrom_mm = 50\nto_mm = 20\n", "6:1", "from_mm < to_mm"),
    (BASE + "[[blocked]]\nfrom_mm = 50\n", "6:1", "missing required field 'to_mm'"),
    (BASE + "presses = 3\n", "6:1", "unknown field 'presses' in start"),
    ("presses = 3\n" + BASE, "1:1", "presses must be an array of tables"),
    (BASE + "noise_percent = 30\n", "6:1", "unknown field 'noise_percent' in start"),
    ("noise_percent = 30\n" + BASE, "1:1", "noise_percent must be in 0..20"),
    (BASE + "[track\n", "6:7", "invalid TOML"),
])
def test_errors_are_located(text, where, message):
    with pytest.raises(WorldFileError) as exc:
        parse_world(text, "w.toml")
    rendered = exc.value.render()
    assert rendered.startswith(f"w.toml:{where}: error: "), rendered
    assert message in rendered.splitlines()[0]
    assert "\n  " in rendered  # the line and a caret follow


def test_unreadable_files(tmp_path):
    with pytest.raises(WorldFileError, match="cannot read world file"):
        load_world(tmp_path / "missing.toml")
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(WorldFileError, match="not UTF-8"):
        load_world(binary)
