"""The arithmetic-heavy benchmark domains plan as they should (their plans are checked step
by step against the arithmetic, so a wrong encoding cannot hide behind a right length)."""
from __future__ import annotations

from pathlib import Path

from cplus import Domain

DATA = Path(__file__).resolve().parent.parent.parent / "bench" / "data"


def test_tanks_are_the_jugs_puzzle_scaled_by_25():
    r = Domain.load(str(DATA / "tanks-200.cp")).solve("0")
    assert r.maxstep == 7        # the 8-5-3 puzzle's shortest solution
    h = r.histories[0]
    caps = {"a": 200, "b": 125, "c": 75}
    for t in range(7):
        before = {k: h.value(f"level({k})", t) for k in caps}
        after = {k: h.value(f"level({k})", t + 1) for k in caps}
        [(src, dst)] = [tuple(gc.args) for gc, v in h.actions[t].items() if v is True]
        moved = min(before[src], caps[dst] - before[dst])
        assert after[src] == before[src] - moved and after[dst] == before[dst] + moved
    assert (h.value("level(a)", 7), h.value("level(b)", 7)) == (100, 100)


def test_the_car_obeys_its_physics_and_the_school_zone():
    r = Domain.load(str(DATA / "car-300.cp")).solve("0")
    assert r.maxstep == 9
    h = r.histories[0]
    for t in range(9):
        pos, spd, clk = (h.value(c, t) for c in ("pos", "spd", "clk"))
        done = {gc.text: gc for gc, v in h.actions[t].items() if v is True}
        drives = [gc.args[0] for gc in done.values() if gc.decl.name == "drive"]
        if drives:
            (d,) = drives
            assert h.value("pos", t + 1) == pos + spd * d and h.value("clk", t + 1) == clk + d
            assert not (spd > 6 and pos + spd * d >= 120 and pos <= 180)
    assert (h.value("pos", 9), h.value("spd", 9)) == (300, 0) and h.value("clk", 9) <= 60
