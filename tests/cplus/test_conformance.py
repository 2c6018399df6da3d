"""Every case of the CCALC conformance corpus (tests/corpus, a copy of the Cplus2ASP-derived corpus, GPL-3) must pass.

A case loads its file, runs the query, and compares satisfiability, the plan length and,
when the manifest knows it exactly, the number of histories at that length (counted by
enumerating all of them, whatever the case asks to print).  The corpus stays outside the
project: it is read in place.
"""
from __future__ import annotations

import json

import pytest
from conftest import CORPUS

from cplus import Domain


def _cases():
    manifest = CORPUS / "manifest.json"
    if not manifest.is_file():
        return [pytest.param(None, id="corpus-missing")]
    return [pytest.param(c, id=c["id"]) for c in json.loads(manifest.read_text())]


@pytest.mark.parametrize("case", _cases())
def test_corpus_case(case, corpus):
    expected = case["expected"]
    domain = Domain.load(str(corpus / "domains" / case["path"]))
    exact = bool(expected.get("num_models_exact"))
    result = domain.solve(case["query_label"], solutions=0 if exact else 1, max_horizon=200)
    got = "SAT" if result.histories else "UNSAT"
    assert got == expected["result"]
    if got == "SAT":
        assert result.maxstep == expected["plan_length"]
    if exact:
        assert len(result.histories) == expected["num_models"]


def test_corpus_report(corpus, capsys):
    """Reports how many cases the manifest holds (all of them run above)."""
    cases = json.loads((corpus / "manifest.json").read_text())
    with capsys.disabled():
        print(f"\nconformance corpus: {len(cases)} cases "
              f"({sum(1 for c in cases if c.get('timing'))} public benchmarks)")
    assert len(cases) > 0
