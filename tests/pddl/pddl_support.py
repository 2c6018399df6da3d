"""Shared by the PDDL tests: unified-planning is the optional extra ``up`` (CI installs it and
sets CPLUS_REQUIRE_UP, so that a missing install fails instead of skipping)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOMAINS = ROOT / "domains" / "pddl"


def need_up():
    if os.environ.get("CPLUS_REQUIRE_UP"):
        import unified_planning  # noqa: F401
    return pytest.importorskip("unified_planning")


def run(argv, capsys):
    from cplus.cli import main
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def validate_text(domain, problem, text):
    """Read an IPC plan printed by cplus back with unified-planning and validate it."""
    from unified_planning.engines import SequentialPlanValidator, ValidationResultStatus
    from unified_planning.io import PDDLReader
    reader = PDDLReader()
    task = reader.parse_problem(str(domain), str(problem))
    body = "\n".join(line for line in text.splitlines() if not line.startswith(";"))
    plan = reader.parse_plan_string(task, body)
    with SequentialPlanValidator() as v:
        return v.validate(task, plan).status is ValidationResultStatus.VALID
