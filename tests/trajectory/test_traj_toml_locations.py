"""Key positions in TOML text: what scene errors point at."""

from __future__ import annotations

import string
import tomllib

from hypothesis import given
from hypothesis import strategies as st

from trajectory.toml_locations import locate_keys, nearest_location

DOC = '''# a comment with [brackets] and "quotes"
format = "cplus.scene/1"   # trailing comment
title = "a # not a comment [x]"

[grid]
x_min = 0
  x_max = 12

[[obstacles]]
name = "wall"
points = [
  [0, 0],  # first
  [1, 0],
  [1, 1],
]

[[obstacles]]
points = [[5, 5], [6, 5], [6, 6], [5, 5]]

[robots.r1]
motors = [ { port = "A", joint = "s" },
           { port = "B" } ]
"quoted key" = 1
bindings.x = "xpos(r1)"
text = """multi
line = not a key
"""
after = true

[robots.r1.extra]
z = 1
'''


def at(text: str, line: int, col: int) -> str:
    return text.splitlines()[line - 1][col - 1:]


def test_every_key_points_at_its_text() -> None:
    locs = locate_keys(DOC)
    expected = {
        ("format",): "format",
        ("title",): "title",
        ("grid",): "[grid]",
        ("grid", "x_min"): "x_min",
        ("grid", "x_max"): "x_max",
        ("obstacles", 0): "[[obstacles]]",
        ("obstacles", 0, "name"): "name",
        ("obstacles", 0, "points"): "points",
        ("obstacles", 0, "points", 1): "[1, 0]",
        ("obstacles", 0, "points", 2, 1): "1]",
        ("obstacles", 1, "points", 3): "[5, 5]]",
        ("robots", "r1"): "[robots.r1]",
        ("robots", "r1", "motors", 0, "port"): 'port = "A"',
        ("robots", "r1", "motors", 1, "port"): 'port = "B"',
        ("robots", "r1", "quoted key"): '"quoted key"',
        ("robots", "r1", "bindings", "x"): 'x = "xpos',
        ("robots", "r1", "after"): "after",
        ("robots", "r1", "extra", "z"): "z = 1",
    }
    for path, prefix in expected.items():
        line, col = locs[path]
        assert at(DOC, line, col).startswith(prefix), (path, line, col)


def test_strings_and_comments_do_not_create_keys() -> None:
    locs = locate_keys(DOC)
    assert ("robots", "r1", "line") not in locs  # inside a multi-line string
    assert not any("brackets" in str(p) for p in locs)
    assert locs[("obstacles", 1, "points")][0] == DOC.splitlines().index(
        "points = [[5, 5], [6, 5], [6, 6], [5, 5]]") + 1


def test_missing_keys_fall_back_to_their_table() -> None:
    locs = locate_keys(DOC)
    assert nearest_location(locs, ("grid", "y_min")) == locs[("grid",)]
    assert nearest_location(locs, ("payload", "length")) == (1, 1)


_keys = st.text(alphabet=string.ascii_lowercase + "_", min_size=1, max_size=8)


_values = st.integers(-99, 99) | st.lists(st.integers(0, 9), max_size=3)
_tables = st.dictionaries(_keys, _values, min_size=1, max_size=4)


@given(st.dictionaries(_keys, _tables, min_size=1, max_size=4), st.integers(0, 3))
def test_generated_documents(tables: dict[str, dict[str, object]], indent: int) -> None:
    """Every key of a generated document is found at its line and column."""
    lines: list[str] = []
    for table, body in tables.items():
        lines.append(f"[{table}]")
        for key, value in body.items():
            lines.append(" " * indent + f"{key} = {value}  # {key}")
    text = "\n".join(lines) + "\n"
    assert tomllib.loads(text)  # the generator writes valid TOML
    locs = locate_keys(text)
    for table, body in tables.items():
        line, col = locs[(table,)]
        assert at(text, line, col) == f"[{table}]"
        for key in body:
            line, col = locs[(table, key)]
            assert at(text, line, col).startswith(f"{key} = ")
            assert text.splitlines()[line - 1].startswith(" " * indent + key)
