"""Continuing a server's log (cplus.robot.serving.serve_log.open_log): where the goal ids go on
from, a line cut off by a crash, and files that are not such a log."""
from __future__ import annotations

import json

import pytest

from cplus.robot.serving.serve_log import LogRefused, open_log

START = {"record": "start", "format": "cplus.online/1", "domain": "mailbot.cp"}


def write(path, records, tail: str = "") -> None:
    path.write_text("".join(json.dumps(r) + "\n" for r in records) + tail)


def last_id(path) -> int:
    stream, history = open_log(str(path))
    stream.close()
    assert history is not None
    return history.last_goal_id


def test_ids_go_on_from_the_highest_one_the_log_names(tmp_path):
    log = tmp_path / "run.jsonl"
    # cplus.serve/2 named goals in cycle records and in the end record
    write(log, [START, {"record": "cycle", "cycle": 1, "goals": [{"id": 1}, {"id": 2}]},
                {"record": "end", "goals": [{"id": 2}, {"id": 3}]}])
    assert last_id(log) == 3
    # goal records; an older goal's record after a newer one's
    write(log, [START, {"record": "goal", "id": 7}, {"record": "goal", "id": 8}, {"record": "goal", "id": 5}])
    assert last_id(log) == 8
    # a run that had no goal still took its first id: the next starts after it
    write(log, [START, {"record": "goal", "id": 4}, {**START, "first_goal_id": 10}, {"record": "end", "goals": []}])
    assert last_id(log) == 9
    # the scan stops at the last run that says where its ids began
    write(log, [START, {"record": "goal", "id": 40}, {**START, "first_goal_id": 41},
                *({"record": "cycle", "cycle": k, "pad": "x" * 200} for k in range(2000)),
                {"record": "goal", "id": 41}])
    assert last_id(log) == 41
    # a plain cplus online log: no goals
    write(log, [START, {"record": "cycle", "cycle": 0}, {"record": "end"}])
    assert last_id(log) == 0


def test_a_line_cut_off_by_a_crash_is_removed(tmp_path):
    log = tmp_path / "run.jsonl"
    write(log, [START, {"record": "goal", "id": 1}], tail='{"record": "goal", "id": 2, "sta')
    stream, history = open_log(str(log))
    stream.write("next\n")
    stream.close()
    assert history is not None and history.repaired == len('{"record": "goal", "id": 2, "sta')
    assert history.last_goal_id == 1
    assert log.read_text().splitlines()[-2:] == ['{"record": "goal", "id": 1}', "next"]


@pytest.mark.parametrize("content", [b"my notes\n", b"\xff\xfe\x00binary", b'{"record": "start"}\n',
                                     b'{"record": "cycle", "format": "cplus.online/1"}\n', b"[1, 2]\n"])
def test_a_file_of_another_kind_is_refused_and_left_as_it_is(tmp_path, content):
    log = tmp_path / "other.txt"
    log.write_bytes(content)
    with pytest.raises(LogRefused, match="is not a cplus.online/1 log"):
        open_log(str(log))
    assert log.read_bytes() == content
    stream, history = open_log(str(log), overwrite=True)
    stream.close()
    assert history is None and log.read_bytes() == b""
