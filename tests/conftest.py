"""Shared fixtures: where the conformance corpus lives (beside the checkout, never copied)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus"))


@pytest.fixture
def corpus() -> Path:
    if not (CORPUS / "manifest.json").is_file():
        pytest.fail(f"the conformance corpus is missing at {CORPUS} (set CPLUS_CORPUS)")
    return CORPUS
