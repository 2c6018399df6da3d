"""The benchmarks' random instances (bench/gen_instances.py): they load, have the plan their
construction promises, and are a function of the seed alone."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import Domain

ROOT = Path(__file__).resolve().parent.parent


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "bench" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


gen = _load("gen_instances")
peer_clingo = _load("peer_clingo")

# one small instance of each family (the seeds that make them)
SMALL = ["bw-15-s31", "spacecraft-8-1-s2", "ferryman-4-2-s2", "hanoi-3-3-s2", "car-80-s31"]


@pytest.mark.parametrize("name", SMALL)
def test_an_instance_has_a_plan_no_longer_than_its_walk(name):
    inst = gen.instance(name)
    result = Domain.from_text(inst.text, name).solve("0")
    assert result.maxstep is not None, f"{name}: no plan in 0..{inst.walk}"
    assert 1 <= result.maxstep <= inst.walk        # the goal is never the start
    if inst.length is not None:
        assert result.maxstep == inst.length


@pytest.mark.parametrize("family", ["ferryman", "hanoi"])
def test_the_searched_families_know_the_shortest_length(family):
    """Breadth-first search in the generator and the planner agree on the shortest plan."""
    checked = 0
    for seed in range(40):
        inst = gen.FAMILIES[family](seed)
        if inst.length is None or inst.length > 12:
            continue
        assert Domain.from_text(inst.text, inst.name).solve("0").maxstep == inst.length, inst.name
        checked += 1
        if checked == 4:
            break
    assert checked == 4


@settings(max_examples=25)
@given(seed=st.integers(0, 10 ** 6), family=st.sampled_from(sorted(gen.FAMILIES)))
def test_every_instance_loads_and_its_name_makes_it_again(seed, family):
    inst = gen.FAMILIES[family](seed)
    domain = Domain.from_text(inst.text, inst.name)
    query = domain.query("0")
    assert (query.lo, query.hi) == (0, inst.walk)
    assert gen.instance(inst.name) == inst
    assert inst.length is None or 1 <= inst.length <= inst.walk


def test_a_draw_is_a_function_of_its_seed():
    first, again, other = gen.draw(5, 10), gen.draw(5, 10), gen.draw(6, 10)
    assert first == again
    assert [i.name for i in first] != [i.name for i in other]
    assert [i.family for i in first] == list(gen.FAMILIES) * 2          # the families in turn
    assert [i.family for i in gen.draw(5, 3, ["hanoi"])] == ["hanoi"] * 3


def test_blocks_worlds_have_15_to_40_blocks():
    sizes = {int(gen.blocks_world(seed).name.split("-")[1]) for seed in range(60)}
    assert min(sizes) >= 15 and max(sizes) <= 40 and len(sizes) > 10


@pytest.mark.parametrize("bad", ["bw-15", "bw-16-s31", "rocket-3-s1", "hanoi-3-3-sx"])
def test_a_wrong_name_is_refused(bad):
    with pytest.raises(ValueError):
        gen.instance(bad)


def test_the_command_writes_the_files_and_refuses_an_unknown_family(tmp_path, capsys):
    assert gen.main([str(tmp_path / "out"), "--count", "3", "--seed", "9"]) == 0
    written = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert written == sorted(f"{i.name}.cp" for i in gen.draw(9, 3))
    assert "seed 9" in capsys.readouterr().out
    assert gen.main([str(tmp_path / "x"), "--family", "hanoi,rockets"]) == 2
    err = capsys.readouterr().err
    assert "unknown family: rockets" in err and len(err.strip().splitlines()) == 1


def test_the_peer_adapter_sums_contributions_per_action():
    """clingo 5 sums a set of tuples: the action must be part of each tuple, or two jets giving
    the same force would count once."""
    line = ("c_f_1_vel(GVAR_axis_1,VAR1+VAR2,t) :- VAR1=#sum{VAR3:contrib_vel(GVAR_axis_1,ACTION,VAR3,t-1),"
            "additiveconst_action(c_f_1_vel(GVAR_axis_1),ACTION),s_afValue(VAR3)}.")
    assert "#sum{VAR3,ACTION:contrib_vel(GVAR_axis_1,ACTION,VAR3,t-1)," in peer_clingo.rewrite(line)
    assert peer_clingo.rewrite("#show c_f_1_on(D,L,T).\n#show done/0.\n") == "% #show c_f_1_on(D,L,T).\n#show done/0.\n"
