"""A step whose changes the show statements leave out says so in the text output; a domain
that shows and hides nothing prints as CCALC does (no comment lines)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from cplus import Domain

ROOT = Path(__file__).resolve().parents[2]

SRC = """
:- constants ready, done :: inertialFluent; prepare, work, wait :: exogenousAction.
prepare causes ready.  work causes done.  nonexecutable work if -ready.
nonexecutable prepare & work.
:- query maxstep :: 2; 0: -ready & -done; 1: -done; maxstep: done.
"""


def text(extra: str) -> str:
    d = Domain.from_text(SRC + extra)
    return d.format(d.solve())


def test_a_step_whose_change_is_hidden_names_it():
    out = text(":- show done; work.")
    assert "0:\n\n% step 0 -> 1 changes only what the show statements leave out: prepare  ready\n\n1:\n" in out
    assert "ACTIONS:  work\n\n2:  done" in out


def test_a_domain_that_shows_everything_prints_as_ccalc():
    out = text("")
    assert "%" not in out and "ACTIONS:  prepare\n\n1:  ready" in out


def test_a_step_that_changes_nothing_says_so_when_something_is_hidden():
    d = Domain.from_text(SRC.replace("maxstep :: 2; 0: -ready & -done; 1: -done; maxstep: done.",
                                     "maxstep :: 1; 0: -ready & -done; 1: -ready & -done.") + ":- show done; ready.")
    out = d.format(d.solve(solutions=0))       # nothing happens, or only wait, which is not shown
    assert out.count("Solution ") == 2
    assert "0:\n\n% step 0 -> 1 changes nothing\n\n1:\n" in out
    assert "0:\n\n% step 0 -> 1 changes only what the show statements leave out: wait\n\n1:\n" in out


def test_the_payload_plan_says_why_its_first_step_exists():
    """`cplus plan domains/payload/payload.cp`: states 0 and 1 print alike; the step between
    them makes canCarry true, which the domain's show statement leaves out."""
    r = subprocess.run([sys.executable, "-m", "cplus", "plan", "domains/payload/payload.cp"], cwd=ROOT,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "\n% step 0 -> 1 changes only what the show statements leave out: canCarry\n" in r.stdout


def test_the_readme_says_so():
    readme = " ".join(" ".join(p.read_text(encoding="utf-8") for p in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]).split())
    assert "a comment line says what changed (`% step 0 -> 1 changes only what the show statements leave out: " \
           "canCarry`, or `changes nothing`)" in readme
