"""docs/api.md, the Python API's reference: its examples run as written (from the repository's
root, as the page says), and every public name of ``cplus``, ``cplus.robot`` and its four
packages is used in one of them."""
from __future__ import annotations

import doctest
import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
API = ROOT / "docs" / "api.md"
FACES = ["cplus", "cplus.robot", "cplus.robot.offline", "cplus.robot.execution", "cplus.robot.online",
         "cplus.robot.serving"]


def test_the_examples_run_as_written(monkeypatch):
    monkeypatch.chdir(ROOT)
    result = doctest.testfile(str(API), module_relative=False, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                              raise_on_error=False, verbose=False)
    assert result.attempted > 150 and result.failed == 0


def _example_source() -> str:
    parser = doctest.DocTestParser()
    return "\n".join(ex.source for ex in parser.get_examples(API.read_text(encoding="utf-8")))


@pytest.mark.parametrize("face", FACES)
def test_every_public_name_has_an_example(face):
    names = importlib.import_module(face).__all__
    code = _example_source()
    missing = [n for n in names if not re.search(rf"\b{re.escape(n)}\b", code)]
    assert not missing, f"docs/api.md has no example using {face}.{', '.join(missing)}"


def test_the_readme_links_it():
    assert "[docs/api.md](docs/api.md)" in (ROOT / "README.md").read_text(encoding="utf-8")
