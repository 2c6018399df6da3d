"""The Python API as a newcomer calls it: a session's loop that keeps what it blocked, the
state of a history by name, the count of solutions refused when negative, and a refinement's
``store.excludes`` given what the refinement hands out."""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import Domain

ROOT = Path(__file__).resolve().parents[2]
LAMP = str(ROOT / "domains" / "examples" / "lamp.cp")
PAYLOAD = ROOT / "domains" / "payload"


def test_the_natural_loop_ends_with_every_history_once():
    """solve_at, block_current, solve_at again at the same horizon: what was blocked stays
    blocked, so the loop ends after the query's 3 histories (it never ended when solve_at
    opened the horizon afresh)."""
    d = Domain.load(LAMP)
    session = d.session("0")
    seen = []
    while session.solve_at(1):
        seen.append(session.history().key())
        session.block_current()
        assert len(seen) <= 3
    assert len(seen) == len(set(seen)) == 3
    assert set(seen) == {h.key() for h in d.solve("0", solutions=0).histories}


def test_histories_enumerates_what_is_not_blocked_and_blocks_it():
    d = Domain.load(LAMP)
    session = d.session("0")
    every = list(session.histories())            # the shortest horizon with one
    assert {h.maxstep for h in every} == {1} and len(every) == 3
    assert list(session.histories(1)) == [] and not session.solve_at(1)
    assert session.solve_at(2)                   # a longer horizon starts from what it allows


@settings(max_examples=10, deadline=None)
@given(st.integers(min_value=0, max_value=3))
def test_blocking_some_then_enumerating_gives_the_rest(k):
    d = Domain.load(LAMP)
    every = {h.key() for h in d.solve("0", solutions=0).histories}
    session = d.session("0")
    blocked = set()
    for _ in range(k):
        if not session.solve_at(1):
            break
        blocked.add(session.history().key())
        session.block_current()
    rest = {h.key() for h in session.histories(1)}
    assert rest | blocked == every and not rest & blocked


def test_a_session_says_what_it_cannot_do():
    session = Domain.load(LAMP).session("0")
    with pytest.raises(ValueError, match=r"^no history: call solve_at\(m\) first$"):
        session.history()
    with pytest.raises(ValueError, match=r"call solve_at\(m\) first"):
        session.resolve()
    assert not session.solve_at(0)
    with pytest.raises(ValueError, match=r"^no history to block: the last solve \(horizon 0\) found no history$"):
        session.block_current()
    assert session.solve_at(2)
    with pytest.raises(ValueError, match=r"^horizon 1 is below 2, the one this session solved last"):
        session.solve_at(1)
    with pytest.raises(ValueError, match=r"^horizon 2 is already open \(this session is at horizon 2\)"):
        session.open_horizon(2)


def test_state_values_are_the_fluents_by_name():
    d = Domain.from_text(":- constants lit :: inertialFluent; flip :: exogenousAction.\nflip causes lit.\n"
                         ":- query label :: on; maxstep :: 1; 0: -lit; 1: lit.")
    hist = d.solve("on").histories[0]
    assert hist.state_values(0) == {"lit": False} and hist.state_values(1) == {"lit": True}
    assert not hasattr(hist, "state_text")


@pytest.mark.parametrize("bad", [-1, -5, 1.5, "2", True, None])
def test_a_count_of_solutions_that_is_not_one_is_refused(bad):
    d = Domain.load(LAMP)
    with pytest.raises(ValueError) as e:
        d.solve("0", solutions=bad)
    assert str(e.value) == f"solutions must be a non-negative integer (0: every history), not {bad!r}"
    assert len(d.solve("0", solutions=0).histories) == 3 and len(d.solve("0", solutions=2).histories) == 2


def test_the_store_explains_the_plans_the_refinement_hands_out():
    from cplus.robot import RobotTask, refine
    task = RobotTask.load(str(PAYLOAD / "payload.cp"), str(PAYLOAD / "scene.toml"))
    res = refine(task, "0")
    assert res.status.value == "found"
    why = res.store.excludes(res.first_history)
    assert why is not None and why.endswith(")") and "(at step " in why
    assert res.store.excludes(list(res.first_history.states)) == why
    assert res.store.excludes(res.history) is None
    with pytest.raises(TypeError) as e:
        res.store.excludes(res.first_states)
    assert str(e.value) == ("excludes() takes a History (such as result.history or result.first_history) or its "
                            "states (list(history.states)), not a list of StepState")
    with pytest.raises(TypeError, match=r"not int$"):
        res.store.excludes(3)


def test_the_readme_api_example_runs_as_written(capsys, monkeypatch):
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Python API"):]
    code = section[section.index("```python\n") + 10:section.index("```\n", section.index("```python\n") + 10)]
    assert "session.block_current()" in code and "state_values(0)" in code
    monkeypatch.chdir(ROOT)
    exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert out.startswith("1 {'lit': ") and "Solution 1:" in out
