"""`cplus run DOMAIN --brick r1=PORT --brick r2=PORT`: the whole job on bricks the user gives.

Two emulated bricks are served on ptys by this test (on a simulated clock, which `cplus run`
finds behind the ports and waits on, so the run does not depend on the machine's load);
`cplus run` must plan, refine, write its files and execute on exactly those bricks: each brick
ends up holding its robot's setpoints of the trajectory that `cplus run` wrote.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

import nxt_link
import trajectory as tj
from cplus.cli import main

pytestmark = pytest.mark.slow        # two ptys and the whole job

ROOT = Path(__file__).resolve().parent.parent


def test_cplus_run_executes_on_the_given_bricks(tmp_path, capsys):
    clock = nxt_link.SimClock()
    servers = [nxt_link.PtyBrickServer(nxt_link.BrickEmulator(nxt_link.EmulatorConfig(
        name=n, link=nxt_link.LinkParams.instant())), clock=clock)
        for n in ("r1", "r2")]
    for s in servers:
        s.start()
    out = tmp_path / "out"
    try:
        code = main(["run", str(ROOT / "domains" / "payload" / "payload.cp"), "--out", str(out),
                     "--brick", f"r1={servers[0].path}", "--brick", f"r2={servers[1].path}",
                     "--step-time", "0.5", "--points-per-step", "5"])
        err = capsys.readouterr().err
        assert code == 0, err
        assert f"r1={servers[0].path}" in err and "(emulated)" not in err
        traj = tj.load_trajectory(out / "trajectory.json")
        for server, robot in zip(servers, traj.robots):
            assert server.emulator.program.reference_rows() == [tuple(r) for r in robot.setpoints_deg.tolist()]
        log = json.loads((out / "execution.json").read_text())
        assert log.get("complete", True) is True
        assert [b["name"] for b in log["bricks"]] == ["r1", "r2"]
    finally:
        for s in servers:
            s.stop()
            assert s.error is None, s.error
