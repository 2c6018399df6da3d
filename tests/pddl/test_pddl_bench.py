"""bench/bench_ipc.py: the layouts of the IPC collections it reads, and one run of cplus on an
instance of domains/pddl (Fast Downward is not needed: it is the bench's own business)."""
from __future__ import annotations

import importlib.util

from pddl_support import DOMAINS, ROOT, need_up

need_up()

spec = importlib.util.spec_from_file_location("bench_ipc", ROOT / "bench" / "bench_ipc.py")
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def test_the_layouts_of_the_collections(tmp_path):
    one = tmp_path / "potassco"
    (one / "instances").mkdir(parents=True)
    (one / "domain.pddl").write_text("")
    for n in (10, 2, 1):
        (one / "instances" / f"instance-{n}.pddl").write_text("")
    assert [p.name for _, p in bench.instances(one)] == ["instance-1.pddl", "instance-2.pddl", "instance-10.pddl"]
    each = tmp_path / "each"
    (each / "instances").mkdir(parents=True)
    (each / "domains").mkdir()
    for n in (1, 2):
        (each / "instances" / f"instance-{n}.pddl").write_text("")
        (each / "domains" / f"domain-{n}.pddl").write_text("")
    assert [(d.name, p.name) for d, p in bench.instances(each)] == [("domain-1.pddl", "instance-1.pddl"),
                                                                     ("domain-2.pddl", "instance-2.pddl")]
    fd = tmp_path / "fd"
    fd.mkdir()
    for stem in ("p01", "p02"):
        (fd / f"{stem}.pddl").write_text("")
    (fd / "p01-domain.pddl").write_text("")
    (fd / "domain_p02.pddl").write_text("")
    assert [(d.name, p.name) for d, p in bench.instances(fd)] == [("p01-domain.pddl", "p01.pddl"),
                                                                  ("domain_p02.pddl", "p02.pddl")]


def test_a_run_of_cplus(tmp_path, capsys):
    out = tmp_path / "rows.json"
    assert bench.main(["--pair", str(DOMAINS / "blocks-domain.pddl"), str(DOMAINS / "blocks-problem.pddl"),
                       "--planners", "cplus", "--time-limit", "300", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "% cplus: 1/1 solved" in text
    import json
    rows = json.loads(out.read_text())
    assert rows[0]["status"] == "solved" and rows[0]["actions"] == 6 and rows[0]["steps"] == 6
