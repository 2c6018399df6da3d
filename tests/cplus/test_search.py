"""The planner's search commits to a slow horizon (its goal becomes a unit clause) and takes
a new solver after a horizon without history was committed to: the answers never change."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from cplus import Domain
from cplus.planner import run_query
from cplus.program import QuerySpec
from cplus.sat import horizon
from cplus.sat.solver import SatSolver

ROOT = Path(__file__).resolve().parents[2]
CORPUS = ROOT / "tests" / "corpus"
CASES = [c for c in json.loads((CORPUS / "manifest.json").read_text())
         if c["expected"].get("num_models_exact") and c["query_label"] != "states"
         and c["expected"].get("num_models") and c["expected"]["num_models"] <= 200 and "benchmark" not in c["path"]]


@pytest.mark.parametrize("case", CASES[:12], ids=lambda c: c["id"])
def test_committing_to_every_horizon_keeps_lengths_and_counts(case, monkeypatch):
    d = Domain.load(str(CORPUS / "domains" / case["path"]))
    q = d.query(case["query_label"])
    if case["step_range"]["kind"] == "unspecified":   # CCALC answers it at maxstep 0: search 0..infinity here
        q = QuerySpec(q.label, 0, None, q.items, q.loc)
    # every budget runs out at once: the search commits to every horizon
    monkeypatch.setattr(SatSolver, "solve_limited", lambda self, assumptions, propagations: None)
    renewed = []
    original = horizon.QuerySession._renew

    def renew(self):
        renewed.append(self.stats[-1].maxstep)
        original(self)
    monkeypatch.setattr(horizon.QuerySession, "_renew", renew)
    committed = run_query(d.theory_for(q), q, solutions=0)
    monkeypatch.undo()
    plain = run_query(d.theory_for(q), q, solutions=0)
    assert committed.maxstep == plain.maxstep == case["expected"]["plan_length"]
    assert committed.failed == plain.failed
    assert renewed == committed.failed              # a new solver after each horizon without history
    assert sorted(h.key() for h in committed.histories) == sorted(h.key() for h in plain.histories)
    assert len(plain.histories) == case["expected"]["num_models"]


def test_a_session_with_assumptions_never_commits(monkeypatch):
    d = Domain.from_text(":- constants p :: inertialFluent; a :: exogenousAction.\na causes p.\n"
                         ":- query maxstep :: 0..3; 0: -p; maxstep: p.")
    monkeypatch.setattr(SatSolver, "solve_limited", lambda self, assumptions, propagations: None)
    s = horizon.QuerySession(d.theory, d.query("0"), commit=True)
    free = s.horizon.new_var()
    s.assumptions.append(free)
    assert not s.solve_at(0) and s.solve_at(1)
    assert not s._stale and s.horizon.solver.count == s.stats[-1].clauses
